#include "workbench/formats/ros2_bag.h"

#include <yaml-cpp/yaml.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/ros2_messages.h"
#include "workbench/formats/ros2_storage.h"
#include "workbench/formats/ros_common.h"

namespace furn {
namespace {

namespace fs = std::filesystem;

std::string SecondsText(int64_t time_ns) { return TimeText(time_ns * 1e-9); }

// The number after the last '_' of a file's stem (rosbag2 splits: x_0, x_1, ...).
int64_t SplitIndex(const fs::path& file) {
  const std::string stem = file.stem().string();
  const size_t underscore = stem.rfind('_');
  if (underscore == std::string::npos) return 0;
  try {
    return std::stoll(stem.substr(underscore + 1));
  } catch (const std::exception&) {
    return 0;
  }
}

constexpr const char* kConvertAdvice =
    "convert with 'ros2 bag convert' to sqlite3 or mcap without file or message compression "
    "(MCAP's compressed chunks are read)";

constexpr uintmax_t kMaxMetadataBytes = 1u << 20;

// A bag folder's rosbag2_bagfile_information, or nothing when its
// metadata.yaml is missing, not a regular file, over 1 MiB or not YAML.
std::optional<YAML::Node> BagInformation(const std::string& folder) {
  const fs::path metadata = fs::path(folder) / "metadata.yaml";
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(metadata, ec)) ||
      fs::file_size(metadata, ec) > kMaxMetadataBytes || ec)
    return std::nullopt;
  try {
    return YAML::Load(ReadFileBytes(metadata.string()))["rosbag2_bagfile_information"];
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// A bag whose metadata.yaml says its files or messages are compressed
// (rosbag2's compression_format / compression_mode) is refused as such.
void RefuseCompressedBag(const std::string& folder) {
  const std::optional<YAML::Node> info = BagInformation(folder);
  if (!info) return;  // the storage files decide
  std::string format, mode;
  try {
    if ((*info)["compression_format"]) format = (*info)["compression_format"].as<std::string>();
    if ((*info)["compression_mode"]) mode = (*info)["compression_mode"].as<std::string>();
  } catch (const std::exception&) {
    return;
  }
  Require(format.empty() && (mode.empty() || mode == "none" || mode == "NONE"),
          (fs::path(folder) / "metadata.yaml").string() + ": compressed storage (" +
              format.substr(0, 16) + ", mode " + mode.substr(0, 16) + ") is not read here; " +
              kConvertAdvice);
}

// Whether a file is a storage file of a bag: .db3 or .mcap.
bool IsStorageFile(const fs::path& file) {
  const std::string extension = FileExtension(file.string());
  return extension == "db3" || extension == "mcap";
}

// The storage files of a bag (.db3 or .mcap), in split order.
std::vector<std::string> BagFiles(const std::string& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    RequireRegularFile(path);
    Require(fs::exists(path, ec), path + ": does not exist");
    return {path};
  }
  RefuseCompressedBag(path);
  std::vector<fs::path> files;
  bool compressed_storage = false;
  for (const fs::directory_entry& entry : fs::directory_iterator(path, ec)) {
    const std::string name = entry.path().filename().string();
    if (IsStorageFile(entry.path())) files.push_back(entry.path());
    if (name.find(".db3.") != std::string::npos || name.find(".mcap.") != std::string::npos)
      compressed_storage = true;
  }
  Require(!ec, path + ": cannot list the bag folder (" + ec.message() + ")");
  Require(
      !files.empty(),
      path + (compressed_storage
                  ? std::string(": compressed storage files are not read here; ") + kConvertAdvice
                  : ": no .db3 or .mcap file (a ROS 2 bag folder holds metadata.yaml and "
                    "<name>_0.db3 or <name>_0.mcap)"));
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
    return std::make_pair(SplitIndex(a), a.string()) < std::make_pair(SplitIndex(b), b.string());
  });
  std::vector<std::string> paths;
  for (const fs::path& file : files) paths.push_back(file.string());
  return paths;
}

using StorageFiles = std::vector<std::unique_ptr<Ros2StorageReader>>;

TfBuffer ReadTf(StorageFiles& files, const std::string& path) {
  TfBuffer tf;
  for (auto& file : files) {
    file->ForEach(file->Ids({"/tf", "/tf_static", "tf", "tf_static"}, kRos2TfMessage),
                  [&](const Ros2Message& m) {
                    const std::string where =
                        path + " " + m.topic + " at " + SecondsText(m.time_ns);
                    const bool is_static = m.topic.find("tf_static") != std::string::npos;
                    for (const RosTransform& t : DecodeTfMessage(m.data, where))
                      tf.Add(t, is_static, where);
                  });
  }
  tf.Sort();
  return tf;
}

// The scan topic's type across the files: PointCloud2 or Image.
std::string ScanTopicType(const StorageFiles& files, const BagScanOptions& options) {
  std::string type;
  for (const auto& file : files) {
    for (const auto& [id, topic] : file->topics())
      if (topic.name == options.topic) type = topic.type;
  }
  Require(!type.empty(), options.bag_path + ": no topic " + options.topic);
  Require(type == kRos2PointCloud2 || type == kRos2Image,
          options.bag_path + ": topic " + options.topic + " is " + type + "; it must be " +
              kRos2PointCloud2 + " or " + kRos2Image);
  return type;
}

int ScanFiles(StorageFiles& files,
              const BagScanOptions& options,
              const TfBuffer& tf,
              const std::function<void(const BagScan&)>& each) {
  const std::string info_topic = CameraInfoTopic(options);
  const std::string type = ScanTopicType(files, options);
  BagScanAssembler scans(options, &tf, info_topic);
  int64_t total = 0;
  for (auto& file : files) total += file->Count(file->Ids({options.topic}));
  if (type == kRos2Image) {  // the first CameraInfo, for images recorded before it
    for (auto& file : files) {
      if (scans.has_camera()) break;
      file->ForEach(
          file->Ids({info_topic}, kRos2CameraInfo),
          [&](const Ros2Message& m) {
            const std::string where = options.bag_path + " " + m.topic;
            scans.OnCameraInfo(DecodeCameraInfo(m.data, where), where);
          },
          /*limit=*/1);
    }
  }
  int count = 0;
  for (auto& file : files) {
    file->ForEach(file->Ids({options.topic, info_topic}), [&](const Ros2Message& m) {
      const std::string where = options.bag_path + " " + m.topic + " at " + SecondsText(m.time_ns);
      const double bag_time = m.time_ns * 1e-9;
      if (m.topic == info_topic && m.topic != options.topic) {
        Require(m.type == kRos2CameraInfo, where + ": " + m.type + " is not " + kRos2CameraInfo);
        scans.OnCameraInfo(DecodeCameraInfo(m.data, where), where);
        return;
      }
      BagScan scan = type == kRos2Image
                         ? scans.OnImage(DecodeImage(m.data, where), m.topic, bag_time, where)
                         : scans.OnCloud(DecodePointCloud2(m.data, where), m.topic, bag_time);
      scan.total = static_cast<int>(std::min<int64_t>(total, INT_MAX));
      each(scan);
      ++count;
    });
  }
  return count;
}

StorageFiles OpenBagFiles(const std::string& path) {
  StorageFiles files;
  for (const std::string& file : BagFiles(path)) files.push_back(OpenRos2Storage(file));
  return files;
}

}  // namespace

bool IsRos2Bag(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec) || IsStorageFile(path);
}

int ForEachRos2BagScan(const BagScanOptions& options,
                       const std::function<void(const BagScan&)>& each) {
  CheckBagScanOptions(options);
  StorageFiles files = OpenBagFiles(options.bag_path);
  const TfBuffer tf = options.world_frame.empty() ? TfBuffer() : ReadTf(files, options.bag_path);
  return ScanFiles(files, options, tf, each);
}

void ForEachRos2Message(const std::string& bag,
                        const std::function<void(const Ros2Message&)>& each) {
  for (auto& file : OpenBagFiles(bag)) {
    std::set<int64_t> all;
    for (const auto& [id, topic] : file->topics()) all.insert(id);
    file->ForEach(all, each);
  }
}

// ---------------------------------------------------------------- writing

namespace {

// What metadata.yaml says of a bag.
struct BagSummary {
  struct TopicCount {
    Ros2Topic topic;
    int64_t messages = 0;
  };
  Ros2Storage storage = Ros2Storage::kSqlite3;
  std::string file_name;
  std::map<std::string, TopicCount> topics;
  int64_t first_ns = INT64_MAX, last_ns = INT64_MIN, messages = 0;
};

// Whether the file starts with `magic` (SQLite's or MCAP's).
bool StartsWith(const fs::path& file, const std::string& magic) {
  std::ifstream in(file, std::ios::binary);
  std::string head(magic.size(), '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  return in && head == magic;
}

// The storage files metadata.yaml names; empty when it is not a readable
// rosbag2 metadata file.
std::set<std::string> NamedBagFiles(const std::string& folder) {
  const std::optional<YAML::Node> info = BagInformation(folder);
  if (!info) return {};
  std::set<std::string> names;
  try {
    const YAML::Node files = (*info)["relative_file_paths"];
    if (!files.IsSequence()) return {};
    for (const YAML::Node& file : files) names.insert(file.as<std::string>());
  } catch (const std::exception&) {
    return {};
  }
  return names;
}

// A folder this writer may replace: a ROS 2 bag recognised by its content —
// a readable metadata.yaml and, beside it, only the regular .db3 or .mcap
// files it names (with SQLite's or MCAP's signature) and a .db3's journal.
// Names alone decide nothing: a subfolder called photos.db3 is not a bag's.
bool IsBagFolder(const std::string& path) {
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(path, ec))) return false;
  const std::set<std::string> named = NamedBagFiles(path);
  if (named.empty()) return false;
  for (const fs::directory_entry& entry : fs::directory_iterator(path, ec)) {
    const std::string name = entry.path().filename().string();
    if (!fs::is_regular_file(entry.symlink_status(ec))) return false;
    if (name == "metadata.yaml") continue;
    const bool journal = name.size() > 8 && name.substr(name.size() - 8) == "-journal" &&
                         named.count(name.substr(0, name.size() - 8));
    const std::string extension = entry.path().extension().string();
    const bool storage =
        named.count(name) &&
        ((extension == ".db3" && StartsWith(entry.path(), std::string("SQLite format 3\0", 16))) ||
         (extension == ".mcap" && StartsWith(entry.path(), "\x89MCAP0\r\n")));
    if (!journal && !storage) return false;
  }
  return !ec;
}

// A writer's folder `<out>.partial-<pid>` left by a process that no longer
// runs (killed mid-write): removed when it holds only what the writer makes.
void RemoveDeadWritersFolders(const std::string& out) {
  const fs::path target(out);
  const std::string prefix = target.filename().string() + ".partial-";
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(parent, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string pid_text = name.substr(prefix.size());
    if (pid_text.empty() || pid_text.size() > 9 ||
        pid_text.find_first_not_of("0123456789") != std::string::npos)
      continue;
    const pid_t pid = static_cast<pid_t>(std::stol(pid_text));
    if (pid == getpid() || kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive, or not ours
    const std::string db3 = target.filename().string() + "_0.db3";
    const std::string mcap = target.filename().string() + "_0.mcap";
    bool only_ours = fs::is_directory(entry.symlink_status(ec));
    for (const fs::directory_entry& file : fs::directory_iterator(entry.path(), ec)) {
      const std::string file_name = file.path().filename().string();
      only_ours = only_ours && fs::is_regular_file(file.symlink_status(ec)) &&
                  (file_name == "metadata.yaml" || file_name == db3 || file_name == mcap ||
                   file_name == db3 + "-journal" || file_name.rfind("metadata.yaml.", 0) == 0);
    }
    if (only_ours) fs::remove_all(entry.path(), ec);
  }
}

std::string MetadataYaml(const BagSummary& bag) {
  const int64_t start = bag.messages > 0 ? bag.first_ns : 0;
  const int64_t duration = bag.messages > 0 ? bag.last_ns - bag.first_ns : 0;
  YAML::Emitter yaml;
  yaml << YAML::BeginMap << YAML::Key << "rosbag2_bagfile_information" << YAML::Value
       << YAML::BeginMap;
  yaml << YAML::Key << "version" << YAML::Value << 5;
  yaml << YAML::Key << "storage_identifier" << YAML::Value << Ros2StorageName(bag.storage);
  yaml << YAML::Key << "duration" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds"
       << YAML::Value << duration << YAML::EndMap;
  yaml << YAML::Key << "starting_time" << YAML::Value << YAML::BeginMap << YAML::Key
       << "nanoseconds_since_epoch" << YAML::Value << start << YAML::EndMap;
  yaml << YAML::Key << "message_count" << YAML::Value << bag.messages;
  yaml << YAML::Key << "topics_with_message_count" << YAML::Value << YAML::BeginSeq;
  for (const auto& [name, topic] : bag.topics) {
    yaml << YAML::BeginMap << YAML::Key << "topic_metadata" << YAML::Value << YAML::BeginMap;
    yaml << YAML::Key << "name" << YAML::Value << name;
    yaml << YAML::Key << "type" << YAML::Value << topic.topic.type;
    yaml << YAML::Key << "serialization_format" << YAML::Value << topic.topic.serialization;
    yaml << YAML::Key << "offered_qos_profiles" << YAML::Value << YAML::DoubleQuoted
         << topic.topic.offered_qos_profiles;
    yaml << YAML::EndMap << YAML::Key << "message_count" << YAML::Value << topic.messages
         << YAML::EndMap;
  }
  yaml << YAML::EndSeq;
  yaml << YAML::Key << "compression_format" << YAML::Value << YAML::DoubleQuoted << "";
  yaml << YAML::Key << "compression_mode" << YAML::Value << YAML::DoubleQuoted << "";
  yaml << YAML::Key << "relative_file_paths" << YAML::Value << YAML::BeginSeq << bag.file_name
       << YAML::EndSeq;
  yaml << YAML::Key << "files" << YAML::Value << YAML::BeginSeq << YAML::BeginMap;
  yaml << YAML::Key << "path" << YAML::Value << bag.file_name;
  yaml << YAML::Key << "starting_time" << YAML::Value << YAML::BeginMap << YAML::Key
       << "nanoseconds_since_epoch" << YAML::Value << start << YAML::EndMap;
  yaml << YAML::Key << "duration" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds"
       << YAML::Value << duration << YAML::EndMap;
  yaml << YAML::Key << "message_count" << YAML::Value << bag.messages;
  yaml << YAML::EndMap << YAML::EndSeq << YAML::EndMap << YAML::EndMap;
  return std::string(yaml.c_str()) + "\n";
}

}  // namespace

struct Ros2BagWriter::Impl {
  std::string out, partial;
  std::unique_ptr<Ros2StorageWriter> file;
  BagSummary summary;
  bool finished = false;

  void Write(const Ros2Topic& topic, int64_t time_ns, const std::vector<uint8_t>& cdr) {
    auto found = summary.topics.find(topic.name);
    if (found == summary.topics.end())
      found = summary.topics.emplace(topic.name, BagSummary::TopicCount{topic, 0}).first;
    Require(found->second.topic.type == topic.type,
            out + ": topic " + topic.name + " written as " + found->second.topic.type + " and " +
                topic.type);
    file->Write(found->second.topic, time_ns, cdr);
    ++found->second.messages;
    ++summary.messages;
    summary.first_ns = std::min(summary.first_ns, time_ns);
    summary.last_ns = std::max(summary.last_ns, time_ns);
  }
};

Ros2BagWriter::Ros2BagWriter(const std::string& out,
                             Ros2Storage storage,
                             McapCompression compression)
    : impl_(std::make_unique<Impl>()) {
  std::string trimmed = out;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  std::error_code ec;
  Require(!fs::exists(trimmed, ec) || IsBagFolder(trimmed),
          out + ": exists and is not a ROS 2 bag folder; a ROS 2 bag is written as a new folder");
  impl_->out = trimmed;
  RemoveDeadWritersFolders(trimmed);
  impl_->partial = trimmed + ".partial-" + std::to_string(getpid());
  impl_->summary.storage = storage;
  impl_->summary.file_name =
      fs::path(trimmed).filename().string() + "_0." + Ros2StorageExtension(storage);
  fs::remove_all(impl_->partial, ec);
  Require(fs::create_directories(impl_->partial, ec) && !ec,
          out + ": cannot create the bag folder " + impl_->partial + " (" + ec.message() + ")");
  impl_->file =
      CreateRos2Storage(impl_->partial + "/" + impl_->summary.file_name, storage, compression);
}

Ros2BagWriter::~Ros2BagWriter() {
  if (impl_->finished) return;
  impl_->file.reset();
  std::error_code ec;
  fs::remove_all(impl_->partial, ec);
}

void Ros2BagWriter::Write(const std::string& topic,
                          const std::string& type,
                          int64_t time_ns,
                          const std::vector<uint8_t>& cdr) {
  Ros2Topic declared;
  declared.name = topic;
  declared.type = type;
  declared.offered_qos_profiles = Ros2OfferedQos(topic == "/tf_static" || topic == "tf_static");
  impl_->Write(declared, time_ns, cdr);
}

void Ros2BagWriter::Write(const Ros2Message& message) {
  if (message.declaration == nullptr)
    return Write(message.topic, message.type, message.time_ns, message.data);
  impl_->Write(*message.declaration, message.time_ns, message.data);
}

int64_t Ros2BagWriter::Finish() {
  impl_->file->Finish();
  impl_->file.reset();
  WriteFileAtomically(impl_->partial + "/metadata.yaml", MetadataYaml(impl_->summary));
  std::error_code ec;
  if (fs::exists(impl_->out, ec)) {
    Require(IsBagFolder(impl_->out), impl_->out + ": exists and is not a ROS 2 bag folder");
    fs::remove_all(impl_->out, ec);
  }
  fs::rename(impl_->partial, impl_->out, ec);
  Require(!ec, impl_->out + ": cannot move the finished bag into place (" + ec.message() + ")");
  impl_->finished = true;
  return impl_->summary.messages;
}

namespace {

int64_t Nanoseconds(double seconds, const std::string& where) {
  const auto [sec, nanosec] = Ros2Time(seconds, where);
  return int64_t{sec} * 1000000000 + nanosec;
}

// The storage of a bag's first file, and its MCAP chunks' compression: what
// a copy of it is written as (the folder listed once).
std::pair<Ros2Storage, McapCompression> StorageOf(const std::string& bag) {
  const std::string first = BagFiles(bag).front();
  if (FileExtension(first) != "mcap") return {Ros2Storage::kSqlite3, McapCompression::kZstd};
  return {Ros2Storage::kMcap, McapReader::FirstChunkCompression(first)};
}

std::string CheckedInput(const std::string& in_bag, const std::string& out_bag) {
  std::error_code ec_in, ec_out;
  const fs::path in = fs::weakly_canonical(in_bag, ec_in);
  const fs::path out = fs::weakly_canonical(out_bag, ec_out);
  Require(ec_in || ec_out || (in != out && in.parent_path() != out),
          "--out-bag " + out_bag + " must not be the input bag or its folder");
  return in_bag;
}

}  // namespace

Ros2DetectionWriter::Ros2DetectionWriter(const std::string& in_bag,
                                         const std::string& out_bag,
                                         std::string world_frame,
                                         std::string marker_topic)
    : in_bag_(CheckedInput(in_bag, out_bag)),
      world_frame_(std::move(world_frame)),
      marker_topic_(std::move(marker_topic)),
      format_(StorageOf(in_bag_)),
      out_(out_bag, format_.first, format_.second) {}

Ros2DetectionWriter::~Ros2DetectionWriter() = default;

void Ros2DetectionWriter::Add(const BagScan& scan,
                              const DetectionResult& result,
                              const TrainedModel& model) {
  RosHeader header;
  header.stamp = scan.stamp > 0 ? scan.stamp : scan.bag_time;
  header.frame_id = MarkerFrame(scan, world_frame_);
  const Eigen::Isometry3d frame_from_world = FrameFromWorld(scan, result);
  const int64_t time_ns = Nanoseconds(scan.bag_time, scan.loaded.description);
  Nanoseconds(header.stamp, scan.loaded.description);  // a stamp ROS 2 can carry
  out_.Write(marker_topic_,
             kRos2MarkerArray,
             time_ns,
             EncodeMarkerArray(DetectionMarkers(result, model, header, frame_from_world)));
  out_.Write(marker_topic_ + "_3d",
             kRos2Detection3DArray,
             time_ns,
             EncodeDetection3DArray(header, DetectionBoxes(result, model, frame_from_world)));
}

void Ros2DetectionWriter::Finish() {
  ForEachRos2Message(in_bag_, [&](const Ros2Message& m) {
    if (m.topic == marker_topic_ || m.topic == marker_topic_ + "_3d") return;  // a rerun's
    out_.Write(m);
  });
  out_.Finish();
}

void Ros2FrameWriter::Write(const RoomRecord& room,
                            const FrameRecord& frame,
                            const std::string& where) {
  const RecordedFrame recorded = RecordFrame(room, frame, frames_, where);
  const int64_t time_ns = Nanoseconds(recorded.stamp, where);
  if (frames_ == 0)  // once, transient local: a late subscriber still gets it
    out_.Write(
        "/tf_static", kRos2TfMessage, time_ns, EncodeTfMessage({recorded.camera_from_optical}));
  out_.Write("/tf", kRos2TfMessage, time_ns, EncodeTfMessage({recorded.world_from_camera}));
  out_.Write(
      "/camera/depth/camera_info", kRos2CameraInfo, time_ns, EncodeCameraInfo(recorded.info));
  out_.Write("/camera/depth/image_raw", kRos2Image, time_ns, EncodeImage(recorded.depth));
  out_.Write("/camera/depth/ids", kRos2Image, time_ns, EncodeImage(recorded.ids));
  out_.Write(
      "/furnidet/ground_truth", kRos2MarkerArray, time_ns, EncodeMarkerArray(recorded.truth));
  ++frames_;
}

int Ros2FrameWriter::Finish() {
  out_.Finish();
  return frames_;
}

int ForEachScanInBag(const BagScanOptions& options,
                     const std::function<void(const BagScan&)>& each) {
  std::error_code ec;  // a symlink loop or an unreadable folder, named as such
  static_cast<void>(fs::status(options.bag_path, ec));
  Require(!ec || ec == std::errc::no_such_file_or_directory,
          options.bag_path + ": cannot read (" + ec.message() + ")");
  return IsRos2Bag(options.bag_path) ? ForEachRos2BagScan(options, each)
                                     : ForEachBagScan(options, each);
}

std::unique_ptr<DetectionBagSink> OpenDetectionBag(const std::string& in_bag,
                                                   const std::string& out_bag,
                                                   const std::string& world_frame) {
  if (IsRos2Bag(in_bag)) return std::make_unique<Ros2DetectionWriter>(in_bag, out_bag, world_frame);
  return std::make_unique<BagMarkerWriter>(in_bag, out_bag, world_frame);
}

std::unique_ptr<FrameBagSink> OpenFrameBag(const std::string& out_bag, Ros2Storage storage) {
  if (FileExtension(out_bag) == "bag") return std::make_unique<FrameBagWriter>(out_bag);
  return std::make_unique<Ros2FrameWriter>(out_bag, storage);
}

}  // namespace furn

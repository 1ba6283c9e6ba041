#include "workbench/pipelines/convert_nyu.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "renderers/depth_frame.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/mat_file.h"

namespace fs = std::filesystem;

namespace furn {

bool IsNyuHeldOut(int labelled_index) {
  for (const auto& [first, last] : kNyuHeldOutRanges) {
    if (labelled_index >= first && labelled_index <= last) return true;
  }
  return false;
}

void NyuConvertOptions::Check() const {
  Require(!source_dir.empty() && !splits_path.empty() && !out_dir.empty(),
          "convert-nyu: --source, --splits and --out are needed");
  Require(max_frames >= 0,
          "convert-nyu: --max-frames " + std::to_string(max_frames) + " must be >= 0");
  Require(dequantise_radius >= 0 && dequantise_radius <= 10,
          "convert-nyu: --dequantise-radius " + std::to_string(dequantise_radius) +
              " must be in 0..10 pixels");
  derive.Check();
}

namespace {

constexpr int kNyuLabelledFrames = 1449;

// The official train split: trainNdxs (1-based labelled indices), checked to
// be whole numbers in 1..1449 that the test split does not also name.
std::vector<int> TrainIndices(const std::string& splits_path) {
  const MatArrays arrays = ReadMatFile(splits_path);
  for (const char* name : {"trainNdxs", "testNdxs"}) {
    if (!arrays.count(name))
      throw InputError(splits_path + ": no variable '" + name + "' (NYU's splits.mat holds both)");
  }
  std::set<int> test;
  for (double value : arrays.at("testNdxs").values) test.insert(static_cast<int>(value));
  std::set<int> train;
  for (double value : arrays.at("trainNdxs").values) {
    const int index = static_cast<int>(value);
    if (index != value || index < 1 || index > kNyuLabelledFrames)
      throw InputError(splits_path + ": trainNdxs value " + std::to_string(value) +
                       " is not a labelled index in 1.." + std::to_string(kNyuLabelledFrames));
    if (test.count(index))
      throw InputError(splits_path + ": index " + std::to_string(index) +
                       " is in both trainNdxs and testNdxs");
    if (!IsNyuHeldOut(index)) train.insert(index);
  }
  return {train.begin(), train.end()};
}

// Every k-th index, so a small conversion still spans the split's rooms.
std::vector<int> EveryKth(const std::vector<int>& indices, int max_frames) {
  if (max_frames == 0 || static_cast<int>(indices.size()) <= max_frames) return indices;
  std::vector<int> chosen;
  const double step = static_cast<double>(indices.size()) / max_frames;
  for (int k = 0; k < max_frames; ++k) chosen.push_back(indices[static_cast<size_t>(k * step)]);
  return chosen;
}

// The PNG's size from its IHDR, read before decoding: the image decoded is
// never larger than a NYU frame.
void RequireNyuPngSize(const std::string& path) {
  RequireRegularFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read (missing; is --source a NYU checkout?)");
  unsigned char header[24] = {};
  in.read(reinterpret_cast<char*>(header), sizeof header);
  const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (in.gcount() != 24 || !std::equal(signature, signature + 8, header) ||
      std::string(reinterpret_cast<char*>(header + 12), 4) != "IHDR")
    throw InputError(path + ": not a PNG file");
  auto be32 = [&](int at) {
    return (uint32_t{header[at]} << 24) | (uint32_t{header[at + 1]} << 16) |
           (uint32_t{header[at + 2]} << 8) | header[at + 3];
  };
  if (be32(16) != kNyuWidth || be32(20) != kNyuHeight)
    throw InputError(path + ": " + std::to_string(be32(16)) + "x" + std::to_string(be32(20)) +
                     "; NYU labelled frames are 640x480");
}

// An 8-bit single-channel NYU image, un-mirrored.
cv::Mat ReadNyuPng(const std::string& path) {
  RequireNyuPngSize(path);
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty() || image.type() != CV_8UC1)
    throw InputError(path + ": must be an 8-bit single-channel PNG");
  cv::flip(image, image, 1);
  return image;
}

struct NyuFrameFiles {
  int index = 0;  // labelled, 1-based
  std::string depth, labels, rgb;
};

NyuFrameFiles FilesOf(const std::string& source_dir, int index) {
  const fs::path data = fs::path(source_dir) / "data";
  const std::string name = std::to_string(index - 1);  // file k is labelled index k + 1
  return {index,
          (data / "nyu_depths" / (name + ".png")).string(),
          (data / "nyu_labels40" / (name + ".png")).string(),
          (data / "nyu_images" / (name + ".jpg")).string()};
}

std::string ScanId(int index) {
  char id[32];
  std::snprintf(id, sizeof id, "nyu-%04d", index);
  return id;
}

nlohmann::ordered_json ObjectJson(const NyuInstance& instance) {
  std::string note = "NYU-40 class " + std::to_string(instance.nyu_class) + ", " +
                     std::to_string(instance.pixels) + " px, visible-part centre";
  if (!instance.ignored.empty()) note += "; ignored: " + instance.ignored;
  auto round3 = [](double v) { return std::round(v * 1000) / 1000; };
  nlohmann::ordered_json object = {{"class", ClassName(instance.furniture_class)},
                                   {"x", round3(instance.x)},
                                   {"y", round3(instance.y)},
                                   {"yaw", nullptr},
                                   {"size",
                                    {round3(std::max(0.05, instance.size.x())),
                                     round3(std::max(0.05, instance.size.y())),
                                     round3(std::max(0.05, instance.size.z()))}},
                                   {"note", note}};
  // Ignored: above 0 (an object in view: a detection on it is neither right
  // nor wrong) and below what an evaluation counts (0.25 by default).
  if (!instance.ignored.empty()) object["visibility"] = 0.1;
  return object;
}

nlohmann::ordered_json ScanJson(const NyuFrameFiles& files, const NyuFrameLabels& labels) {
  nlohmann::ordered_json frame = nlohmann::ordered_json::array();
  const Eigen::Matrix4d m = labels.world_from_camera.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) frame.push_back(std::round(m(r, c) * 1e6) / 1e6);
  }
  nlohmann::ordered_json objects = nlohmann::ordered_json::array();
  for (const NyuInstance& instance : labels.instances) objects.push_back(ObjectJson(instance));
  char intrinsics[96];
  std::snprintf(
      intrinsics, sizeof intrinsics, "%.3f,%.3f,%.2f,%.2f", kNyuFx, kNyuFy, kNyuCx, kNyuCy);
  return {{"id", ScanId(files.index)},
          {"depth", "depth/" + ScanId(files.index) + ".png"},
          {"intrinsics", intrinsics},
          {"depth_scale", 1000},
          {"source",
           "NYU Depth V2 labelled frame " + std::to_string(files.index) +
               " (official train split), via markshih91/refinenet_pytorch data/"
               "nyu_depths/" +
               std::to_string(files.index - 1) + ".png"},
          {"licence", "NYU Depth V2: research use; not redistributed"},
          {"label_frame", frame},
          {"objects", objects}};
}

}  // namespace

float DequantisedNyuDepth(const std::vector<uint8_t>& steps, int u, int v, int radius) {
  const int centre = steps[static_cast<size_t>(v) * kNyuWidth + u];
  if (centre == 0) return 0;  // below the first step: no depth there
  int sum = 0, count = 0;
  for (int y = std::max(0, v - radius); y <= std::min(kNyuHeight - 1, v + radius); ++y) {
    for (int x = std::max(0, u - radius); x <= std::min(kNyuWidth - 1, u + radius); ++x) {
      const int value = steps[static_cast<size_t>(y) * kNyuWidth + x];
      if (value != 0 && std::abs(value - centre) <= 1) {
        sum += value;
        ++count;
      }
    }
  }
  return static_cast<float>((static_cast<double>(sum) / count + 0.5) * kNyuDepthStep);
}

namespace {

DepthFrame DepthOf(const cv::Mat& depth_8bit, int radius, std::vector<float>* metres) {
  const std::vector<uint8_t> steps(depth_8bit.datastart, depth_8bit.dataend);
  DepthFrame frame;
  frame.Resize(kNyuWidth, kNyuHeight);
  frame.normals.clear();
  for (int v = 0; v < kNyuHeight; ++v) {
    for (int u = 0; u < kNyuWidth; ++u)
      frame.depth[frame.Index(u, v)] = DequantisedNyuDepth(steps, u, v, radius);
  }
  *metres = frame.depth;
  return frame;
}

// The frame's colour image with its floor tinted and its instances outlined
// in their class colour (targets solid, ignored ones thin), for checking the
// derived labels by eye.
void WriteOverlay(const NyuFrameFiles& files,
                  const cv::Mat& labels,
                  const NyuFrameLabels& derived,
                  const std::string& path) {
  cv::Mat rgb;
  if (fs::is_regular_file(files.rgb) && fs::file_size(files.rgb) < (uint64_t{16} << 20))
    rgb = cv::imread(files.rgb, cv::IMREAD_COLOR);
  if (rgb.empty() || rgb.cols != kNyuWidth || rgb.rows != kNyuHeight) {
    rgb = cv::Mat(kNyuHeight, kNyuWidth, CV_8UC3, cv::Scalar(60, 60, 60));
  } else {
    cv::flip(rgb, rgb, 1);
  }
  for (int v = 0; v < kNyuHeight; ++v) {
    for (int u = 0; u < kNyuWidth; ++u) {
      cv::Vec3b& pixel = rgb.at<cv::Vec3b>(v, u);
      if (labels.at<uint8_t>(v, u) + 1 == 2) pixel = pixel / 2 + cv::Vec3b(0, 100, 0);  // floor
    }
  }
  // BGR per class: chair, armchair, table, sideboard, sofa.
  const cv::Scalar colours[] = {
      {0, 200, 255}, {255, 120, 0}, {0, 0, 255}, {255, 0, 255}, {200, 200, 0}};
  for (const NyuInstance& instance : derived.instances) {
    cv::Mat mask = cv::Mat::zeros(kNyuHeight, kNyuWidth, CV_8UC1);
    for (int i : instance.pixel_indices) mask.at<uint8_t>(i / kNyuWidth, i % kNyuWidth) = 255;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    const cv::Scalar colour = instance.ignored.empty()
                                  ? colours[static_cast<int>(instance.furniture_class) % 5]
                                  : cv::Scalar(160, 160, 160);
    cv::drawContours(rgb, contours, -1, colour, instance.ignored.empty() ? 3 : 1);
    const cv::Rect box = cv::boundingRect(mask);
    char text[64];
    std::snprintf(
        text, sizeof text, "%s %.1fm", ClassName(instance.furniture_class), instance.range_m);
    cv::putText(rgb, text, box.tl() + cv::Point(2, 16), cv::FONT_HERSHEY_SIMPLEX, 0.5, colour, 2);
  }
  if (!cv::imwrite(path, rgb)) throw InputError(path + ": cannot write the overlay");
}

// What the conversion did and the rules it used, beside the labels.
std::string ReadmeText(const NyuConvertOptions& options, const NyuConvertSummary& summary) {
  std::ostringstream text;
  text << "# NYU Depth V2 labelled frames as a furnidet real set\n\n"
       << "Written by `workbench dataset convert-nyu` from " << options.source_dir << " and "
       << options.splits_path << ". Research use only (NYU Depth V2's terms): do not commit or "
       << "redistribute this folder.\n\n"
       << "- train-split frames (held-out ranges 1330-1350 and 1400-1420 removed): "
       << summary.train_frames << "\n- converted: " << summary.frames
       << "\n- left out (no trusted floor): " << summary.frames_left_out << "\n";
  for (const auto& [reason, count] : summary.left_out_reasons)
    text << "  - " << reason << ": " << count << "\n";
  text << "- instances: " << summary.targets << " targets, " << summary.ignored
       << " ignored (visibility 0.1; see each object's note)\n\n"
       << "Rules and label noise: docs/real-scans.md, \"NYU Depth V2\".\n";
  return text.str();
}

void ConvertFrame(const NyuFrameFiles& files,
                  const NyuConvertOptions& options,
                  const std::string& dir,
                  NyuConvertSummary* summary,
                  nlohmann::ordered_json* scans) {
  const cv::Mat depth_8bit = ReadNyuPng(files.depth);
  const cv::Mat labels = ReadNyuPng(files.labels);
  std::vector<float> metres;
  const DepthFrame depth = DepthOf(depth_8bit, options.dequantise_radius, &metres);
  const std::vector<uint8_t> label_values(labels.datastart, labels.dataend);
  const NyuFrameLabels derived = DeriveNyuLabels(metres, label_values, options.derive);
  if (options.overlays)
    WriteOverlay(files, labels, derived, dir + "/overlays/" + ScanId(files.index) + ".png");
  if (!derived.usable) {
    ++summary->frames_left_out;
    ++summary->left_out_reasons[derived.reason];
    return;
  }
  WriteDepthPng(depth, dir + "/depth/" + ScanId(files.index) + ".png");
  for (const NyuInstance& instance : derived.instances)
    ++(instance.ignored.empty() ? summary->targets : summary->ignored);
  ++summary->frames;
  scans->push_back(ScanJson(files, derived));
}

}  // namespace

NyuConvertSummary ConvertNyu(const NyuConvertOptions& options) {
  options.Check();
  Require(!fs::exists(options.out_dir),
          options.out_dir + ": exists; convert-nyu writes a new folder (remove it first)");
  const std::vector<int> train = TrainIndices(options.splits_path);
  NyuConvertSummary summary;
  summary.train_frames = static_cast<int>(train.size());
  const std::vector<int> chosen = EveryKth(train, options.max_frames);
  WriteDirectoryAtomically(options.out_dir, [&](const std::string& dir) {
    MakeDirectories(dir + "/depth", "depth folder");
    if (options.overlays) MakeDirectories(dir + "/overlays", "overlay folder");
    nlohmann::ordered_json scans = nlohmann::ordered_json::array();
    Progress progress("convert-nyu", chosen.size(), "frames");
    for (int index : chosen) {
      ConvertFrame(FilesOf(options.source_dir, index), options, dir, &summary, &scans);
      progress.Advance();
    }
    progress.Finish();
    const nlohmann::ordered_json set = {
        {"format", "furnidet-real-set"}, {"version", 2}, {"scans", scans}};
    WriteFileAtomically(dir + "/labels.json", set.dump(1) + "\n");
    WriteFileAtomically(dir + "/README.md", ReadmeText(options, summary));
  });
  return summary;
}

}  // namespace furn

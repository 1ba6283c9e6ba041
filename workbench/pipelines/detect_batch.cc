#include "workbench/pipelines/detect_batch.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "core/util/text.h"
#include "reports/detection_debug.h"
#include "workbench/formats/detection_output.h"
#include "workbench/formats/options_file.h"
#include "workbench/formats/ros2_bag.h"
#include "workbench/pipelines/model_info.h"

namespace furn {
namespace {

void PrintDetections(const LoadedScan& scan, const DetectionResult& result) {
  std::fprintf(stderr, "%s: %zu detections", scan.description.c_str(), result.detections.size());
  for (const Detection& d : result.detections)
    std::fprintf(stderr, "\n  %s", DetectionLine(d).c_str());
  std::fprintf(stderr, "\n");
}

// JSON (lines) to --out, else to stdout unless quiet.
void Emit(const std::string& text, const DetectRunOptions& run) {
  if (!run.out.empty()) {
    WriteFileAtomically(run.out, text);
  } else if (!run.quiet) {
    std::fputs(text.c_str(), stdout);
  }
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

void Explain(const std::string& description,
             const DetectionResult& result,
             const Detector& detector) {
  std::fprintf(stderr, "%s: ", description.c_str());
  std::fputs(ExplainDetection(result, detector.model()).c_str(), stderr);
}

void PrintStageTimes(const DetectionResult& result,
                     const std::map<DetectionStage, std::vector<double>>& stage_times,
                     int repeat) {
  std::fprintf(stderr,
               "stage times (ms, %s of %d run%s):\n",
               repeat > 1 ? "median" : "one",
               repeat,
               repeat > 1 ? "s" : "");
  for (const StageTime& t : result.timings_ms.stages) {
    std::fprintf(stderr, "  %-16s %8.1f\n", EnumName(t.stage), Median(stage_times.at(t.stage)));
  }
}

// What a scan without detections needs, in the CLI's words (the detector's
// message names its fields): no floor found, a pose or a larger range;
// nothing in range of an image, most often its depth unit.
std::string CliHint(const LoadedScan& scan, const DetectionResult& result) {
  if (result.status == DetectionStatus::kNoFloor)
    return " (detect: --world-from-camera or --floor-aligned; --max-range)";
  if (scan.input.width <= 0 || result.status != DetectionStatus::kNoPointsInRange) return "";
  return "; if the image's depth unit is not the millimetre, give --depth-scale (units per "
         "metre; TUM RGB-D PNGs: 5000)";
}

// The model file behind a run's JSON: its path and content hash.
DetectionProvenance ProvenanceOf(const DetectRunOptions& run) {
  return {run.model_path, ModelFileHash(run.model_path)};
}

// A batch's or bag's lines as they are made, in "<out>.partial": a header
// naming the run (model hash, detector options, inputs), then one entry per
// scan {"key", "failed", "line"} appended and flushed. With --resume the
// entries of a killed run of the same run are taken instead of detecting
// their scans again (a last entry cut by the kill is dropped).
class PartialLines {
 public:
  PartialLines(const DetectRunOptions& run,
               const std::string& model_hash,
               const std::string& inputs,
               bool has_out_bag) {
    Require(!run.resume || !has_out_bag,
            "--resume does not apply with --out-bag (the marked bag is written in one pass)");
    std::error_code ec;
    const bool device =  // /dev/null and the like: nothing to resume into
        std::filesystem::exists(run.out, ec) && !std::filesystem::is_regular_file(run.out, ec);
    if (run.out.empty() || run.out == "-" || device) {
      Require(!run.resume, "--resume needs --out FILE (the lines a killed run kept are there)");
      return;
    }
    path_ = run.out + ".partial";
    nlohmann::ordered_json header{{"furnidet_partial", 1},
                                  {"model_hash", model_hash},
                                  {"detector", DetectorOptionsJson(run.detector)},
                                  {"inputs", inputs}};
    header_ = header.dump();
    if (run.resume) ReadSaved();
    file_ = std::fopen(path_.c_str(), "wb");
    Require(file_ != nullptr, path_ + ": cannot write (" + std::strerror(errno) + ")");
    std::fputs((header_ + "\n").c_str(), file_);
    for (const auto& [key, entry] : saved_) Append(key, entry.second, entry.first);
    std::fflush(file_);
  }
  ~PartialLines() {
    if (file_ != nullptr) std::fclose(file_);
  }
  PartialLines(const PartialLines&) = delete;
  PartialLines& operator=(const PartialLines&) = delete;

  // A saved scan's line and whether it failed.
  const std::pair<bool, std::string>* Saved(const std::string& key) const {
    const auto found = saved_.find(key);
    return found == saved_.end() ? nullptr : &found->second;
  }
  size_t saved() const { return saved_.size(); }
  void Add(const std::string& key, const std::string& line, bool failed) {
    if (file_ == nullptr) return;
    Append(key, line, failed);
    std::fflush(file_);
  }
  // The run is written: the partial lines are not needed any more.
  void Finish() {
    if (file_ == nullptr) return;
    std::fclose(file_);
    file_ = nullptr;
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }

 private:
  void Append(const std::string& key, const std::string& line, bool failed) {
    const nlohmann::ordered_json entry{{"key", key}, {"failed", failed}, {"line", line}};
    std::fputs((entry.dump() + "\n").c_str(), file_);
  }
  void ReadSaved() {
    std::error_code ec;
    if (!std::filesystem::exists(path_, ec)) return;
    RequireRegularFile(path_);
    std::istringstream in(ReadFileBytes(path_));
    std::string line;
    Require(std::getline(in, line) && line == header_,
            path_ +
                ": the lines of another run (model, options or inputs differ); remove it or "
                "run without --resume");
    for (int number = 2; std::getline(in, line); ++number) {
      nlohmann::json entry;
      try {
        entry = nlohmann::json::parse(line);
        saved_[entry.at("key").get<std::string>()] = {entry.at("failed").get<bool>(),
                                                      entry.at("line").get<std::string>()};
      } catch (const std::exception&) {
        Require(in.peek() == EOF,
                path_ + ":" + std::to_string(number) +
                    ": not an entry of "
                    "furnidet's partial lines");
      }
    }
    if (!saved_.empty())
      std::fprintf(stderr, "detect: resuming: %zu scans from %s\n", saved_.size(), path_.c_str());
  }
  std::string path_, header_;
  std::FILE* file_ = nullptr;
  std::map<std::string, std::pair<bool, std::string>> saved_;
};

// One scan given by the user: its errors throw, with debug PNGs and repeats.
int DetectOneScan(const LoadedScan& scan, const Detector& detector, const DetectRunOptions& run) {
  std::map<DetectionStage, std::vector<double>> stage_times;
  DetectionResult result;
  for (int k = 0; k < run.repeat; ++k) {
    result =
        detector.Detect(scan.input, /*keep_debug=*/!run.debug_dir.empty() && k == run.repeat - 1);
    // One scan given by the user: nothing in range is most likely a wrong file or unit.
    Require(result.status == DetectionStatus::kDetected,
            scan.description + ": " + result.message + CliHint(scan, result));
    for (const StageTime& t : result.timings_ms.stages) stage_times[t.stage].push_back(t.ms);
  }
  if (!run.debug_dir.empty()) {  // first: --out may name a file inside it
    WriteDetectionDebug(result,
                        detector.model(),
                        scan.camera,
                        GroundTruthInDetectorFrame(scan, result),
                        run.debug_dir,
                        SceneViewLinks{scan.description, "", "", "", ""});
  }
  Emit(DetectionJson(result, scan, detector.model(), ProvenanceOf(run)), run);
  if (!run.quiet) PrintDetections(scan, result);
  if (run.explain) std::fputs(ExplainDetection(result, detector.model()).c_str(), stderr);
  if (run.timings || run.repeat > 1) PrintStageTimes(result, stage_times, run.repeat);
  return 0;
}

// A batch: one JSON line per scan, in input order; a scan that cannot be
// read gets a line with its error and the others go on.
int DetectBatch(const std::vector<ScanSource>& sources,
                const Detector& detector,
                double load_ms,
                const DetectRunOptions& run) {
  std::string lines, names;
  for (const ScanSource& source : sources) names += ScanSourceName(source) + "\n";
  const DetectionProvenance provenance = ProvenanceOf(run);  // the model file hashed once
  PartialLines partial(run, provenance.model_hash, names, /*has_out_bag=*/false);
  int failed = 0;
  std::vector<double> totals;
  Progress progress("detect", sources.size(), "scans");
  for (size_t k = 0; k < sources.size(); ++k) {
    const ScanSource& source = sources[k];
    const std::string key = std::to_string(k);
    if (const auto* saved = partial.Saved(key)) {
      lines += saved->second;
      failed += saved->first;
      progress.Advance();
      continue;
    }
    std::string line;
    bool scan_failed = false;
    try {
      const LoadedScan scan = LoadScan(source);
      const DetectionResult result = detector.Detect(scan.input, /*keep_debug=*/false);
      if (result.status != DetectionStatus::kDetected) {
        line = ScanErrorJson(scan.description, result.message + CliHint(scan, result));
        scan_failed = true;
      } else {
        line = DetectionJson(result, scan, detector.model(), provenance, /*one_line=*/true);
        totals.push_back(result.timings_ms.Of(DetectionStage::kTotal));
        if (run.explain) Explain(scan.description, result, detector);
      }
    } catch (const InputError& e) {
      line = ScanErrorJson(ScanSourceName(source), e.what());
      scan_failed = true;
    }
    lines += line;
    failed += scan_failed;
    partial.Add(key, line, scan_failed);
    progress.Advance();
  }
  progress.Finish();
  Emit(lines, run);
  partial.Finish();
  if (!run.quiet || failed > 0) {
    std::sort(totals.begin(), totals.end());
    std::fprintf(stderr,
                 "%zu scans: %zu detected, %d failed (their lines say why); model loaded in "
                 "%.0f ms, detection median %.0f ms\n",
                 sources.size(),
                 totals.size(),
                 failed,
                 load_ms,
                 totals.empty() ? 0.0 : totals[totals.size() / 2]);
  }
  return failed > 0 ? 1 : 0;
}

// One message's JSON line: its place in the bag first, then what
// DetectionJson (or the error line) says.
std::string BagLine(const BagScan& scan,
                    const DetectionResult& result,
                    const TrainedModel& model,
                    const DetectionProvenance& provenance,
                    const std::string& world_frame) {
  // The boxes' frame: the TF world frame their pose came from, else none a
  // TF tree knows (the detector's own floor frame, whose pose of the camera
  // is the line's world_from_camera).
  const nlohmann::ordered_json place{
      {"topic", scan.topic},
      {"stamp", scan.stamp},
      {"seq", scan.seq},
      {"frame_id", scan.frame_id},
      {"boxes_frame_id", scan.pose_from_tf ? nlohmann::json(world_frame) : nlohmann::json()}};
  const std::string place_text = place.dump();  // {"topic":...}
  const std::string line =
      result.status != DetectionStatus::kDetected
          ? ScanErrorJson(scan.loaded.description, result.message + CliHint(scan.loaded, result))
          : DetectionJson(result, scan.loaded, model, provenance, /*one_line=*/true);
  // Both are one-line JSON objects: splice the place in after the brace.
  return place_text.substr(0, place_text.size() - 1) + "," + line.substr(1);
}

// A note on stderr when the model's vote network was trained on the other
// kind of input (VoteNetInputNote); nothing under --quiet.
void NoteVoteNetInput(const Detector& detector, const DetectRunOptions& run, bool fused_input) {
  if (run.quiet) return;
  const std::string note = VoteNetInputNote(detector.model(), run.model_path, fused_input);
  if (!note.empty()) std::fprintf(stderr, "note: %s\n", note.c_str());
}

}  // namespace

bool IsBatch(const std::vector<std::string>& inputs, const std::vector<ScanSource>& sources) {
  if (sources.size() > 1) return true;
  if (inputs.empty()) return false;
  if (inputs[0].find_first_of("*?[") != std::string::npos) return true;
  // A list or a folder that expanded to one scan is still a batch.
  return !sources.empty() && ScanSourceName(sources[0]) != inputs[0];
}

int DetectScans(const std::vector<ScanSource>& sources, bool batch, const DetectRunOptions& run) {
  Require(!batch || run.fuse || run.debug_dir.empty(), "--debug-dir applies to one scan");
  Require(!batch || run.fuse || run.repeat == 1, "--repeat applies to one scan");
  // One scan is checked before the model loads: a bad file fails fast.
  std::optional<LoadedScan> first;
  if (run.fuse) {
    Require(static_cast<int64_t>(sources.size()) <= run.fuse_max_scans,
            "--fuse: " + std::to_string(sources.size()) + " scans, more than --fuse-max-scans " +
                std::to_string(run.fuse_max_scans) +
                " (every fused scan is held in memory; raise it to fuse more)");
    std::vector<LoadedScan> scans;
    int64_t points = 0;
    for (const ScanSource& source : sources) {
      scans.push_back(LoadScan(source));
      points += static_cast<int64_t>(scans.back().input.points.size());
      Require(points <= run.fuse_max_points,
              "--fuse: " + scans.back().description + " brings the fused points past " +
                  "--fuse-max-points " + std::to_string(run.fuse_max_points) +
                  " (every fused scan is held in memory; raise it to fuse more)");
    }
    first = FuseLoadedScans(scans, run.fuse_registration);
    batch = false;
  } else if (!batch) {
    first = LoadScan(sources.at(0));
  }
  const auto load_start = std::chrono::steady_clock::now();
  const Detector detector(LoadTrainedModel(run.model_path), run.detector);
  const double load_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start)
          .count();
  if (run.timings) std::fprintf(stderr, "model loaded in %.0f ms\n", load_ms);
  // Fused: several scans (--fuse), or a dataset frame with its room's frames.
  const bool fused_input =
      run.fuse || std::any_of(sources.begin(), sources.end(), [](const ScanSource& source) {
        return source.fusion.room_frames;
      });
  NoteVoteNetInput(detector, run, fused_input);
  return batch ? DetectBatch(sources, detector, load_ms, run)
               : DetectOneScan(*first, detector, run);
}

int DetectInBag(const BagScanOptions& bag,
                const std::string& out_bag,
                const DetectRunOptions& run) {
  // Before the model loads: a wrong path fails at once.
  std::error_code ec;
  Require(std::filesystem::exists(bag.bag_path, ec), bag.bag_path + ": does not exist");
  if (!std::filesystem::is_directory(bag.bag_path, ec)) RequireRegularFile(bag.bag_path);
  const Detector detector(LoadTrainedModel(run.model_path), run.detector);
  NoteVoteNetInput(detector, run, /*fused_input=*/false);
  const DetectionProvenance provenance = ProvenanceOf(run);  // the model file hashed once
  PartialLines partial(run,
                       provenance.model_hash,
                       bag.bag_path + "\n" + bag.topic + "\n" + bag.world_frame,
                       !out_bag.empty());
  std::unique_ptr<DetectionBagSink> markers;
  if (!out_bag.empty()) markers = OpenDetectionBag(bag.bag_path, out_bag, bag.world_frame);
  std::string lines;
  std::vector<double> totals;
  int without = 0, resumed_ok = 0, index = 0;
  std::optional<Progress> progress;
  bool warned = false;
  ForEachScanInBag(bag, [&](const BagScan& scan) {
    if (!scan.tf_miss.empty()) {
      Require(!run.strict,
              scan.loaded.description + ": " + scan.tf_miss + " (--strict; name a root with " +
                  "--tf-world)");
      if (!warned) std::fprintf(stderr, "warning: %s\n", PrintableText(scan.tf_miss).c_str());
      warned = true;
    }
    if (!progress) progress.emplace("detect", scan.total, "messages");  // its clock starts here
    const std::string key = std::to_string(index++);
    if (const auto* saved = partial.Saved(key)) {
      lines += saved->second;
      without += saved->first;
      resumed_ok += !saved->first;
      progress->Advance();
      return;
    }
    const DetectionResult result = detector.Detect(scan.loaded.input, /*keep_debug=*/false);
    if (result.status != DetectionStatus::kDetected) {
      ++without;
    } else {
      totals.push_back(result.timings_ms.Of(DetectionStage::kTotal));
    }
    const std::string line = BagLine(scan, result, detector.model(), provenance, bag.world_frame);
    partial.Add(key, line, result.status != DetectionStatus::kDetected);
    lines += line;
    if (markers) markers->Add(scan, result, detector.model());
    if (run.explain) Explain(scan.loaded.description, result, detector);
    progress->Advance();
  });
  if (progress) progress->Finish();
  if (markers) markers->Finish();
  Emit(lines, run);
  partial.Finish();
  if (!run.quiet) {
    std::sort(totals.begin(), totals.end());
    std::fprintf(stderr,
                 "%s %s: %zu messages, %d without points or floor; detection median %.0f ms%s%s\n",
                 bag.bag_path.c_str(),
                 bag.topic.c_str(),
                 totals.size() + resumed_ok + without,
                 without,
                 totals.empty() ? 0.0 : totals[totals.size() / 2],
                 out_bag.empty() ? "" : "; markers in ",
                 out_bag.c_str());
  }
  // As a batch of files: 1 when a message was not detected in (its line
  // says why), whatever else went well. A bag of nothing on the topic is
  // an error of its own.
  Require(totals.size() + resumed_ok + without > 0,
          bag.bag_path + ": no message on " + bag.topic + " could be read as a scan");
  if (without > 0 && run.quiet)
    std::fprintf(stderr,
                 "%s %s: %d of %zu messages without points or floor\n",
                 bag.bag_path.c_str(),
                 bag.topic.c_str(),
                 without,
                 totals.size() + resumed_ok + without);
  return without > 0 ? 1 : 0;
}

}  // namespace furn

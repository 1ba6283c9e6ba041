// `workbench detect`: detection over scans with the model loaded once.
//
//   one scan    one indented JSON (stdout or --out), optional debug PNGs,
//               --repeat N for median stage times;
//   a batch     one JSON line per scan, in input order; a scan that cannot
//               be read gets a line with its error and the others go on;
//   fused scans one detection in several posed scans at once (--fuse);
//   a ROS bag   one JSON line per message of a topic, optionally the
//               detections written back as markers (--out-bag).
//
//   DetectRunOptions run;
//   run.model_path = "model.fcm";
//   return DetectScans({source}, /*batch=*/false, run);
#pragma once

#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "workbench/formats/rosbag_io.h"
#include "workbench/formats/scan_file.h"

namespace furn {

struct DetectRunOptions {
  std::string model_path;
  DetectorOptions detector;
  std::string out;        // JSON (lines) written here atomically; empty: stdout
  std::string debug_dir;  // one scan: debug PNGs here
  int repeat = 1;         // one scan: runs, median stage times printed
  bool quiet = false;     // nothing but errors
  bool explain = false;   // every hypothesis and its outcome on stderr
  bool timings = false;   // stage times and the model's load time on stderr
  // Warnings are errors: a bag's --tf-world that TF cannot resolve stops the
  // run instead of falling back to estimating the floor.
  bool strict = false;
  // Several scans with their own poses: one detection in all of them fused
  // (FuseLoadedScans), seen from the last one's camera, as for one scan.
  bool fuse = false;
  // Their poses refined against the last one's points first; nothing: as given.
  std::optional<ScanRegistrationOptions> fuse_registration;
  // Every fused scan is held in memory at once: at most this many scans
  // (refused before any is read) and points in all (refused while reading).
  int fuse_max_scans = 64;
  int64_t fuse_max_points = int64_t{1} << 25;  // 33.5 M: 109 Kinect v1 frames
  // Batches and bags with `out`: every scan's line also goes to
  // "<out>.partial" as it is made; with resume, the scans a killed run of
  // the same model and options left there are not detected again, and the
  // finished file is the one an uninterrupted run writes. Not with an
  // output bag (written in one pass).
  bool resume = false;
};

// Whether `inputs` (the command's positional scans) expanded into `sources`
// make a batch (JSON lines): several scans, a glob, a list or a folder.
bool IsBatch(const std::vector<std::string>& inputs, const std::vector<ScanSource>& sources);

// One scan (batch false: errors throw) or a batch (an error is a line). The
// exit code: 0, or 1 when a scan of a batch failed.
int DetectScans(const std::vector<ScanSource>& sources, bool batch, const DetectRunOptions& run);

// Every message of the bag's topic; markers into `out_bag` unless empty.
// The exit code as for a batch: 0, or 1 when a message could not be
// detected in (no points in range, no floor); a bag with no readable
// message on the topic throws.
int DetectInBag(const BagScanOptions& bag, const std::string& out_bag, const DetectRunOptions& run);

}  // namespace furn

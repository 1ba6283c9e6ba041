// `workbench adapt` (issue 69): a model's vote network fitted to a user's
// own sensor and rooms from their scans, without a label. Every scan is
// prepared as detection prepares it (the floor found, or the pose given) and
// rasterised into the network's bird's-eye-view grid; the network's batch
// normalisation statistics are then re-estimated on those images
// (AdaptNormalisation: AdaBN), the weights kept. The operating point stays
// the one chosen on the model's generated rooms: no label of the user's
// frames is read, so none can choose another (`model operating-point --db`
// does, on frames that have labels).
//
//   AdaptOptions options;
//   options.model_path = "default.fcm";
//   options.out = "mine.fcm";
//   options.sources = ExpandScanInputs({"scans/"}, {}, false, false);
//   const AdaptSummary summary = AdaptModel(options);
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/detector.h"
#include "core/learned/vote_net_training.h"
#include "db/split.h"
#include "workbench/formats/rosbag_io.h"
#include "workbench/formats/scan_file.h"

namespace furn {

struct AdaptOptions {
  std::string model_path, out;
  // Where the scans come from (any together): a dataset's frames (their
  // labels are never read), scan files, a bag's topic.
  std::string db_path;
  Split split = Split::kAll;  // of db_path's frames
  std::vector<ScanSource> sources;
  std::optional<BagScanOptions> bag;
  DetectorOptions detector;  // its floor search and range prepare the scans
  // At most this many scans (0: all), drawn by `seed` when there are more.
  int max_frames = 0;
  uint64_t seed = 1;          // which scans, their order and which are mirrored
  double mirror_share = 0.5;  // scans used mirrored (as training mirrors rooms)
  int batch = 8;              // images per batch normalisation batch (>= 2)
  double blend = 1;           // the scans' statistics' share (AdaptNormalisation)
  bool quiet = false;

  // Throws InputError naming the option and the rule.
  void Check() const;
};

struct AdaptSummary {
  int scans = 0;  // read
  int used = 0;   // adapted on
  // Scans not used, by reason (a status or an error's first words).
  std::map<std::string, int> skipped;
  NormalisationShift shift;
  double seconds = 0;
};

// Reads the model and every scan, adapts, writes options.out atomically
// (nothing is written on an error). Throws InputError for a model without a
// vote network, no usable scan, or bad options; a scan of a batch that
// cannot be read is skipped and counted.
AdaptSummary AdaptModel(const AdaptOptions& options);

std::string AdaptSummaryText(const AdaptOptions& options, const AdaptSummary& summary);

}  // namespace furn

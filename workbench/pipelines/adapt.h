// `workbench adapt` (issue 69): a model's vote network fitted to a user's
// own sensor and rooms from their scans, without a label. Every scan is
// prepared as detection prepares it (the floor found, or the pose given) and
// rasterised into the network's bird's-eye-view grid. Then one of:
//
//   normalisation  the network's batch normalisation statistics are
//                  re-estimated on those images (AdaptNormalisation: AdaBN),
//                  the weights kept, the operating point kept;
//   self-training  the network's confident, mirror-consistent maxima on the
//                  scans become their targets (PseudoLabelledSample), and the
//                  network is fine-tuned on them with as many frames of
//                  generated rooms beside them (rooms_db: rooms of the
//                  model's training catalog only, e.g. `train --keep-rooms`'s
//                  <model>.rooms.db), so that what the CAD rooms taught stays;
//                  the operating point is chosen again on those rooms'
//                  validation frames (never on the scans: no label of the
//                  user's frames is read; `model operating-point --db` chooses
//                  one on frames that have labels).
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

#include "core/detector/detector.h"
#include "core/learned/self_training.h"
#include "core/learned/vote_net_training.h"
#include "db/split.h"
#include "workbench/formats/rosbag_io.h"
#include "workbench/formats/scan_file.h"

namespace furn {

enum class AdaptMethod { kNormalisation, kSelfTraining };

template <>
struct EnumText<AdaptMethod> {
  static constexpr const char* kKind = "adaptation method";
  static constexpr EnumEntry<AdaptMethod> kEntries[] = {
      {AdaptMethod::kNormalisation, "normalisation"},
      {AdaptMethod::kSelfTraining, "self-training"},
  };
};

struct AdaptOptions {
  AdaptMethod method = AdaptMethod::kNormalisation;
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
  // Self-training: the generated rooms (a dataset database of rooms made
  // from the model's training catalog alone), their frames per scan in the
  // fine-tuning, its epochs and peak learning rate (cosine decay), and what
  // becomes a pseudo-target (its thresholds: the model's operating point,
  // scaled by pseudo.heat_share; its decoding: the detector's).
  std::string rooms_db;
  double rooms_share = 1;
  int epochs = 4;
  double learning_rate = 1e-3;
  PseudoLabelOptions pseudo;
  // Whether a scan's cells away from its pseudo-targets train as background
  // (false: unknown, since the furniture the network missed is there too;
  // only the pseudo-targets' surroundings train: BevSample::background_known).
  bool scans_background_known = false;
  bool quiet = false;

  // Throws InputError naming the option and the rule.
  void Check() const;
};

struct AdaptSummary {
  int scans = 0;  // read
  int used = 0;   // adapted on
  // Scans not used, by reason (a status or an error's first words).
  std::map<std::string, int> skipped;
  NormalisationShift shift;  // normalisation
  // Self-training: the scans' pseudo-labels, the generated frames beside
  // them, the last epoch's training loss and the operating point chosen.
  PseudoLabelCounts pseudo;
  int room_frames = 0;
  double final_loss = 0;
  std::string operating_point_chosen_on;
  double seconds = 0;
};

// Reads the model and every scan, adapts, writes options.out atomically
// (nothing is written on an error). Throws InputError for a model without a
// vote network, no usable scan, or bad options; a scan of a batch that
// cannot be read is skipped and counted.
AdaptSummary AdaptModel(const AdaptOptions& options);

std::string AdaptSummaryText(const AdaptOptions& options, const AdaptSummary& summary);

}  // namespace furn

#include "workbench/pipelines/adapt.h"

#include <chrono>
#include <cstdio>
#include <set>
#include <sstream>
#include <utility>

#include "core/learned/bev_grid.h"
#include "core/learned/self_training.h"
#include "core/learned/vote_net.h"
#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "core/util/progress.h"
#include "core/util/random.h"
#include "db/dataset_db.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {
namespace {

// The scans' images, at most `capacity` of them kept by reservoir sampling
// (Vitter's algorithm R), so that a long bag never holds more.
class ImageReservoir {
 public:
  ImageReservoir(size_t capacity, uint64_t seed) : capacity_(capacity), rng_(seed) {}

  void Offer(BevImage image) {
    ++offered_;
    if (capacity_ == 0 || images_.size() < capacity_) {
      images_.push_back(std::move(image));
      return;
    }
    const int64_t slot = rng_.UniformInt(0, offered_ - 1);
    if (slot < static_cast<int64_t>(capacity_))
      images_[static_cast<size_t>(slot)] = std::move(image);
  }

  std::vector<BevImage>& images() { return images_; }
  Rng& rng() { return rng_; }

 private:
  size_t capacity_;
  Rng rng_;
  int64_t offered_ = 0;
  std::vector<BevImage> images_;
};

// Reads scans, prepares them as detection does and rasterises them into the
// network's grid.
class ScanRasteriser {
 public:
  ScanRasteriser(const Detector& detector,
                 const VoteNetOptions& net,
                 ImageReservoir* reservoir,
                 AdaptSummary* summary)
      : detector_(detector), net_(net), reservoir_(reservoir), summary_(summary) {}

  void Add(const DetectionInput& input) {
    ++summary_->scans;
    const PreparedScan scan = detector_.Prepare(input);
    if (scan.status != DetectionStatus::kDetected) {
      ++summary_->skipped[EnumName(scan.status)];
      return;
    }
    reservoir_->Offer(
        RasteriseScan(scan.camera_points, scan.world_from_camera, net_.range_m, net_.grid));
  }

  // A scan that cannot be read is counted by its error's kind and skipped.
  void AddFailed() {
    ++summary_->scans;
    ++summary_->skipped["unreadable"];
  }

 private:
  const Detector& detector_;
  const VoteNetOptions net_;
  ImageReservoir* reservoir_;
  AdaptSummary* summary_;
};

// Every frame of the dataset's rooms in `split`, as a scan source.
std::vector<ScanSource> DatasetSources(const std::string& db_path, Split split) {
  DatasetDb db(db_path, DatasetDb::Mode::kReadOnly);
  std::vector<ScanSource> sources;
  for (int64_t room_id : db.RoomIds()) {
    const RoomRecord room = db.ReadRoom(room_id, /*with_images=*/false);
    if (!InSplit(room.split, split)) continue;
    for (const FrameRecord& frame : room.frames) {
      ScanSource source;
      source.db_path = db_path;
      source.frame_id = frame.id;
      sources.push_back(source);
    }
  }
  Require(!sources.empty(), db_path + ": no frame in split '" + EnumName(split) + "' to adapt on");
  return sources;
}

void RasteriseSources(const std::vector<ScanSource>& sources,
                      bool quiet,
                      ScanRasteriser* rasteriser) {
  Progress progress("adapt: scans", sources.size(), "scans");
  for (const ScanSource& source : sources) {
    try {
      rasteriser->Add(LoadScan(source).input);
    } catch (const InputError& e) {
      if (!quiet) std::fprintf(stderr, "adapt: skipped %s\n", e.what());
      rasteriser->AddFailed();
    }
    progress.Advance();
  }
  progress.Finish();
}

// The images in the seed's order, a share of them mirrored.
std::vector<BevImage> ShuffledAndMirrored(ImageReservoir* reservoir, double mirror_share) {
  std::vector<BevImage>& images = reservoir->images();
  Rng& rng = reservoir->rng();
  for (size_t i = images.size(); i > 1; --i)
    std::swap(images[i - 1], images[static_cast<size_t>(rng.UniformInt(0, i - 1))]);
  for (BevImage& image : images)
    if (rng.Bernoulli(mirror_share)) image = image.Mirrored();
  return std::move(images);
}

// The fine-tuning's options: the network's own grid and coder, the adapt
// options' schedule, seed and batch.
VoteNetTrainingOptions TuningOptions(const AdaptOptions& options, const VoteNet& net) {
  VoteNetTrainingOptions tuning;
  tuning.net = net.options();
  tuning.seed = options.seed;
  tuning.epochs = options.epochs;
  tuning.learning_rate = options.learning_rate;
  tuning.batch_size = options.batch;
  tuning.threads = std::max(1, options.detector.torch_threads);
  tuning.quiet = options.quiet;
  return tuning;
}

// rooms_share x `scans` of the generated frames (at most all), drawn by seed.
std::vector<BevSample> DrawnRoomFrames(std::vector<BevSample> rooms,
                                       double rooms_share,
                                       size_t scans,
                                       uint64_t seed) {
  Rng rng(seed * 31 + 7);
  for (size_t i = rooms.size(); i > 1; --i)
    std::swap(rooms[i - 1], rooms[static_cast<size_t>(rng.UniformInt(0, i - 1))]);
  const size_t wanted = std::min(rooms.size(), static_cast<size_t>(rooms_share * scans + 0.5));
  rooms.resize(wanted);
  return rooms;
}

// Self-training (AdaptMethod::kSelfTraining): pseudo-labels on the scans,
// fine-tuning on them beside generated frames, the operating point chosen
// again on the generated rooms' validation frames.
void SelfTrain(const AdaptOptions& options,
               const std::vector<BevImage>& images,
               VoteNet* net,
               TrainedModel* model,
               AdaptSummary* summary) {
  Require(net->Members() == 1,
          options.model_path + ": self-training needs one vote network (this is an ensemble of " +
              std::to_string(net->Members()) + ")");
  const VoteNetTrainingOptions tuning = TuningOptions(options, *net);
  std::vector<BevSample> rooms, validation;
  ReadBevSamples(options.rooms_db, tuning, &rooms, &validation);
  Require(!rooms.empty(), options.rooms_db + ": has no training frame (the generated rooms)");
  PseudoLabelOptions pseudo = options.pseudo;
  for (FurnitureClass c : kAllClasses) {
    double& threshold = pseudo.min_heat[static_cast<size_t>(c)];
    if (threshold < 0) threshold = model->operating_point.MinScore(c);
  }
  pseudo.decode = options.detector.LearnedDecode();
  std::vector<BevSample> training;
  Progress progress("adapt: pseudo-labels", images.size(), "scans");
  for (const BevImage& image : images) {
    training.push_back(PseudoLabelledSample(*net, image, pseudo, &summary->pseudo));
    training.back().background_known = options.scans_background_known;
    progress.Advance();
  }
  progress.Finish();
  std::vector<BevSample> drawn =
      DrawnRoomFrames(std::move(rooms), options.rooms_share, images.size(), options.seed);
  summary->room_frames = static_cast<int>(drawn.size());
  for (BevSample& sample : drawn) training.push_back(std::move(sample));
  VoteNetTrainingSummary trained;
  *net = TrainVoteNetOnSamples(training, {}, tuning, &trained, net);
  summary->final_loss = trained.epochs.empty() ? 0 : trained.epochs.back().train_loss;
  if (validation.empty()) {
    summary->operating_point_chosen_on = "kept: " + options.rooms_db + " has no validation room";
    return;
  }
  model->operating_point = VoteNetOperatingPoint(*net, validation);
  model->operating_point.chosen_on += " (after self-training)";
  summary->operating_point_chosen_on = model->operating_point.chosen_on;
}

}  // namespace

void AdaptOptions::Check() const {
  Require(!model_path.empty(), "adapt needs --model");
  Require(!out.empty(), "adapt needs --out");
  Require(!db_path.empty() || !sources.empty() || bag.has_value(),
          "adapt needs scans: --db, scan files or --bag");
  Require(max_frames >= 0, "--max-frames must be >= 0 (got " + std::to_string(max_frames) + ")");
  Require(batch >= 2, "--batch must be >= 2 (got " + std::to_string(batch) + ")");
  Require(blend >= 0 && blend <= 1,
          "--blend must be in [0, 1] (got " + std::to_string(blend) + ")");
  Require(mirror_share >= 0 && mirror_share <= 1,
          "--mirror-share must be in [0, 1] (got " + std::to_string(mirror_share) + ")");
  if (method != AdaptMethod::kSelfTraining) {
    Require(rooms_db.empty(), "--rooms applies to --method self-training");
    return;
  }
  Require(!rooms_db.empty(),
          "--method self-training needs --rooms (generated rooms of the model's training catalog)");
  Require(rooms_share > 0 && rooms_share <= 16,
          "--rooms-share must be in (0, 16] (got " + std::to_string(rooms_share) + ")");
  Require(epochs >= 1 && epochs <= 100,
          "--epochs must be in 1..100 (got " + std::to_string(epochs) + ")");
  Require(learning_rate > 0 && learning_rate <= 0.1,
          "--learning-rate must be in (0, 0.1] (got " + std::to_string(learning_rate) + ")");
  pseudo.Check();
}

AdaptSummary AdaptModel(const AdaptOptions& options) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  TrainedModel model = LoadTrainedModel(options.model_path);
  Require(!model.vote_net.empty(),
          options.model_path + ": has no vote network to adapt (a codebook model)");
  VoteNet net = VoteNet::Deserialize(model.vote_net, options.model_path);
  net.SetPrecision(options.detector.network_precision);
  DetectorOptions prepare = options.detector;
  prepare.voting = VotingMode::kLearned;  // the points as the network's grid takes them
  const Detector detector(model, prepare);
  AdaptSummary summary;
  ImageReservoir reservoir(static_cast<size_t>(options.max_frames), options.seed);
  ScanRasteriser rasteriser(detector, net.options(), &reservoir, &summary);
  std::vector<ScanSource> sources = options.sources;
  if (!options.db_path.empty()) {
    const std::vector<ScanSource> frames = DatasetSources(options.db_path, options.split);
    sources.insert(sources.end(), frames.begin(), frames.end());
  }
  RasteriseSources(sources, options.quiet, &rasteriser);
  if (options.bag) {
    ForEachBagScan(*options.bag, [&](const BagScan& scan) { rasteriser.Add(scan.loaded.input); });
  }
  const bool self_training = options.method == AdaptMethod::kSelfTraining;
  // Self-training mirrors in its own batches.
  std::vector<BevImage> images =
      ShuffledAndMirrored(&reservoir, self_training ? 0.0 : options.mirror_share);
  summary.used = static_cast<int>(images.size());
  Require(summary.used >= options.batch,
          "adapt: " + std::to_string(summary.used) + " of " + std::to_string(summary.scans) +
              " scans could be used (a floor found, points in range), fewer than one batch of " +
              std::to_string(options.batch));
  std::vector<const BevImage*> pointers;
  for (const BevImage& image : images) pointers.push_back(&image);
  SetTorchThreads(options.detector.torch_threads);
  if (self_training)
    SelfTrain(options, images, &net, &model, &summary);
  else
    summary.shift = AdaptNormalisation(&net, pointers, options.batch, options.blend);
  model.vote_net = net.Serialize();
  SaveTrainedModel(model, options.out);
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

namespace {

std::string PseudoLabelText(const PseudoLabelCounts& pseudo) {
  std::string text;
  for (FurnitureClass c : kAllClasses) {
    const int count = pseudo.targets[static_cast<size_t>(c)];
    if (count == 0) continue;
    text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + ClassName(c);
  }
  return text.empty() ? "none" : text;
}

}  // namespace

std::string AdaptSummaryText(const AdaptOptions& options, const AdaptSummary& summary) {
  std::ostringstream text;
  char line[512];
  if (options.method == AdaptMethod::kSelfTraining) {
    std::snprintf(line,
                  sizeof line,
                  "%s: the vote network fine-tuned on %d of %d scans with %d pseudo-targets (%s; "
                  "%d maxima ignored) beside %d generated frames, %d epochs (seed %llu) in %.1f s; "
                  "last epoch's loss %.3f\n",
                  options.out.c_str(),
                  summary.used,
                  summary.scans,
                  summary.pseudo.Targets(),
                  PseudoLabelText(summary.pseudo).c_str(),
                  summary.pseudo.ignored,
                  summary.room_frames,
                  options.epochs,
                  static_cast<unsigned long long>(options.seed),
                  summary.seconds,
                  summary.final_loss);
  } else {
    std::snprintf(line,
                  sizeof line,
                  "%s: the vote network's %d batch normalisations re-estimated on %d of %d scans "
                  "(blend %.2f, seed %llu) in %.1f s; mean shift %.2f sd, variance ratio %.2f\n",
                  options.out.c_str(),
                  summary.shift.layers,
                  summary.used,
                  summary.scans,
                  options.blend,
                  static_cast<unsigned long long>(options.seed),
                  summary.seconds,
                  summary.shift.mean_shift_sd,
                  summary.shift.variance_ratio);
  }
  text << line;
  for (const auto& [reason, count] : summary.skipped)
    text << "  skipped " << count << " scans: " << reason << "\n";
  if (options.method == AdaptMethod::kSelfTraining)
    text << "  operating point: " << summary.operating_point_chosen_on
         << " (no label of the scans was read)\n";
  else
    text << "  operating point: the model's (chosen on its generated rooms; no label was read)\n";
  return text.str();
}

}  // namespace furn

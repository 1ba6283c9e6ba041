#include "workbench/pipelines/train_vote_net.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/detector/learned_source.h"
#include "core/geometry/scan_fusion.h"
#include "core/util/error.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "core/util/random.h"
#include "db/dataset_db.h"
#include "reports/evaluation.h"
#include "reports/training_curve.h"
#include "scenes/procedural_shapes.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/dataset_tools.h"    // MergeDatasets
#include "workbench/pipelines/evaluated_frame.h"  // ScoredDetectionOf
#include "workbench/pipelines/generate.h"
#include "workbench/pipelines/rooms_cache.h"
#include "workbench/pipelines/run_program.h"
#include "workbench/pipelines/vote_net_checkpoint.h"

namespace furn {
namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The labelled objects the frames see, with the best of their visibilities:
// targets when seen at least min_visibility, else objects the loss ignores
// around.
void AddObjectsSeenBy(const RoomRecord& room,
                      const std::vector<const FrameRecord*>& frames,
                      double min_visibility,
                      BevSample* sample) {
  for (const ObjectRecord& object : room.objects) {
    if (!object.furniture_class) continue;
    double visibility = 0;
    for (const FrameRecord* frame : frames) {
      for (const FrameObjectRecord& seen : frame->objects) {
        if (seen.instance_id == object.instance_id)
          visibility = std::max(visibility, seen.visibility);
      }
    }
    if (visibility <= 0) continue;
    sample->objects.push_back(
        {object.Footprint(), *object.furniture_class, visibility >= min_visibility});
    sample->visibility.push_back(visibility);
  }
}

// A validation frame's decoded maxima as an evaluation frame, each the
// detection it stands for as detection decodes it
// (LearnedSource::DetectionOf) and scored as evaluate scores it, from the
// network's plain answer: not mirror-averaged, though detection is by
// default. F1 is flat over the mirror's scores, and its best lies lower
// (chair 0.32 against 0.40): twice the false detections at the same F1 on
// seen-model rooms (docs/learned-voting.md, "fold seed 3 and mirror
// averaging"). Objects seen too little to be targets count as "ignore" when
// `ignore_non_targets`, else are left out. `decode` says how far maxima
// are kept (detection's range for the operating point, every one for AP).
FrameOutcome DecodedFrame(const BevSample& sample,
                          size_t index,
                          const BevOutput& answer,
                          const BevDecodeOptions& decode,
                          bool ignore_non_targets) {
  FrameOutcome frame;
  frame.frame_id = static_cast<int64_t>(index);
  for (size_t k = 0; k < sample.objects.size(); ++k) {
    const BevObject& object = sample.objects[k];
    if (!object.target && !ignore_non_targets) continue;
    TruthObject truth;
    truth.furniture_class = object.furniture_class;
    truth.box() = object.box();
    // As evaluation counts them: the object's visibility (a non-target
    // one below any min_visibility: ignore), its distance from the camera.
    truth.visibility = k < sample.visibility.size() ? sample.visibility[k] : 1;
    if (!object.target) truth.visibility = std::min(truth.visibility, 0.01);
    truth.distance_m = (object.Centre() - sample.image.frame.origin).norm();
    frame.truth.push_back(truth);
  }
  for (const BevPeak& peak : DecodeBevOutput(sample.image, answer, decode)) {
    if (peak.suppressed) continue;
    frame.detections.push_back(
        ScoredDetectionOf(LearnedSource::DetectionOf(peak), BevYawSymmetry(peak.furniture_class)));
  }
  return frame;
}

// Every validation frame decoded (DecodedFrame) from the network's answer.
std::vector<FrameOutcome> DecodedFrames(const VoteNet& net,
                                        const std::vector<BevSample>& validation,
                                        const BevDecodeOptions& decode,
                                        bool ignore_non_targets) {
  std::vector<FrameOutcome> frames;
  for (size_t i = 0; i < validation.size(); ++i) {
    frames.push_back(DecodedFrame(
        validation[i], i, net.Predict(validation[i].image), decode, ignore_non_targets));
  }
  return frames;
}

// The validation frames' mean loss; with `decoded` (a single network), each
// frame decoded for AP (DecodedFrame, every maximum kept) from the same
// forward pass, a batch's answers dropped once decoded.
VoteNetLoss ValidationLoss(const VoteNet& net,
                           const std::vector<BevSample>& validation,
                           const VoteNetTrainingOptions& options,
                           std::vector<FrameOutcome>* decoded = nullptr) {
  const size_t batch_size = options.batch_size;
  const BevDecodeOptions decode;  // its floor is low: AP sweeps the score
  VoteNetLoss sum;
  int batches = 0;
  for (size_t start = 0; start < validation.size(); start += batch_size) {
    std::vector<size_t> indices;
    for (size_t i = start; i < std::min(validation.size(), start + batch_size); ++i)
      indices.push_back(i);
    std::vector<BevOutput> answers;
    sum += EvaluateVoteNetLoss(net,
                               MakeTrainingBatch(validation, indices, {}, options.net.coder),
                               options.loss,
                               decoded != nullptr ? &answers : nullptr);
    for (size_t k = 0; k < answers.size(); ++k)
      decoded->push_back(
          DecodedFrame(validation[indices[k]], indices[k], answers[k], decode, false));
    ++batches;
  }
  return batches > 0 ? sum.Scaled(1.0 / batches) : sum;
}

// The samples' objects are all in the network's view.
EvaluationOptions ValidationEvaluation() {
  EvaluationOptions options;
  options.max_distance_m = 1e9;
  return options;
}

// mAP@10cm of decoded validation frames (every target a labelled object;
// protocol B's matching).
double ValidationMeanAp(const std::vector<FrameOutcome>& decoded) {
  const EvaluationResult result = EvaluateFrames(decoded, ValidationEvaluation());
  return MetricOrNan(result.metrics, MetricId::MeanAp(0.10));
}

// The same of the network's decoded maxima on the validation frames.
double ValidationMeanAp(const VoteNet& net, const std::vector<BevSample>& validation) {
  return ValidationMeanAp(DecodedFrames(net, validation, BevDecodeOptions{}, false));
}

// What `generate` makes the training rooms with: the training catalog's
// models only (evaluation-only entries and `held_out` never placed).
GenerateOptions TrainingRooms(const VoteNetTrainingOptions& options,
                              const std::string& catalog_spec,
                              const std::set<std::string>& held_out) {
  GenerateOptions generate;
  generate.catalog_spec = catalog_spec;
  generate.rooms = options.rooms;
  generate.seed = options.seed;
  generate.room = options.room;
  generate.room.frames_per_room = options.frames_per_room;
  generate.room.include_evaluation_only = false;
  generate.room.include_vote_net_only = true;
  generate.excluded_models = held_out;
  generate.noise = options.sensor;
  return generate;
}

// The catalog the training rooms are composed from: the training catalog,
// plus options.shape_variety varied tables and sideboards per class.
Catalog TrainingCatalog(const Catalog& catalog,
                        const std::set<std::string>& held_out,
                        const VoteNetTrainingOptions& options) {
  Catalog training = catalog.Copy();
  if (options.shape_variety > 0) {
    training.AddModels(
        MakeShapeVariety(
            catalog, held_out, options.shape_variety, options.seed, options.shape_sizes),
        "Shape variety",
        std::to_string(options.shape_variety) + " varied tables and sideboards per class (" +
            EnumName(options.shape_sizes) + " sizes, seed " + std::to_string(options.seed) + ")");
  }
  return training;
}

}  // namespace

namespace {

// Where rank 0 tells the others its rooms are (a group started by Slurm).
constexpr const char* kRoomsKey = "rooms";

// Rank 0 of a local data-parallel training (options.workers > 1): the other
// ranks started as processes of their own (their output in
// <rooms>.worker-R.log), the group joined; Finish waits for them and fails
// when one did, and a worker that dies before that ends this process at
// once (ProgramWatch). Nothing when options.workers is 1.
class LocalGroup {
 public:
  LocalGroup(const VoteNetTrainingOptions& options, const std::string& rooms_path) {
    if (options.data_parallel.Active()) {  // rank 0 of a group started elsewhere (Slurm)
      group_ = std::make_unique<DataParallelGroup>(options.data_parallel);
      group_->Broadcast(kRoomsKey, std::filesystem::absolute(rooms_path).string());
      return;
    }
    if (options.workers < 2) return;
    DataParallelOptions parallel;
    parallel.world = options.workers;
    parallel.store_path = rooms_path + ".group";
    std::filesystem::remove(parallel.store_path);
    for (int rank = 1; rank < options.workers; ++rank) {
      std::vector<std::string> argv = options.worker_command;
      for (const std::string& flag : {std::string("--vote-worker-rank"),
                                      std::to_string(rank),
                                      std::string("--vote-worker-of"),
                                      std::to_string(options.workers),
                                      std::string("--vote-worker-store"),
                                      parallel.store_path,
                                      std::string("--vote-worker-rooms"),
                                      rooms_path})
        argv.push_back(flag);
      logs_.push_back(rooms_path + ".worker-" + std::to_string(rank) + ".log");
      workers_.push_back(std::make_unique<RunningProgram>(argv, logs_.back()));
    }
    store_ = parallel.store_path;
    std::vector<RunningProgram*> watched;
    for (const auto& worker : workers_) watched.push_back(worker.get());
    watch_ = std::make_unique<ProgramWatch>(watched, [this](size_t i) { WorkerFailed(i); });
    group_ = std::make_unique<DataParallelGroup>(parallel);
    group_->Broadcast(kRoomsKey, std::filesystem::absolute(rooms_path).string());
  }
  ~LocalGroup() {
    if (!store_.empty()) std::filesystem::remove(store_);
  }

  DataParallelGroup* group() { return group_.get(); }

  void Finish() {
    if (watch_) watch_->Stop();
    for (size_t i = 0; i < workers_.size(); ++i) {
      const int code = workers_[i]->Wait();
      Require(code == 0,
              "data-parallel worker " + std::to_string(i + 1) + " failed (exit " +
                  std::to_string(code) + "; its log: " + logs_[i] + ")");
      std::filesystem::remove(logs_[i]);
    }
    workers_.clear();
  }

  // On the watch's thread, while this rank may be blocked in the group: a
  // worker that died fails the training at once (the group would only time
  // out), the others stopped, nothing written.
  // What the group lost, when this rank's training failed in it: a worker
  // that died, by its exit code and log. Rethrows `e` otherwise.
  [[noreturn]] void Explain(const std::runtime_error& e) const {
    if (watch_) watch_->Stop();
    for (size_t i = 0; i < workers_.size(); ++i) {
      std::optional<int> code;
      for (int tries = 0; tries < 20 && !code; ++tries) {  // a worker's end is seen within 1 s
        code = workers_[i]->Poll();
        if (!code) std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      if (code && *code != 0)
        throw std::runtime_error("data-parallel worker " + std::to_string(i + 1) +
                                 " failed (exit " + std::to_string(*code) +
                                 "; its log: " + logs_[i] + ")");
    }
    throw e;
  }

 private:
  [[noreturn]] void WorkerFailed(size_t i) {
    std::fprintf(stderr,
                 "workbench: error: data-parallel worker %zu failed (exit %d; its log: %s)\n",
                 i + 1,
                 workers_[i]->Poll().value_or(128),
                 logs_[i].c_str());
    for (const auto& worker : workers_) worker->Stop();
    std::filesystem::remove(store_);
    std::_Exit(1);
  }

  std::vector<std::unique_ptr<RunningProgram>> workers_;
  std::vector<std::string> logs_;
  std::string store_;
  std::unique_ptr<ProgramWatch> watch_;
  std::unique_ptr<DataParallelGroup> group_;
};

}  // namespace

void VoteNetTrainingOptions::Check() const {
  Require(rooms >= 1 && rooms <= 100000,
          "vote-net rooms " + std::to_string(rooms) + " must be in 1..100000");
  Require(frames_per_room >= 1 && frames_per_room <= 64,
          "vote-net frames per room must be in 1..64");
  Require(epochs >= 1 && epochs <= 1000,
          "vote-net epochs " + std::to_string(epochs) + " must be in 1..1000");
  Require(batch_size >= 1 && batch_size <= 512, "vote-net batch size must be in 1..512");
  Require(learning_rate > 0 && learning_rate <= 1, "vote-net learning rate must be in (0, 1]");
  Require(threads >= 0 && threads <= 256, "vote-net threads must be in 0..256");
  ResolvePrecision(precision);  // bf16 asked of a CPU without it fails here, before the rooms
  Require(min_visibility >= 0 && min_visibility <= 1, "vote-net min visibility must be in 0..1");
  Require(validation_share >= 0 && validation_share < 1,
          "vote-net validation share must be in [0, 1)");
  Require(weight_average >= 0 && weight_average < 1,
          "vote-net weight average " + std::to_string(weight_average) + " must be in [0, 1)");
  Require(!keep_last_weights || weight_average > 0,
          "the last weights are kept only beside a weight average (--vote-average)");
  Require(member >= 0 && member <= 1000,
          "vote-net ensemble member " + std::to_string(member) + " must be in 0..1000");
  Require(ensemble >= 1 && ensemble <= VoteNet::kMaxMembers,
          "vote-net ensemble " + std::to_string(ensemble) + " must be in 1.." +
              std::to_string(VoteNet::kMaxMembers) + " networks");
  Require(!keep_last_weights || ensemble == 1,
          "the last weights are kept for one network, not beside an ensemble");
  Require(fused_share >= 0 && fused_share <= 1,
          "vote-net fused share " + std::to_string(fused_share) + " must be in 0..1");
  Require(fused_share == 0 || frames_per_room > 1,
          "vote-net fused frames need two or more frames per training room (--vote-frames)");
  Require(!FusedFrames().HasPoseError() || fused_share > 0,
          "a vote-net fused pose error needs fused frames (--vote-fused-share)");
  CheckPoseErrorSpreads(fused_pose_noise_m, fused_pose_noise_deg, "vote-net fused pose noise");
  Require(shape_variety >= 0 && shape_variety <= 1000,
          "vote-net shape variety " + std::to_string(shape_variety) + " must be in 0..1000");
  Require(rooms_cache.empty() || (!keep_rooms && room_shards.empty()),
          "--rooms-cache " + rooms_cache + " keeps the rooms itself: not with --keep-rooms " +
              "or the rooms of 'train --shards'");
  Require(rooms_cache.empty() || !std::filesystem::exists(rooms_cache) ||
              std::filesystem::is_directory(rooms_cache),
          "--rooms-cache " + rooms_cache + " must be a directory (or not exist yet)");
  Require(workers >= 1 && workers <= 64,
          "vote-net workers " + std::to_string(workers) + " must be in 1..64");
  Require(workers == 1 || !worker_command.empty(), "vote-net workers need a command to start");
  Require(workers == 1 || ensemble == 1,
          "vote-net workers train one network, not an ensemble (--vote-ensemble)");
  Require(workers == 1 || !data_parallel.Active(), "a vote-net worker starts no workers");
  Require(ensemble == 1 || !data_parallel.Active(),
          "data-parallel ranks train one network, not an ensemble (--vote-ensemble)");
  data_parallel.Check();
  net.Check();
  loss.Check();
  room.Check();
}

std::string VoteNetTrainingOptions::Json() const {
  nlohmann::json json = {
      {"rooms", rooms},
      {"frames_per_room", frames_per_room},
      {"seed", seed},
      {"epochs", epochs},
      {"batch_size", batch_size},
      {"learning_rate", learning_rate},
      {"threads", threads},
      {"min_visibility", min_visibility},
      {"max_range_m", net.range_m},
      {"validation_share", validation_share},
      {"grid",
       {{"cell_m", net.grid.cell_m},
        {"rows", net.grid.rows},
        {"cols", net.grid.cols},
        {"floor_band_m", net.grid.floor_band_m}}},
      {"width", net.width},
      {"levels", net.levels},
      {"coder",
       {{"heat_sigma_cells", net.coder.heat_sigma_cells},
        {"vote_margin_m", net.coder.vote_margin_m},
        {"ignore_radius_cells", net.coder.ignore_radius_cells}}},
      {"loss",
       {{"heat", loss.heat},
        {"offset", loss.offset},
        {"size", loss.size},
        {"yaw", loss.yaw},
        {"membership", loss.membership}}},
      // The rooms as `generate` records them (held-out models
      // are keyed by the caller).
      {"rooms_content", nlohmann::json::parse(TrainingRooms(*this, "", {}).ContentJson())}};
  // Only when used: keys of models trained before the option stay valid.
  if (shape_variety > 0) json["shape_variety"] = shape_variety;
  if (weight_average > 0) json["weight_average"] = weight_average;
  if (fused_share > 0) json["fused_share"] = fused_share;
  if (FusedFrames().HasPoseError())
    json["fused_pose_noise"] = {
        {"m", fused_pose_noise_m}, {"deg", fused_pose_noise_deg}, {"planar", fused_planar_noise}};
  if (member > 0) json["member"] = member;
  if (ensemble > 1) json["ensemble"] = ensemble;
  if (shape_variety > 0 && shape_sizes != ShapeSizes::kCatalog)
    json["shape_sizes"] = EnumName(shape_sizes);
  if (!net.coder.dense_votes) json["coder"]["dense_votes"] = false;
  if (net.coder.centre_radius_cells > 0)
    json["coder"]["centre_radius_cells"] = net.coder.centre_radius_cells;
  if (net.coder.edge_votes) {
    json["coder"]["edge_votes"] = true;
    json["loss"]["edges"] = loss.edges;
  }
  return json.dump();
}

uint64_t VoteNetTrainingOptions::WeightSeed() const {
  // A large odd step (the golden ratio's, as splitmix64 uses) so that the
  // members of seed s and of seed s + 1 do not meet.
  return seed + static_cast<uint64_t>(member) * 0x9E3779B97F4A7C15ULL;
}

bool VoteNetTrainingOptions::FusesFrame(int64_t frame_id) const {
  if (fused_share <= 0) return false;
  if (fused_share >= 1) return true;
  FastRng rng(seed ^ (static_cast<uint64_t>(frame_id) * 0xD1B54A32D192ED03ULL));
  return rng.Uniform01() < fused_share;
}

FrameFusion VoteNetTrainingOptions::FusedFrames() const {
  FrameFusion fusion;
  fusion.room_frames = true;
  fusion.pose_noise_m = fused_pose_noise_m;
  fusion.pose_noise_deg = fused_pose_noise_deg;
  fusion.planar_noise = fused_planar_noise;
  return fusion;
}

namespace {

// The room's scans fused in the camera of scans[reference], the others'
// poses with the fusion's error; copied only when there is an error.
DetectionInput FusedScan(const std::vector<DetectionInput>& scans,
                         const RoomRecord& room,
                         size_t reference,
                         const FrameFusion& fusion) {
  if (!fusion.HasPoseError()) return FuseScans(scans, reference);
  std::vector<DetectionInput> mates = scans;
  PerturbRoomMates(room, reference, fusion, &mates);
  return FuseScans(mates, reference);
}

}  // namespace

void VoteNetStageTimes::Add(const VoteNetStepTimes& step) {
  tensors_s += step.tensors_s;
  forward_s += step.forward_s;
  backward_s += step.backward_s;
  update_s += step.update_s;
  steps += step.steps;
}

void VoteNetStageTimes::AddTrainingOf(const VoteNetStageTimes& member) {
  batch_s += member.batch_s;
  tensors_s += member.tensors_s;
  forward_s += member.forward_s;
  backward_s += member.backward_s;
  update_s += member.update_s;
  average_s += member.average_s;
  validation_s += member.validation_s;
  steps += member.steps;
}

std::string VoteNetStageTimes::Text() const {
  char text[512];
  std::snprintf(text,
                sizeof text,
                "generate %.1f, read %.1f, rasterise %.1f, batches %.1f, tensors %.1f, forward "
                "%.1f, backward %.1f, Adam %.1f, average %.1f, validation %.1f, operating point "
                "%.1f (%lld steps)",
                generate_s,
                read_s,
                raster_s,
                batch_s,
                tensors_s,
                forward_s,
                backward_s,
                update_s,
                average_s,
                validation_s,
                operating_point_s,
                static_cast<long long>(steps));
  return text;
}

void ReadBevSamples(const std::string& db_path,
                    const VoteNetTrainingOptions& options,
                    std::vector<BevSample>* training,
                    std::vector<BevSample>* validation,
                    VoteNetStageTimes* stages,
                    SampleShare* share) {
  DatasetDb db(db_path, DatasetDb::Mode::kReadOnly);
  const int rank = share != nullptr && share->group != nullptr ? share->group->rank() : 0;
  const int world = share != nullptr && share->group != nullptr ? share->group->world() : 1;
  if (share != nullptr) *share = SampleShare{share->group, 0, {}};
  size_t training_rooms = 0;
  const std::vector<int64_t> rooms = db.RoomIds();
  // Every k-th room validates (none when the share is 0 or there is one room).
  const int every = options.validation_share > 0 && rooms.size() > 1
                        ? std::max(2, static_cast<int>(std::lround(1 / options.validation_share)))
                        : 0;
  auto destination = [&](size_t k) {
    return every > 0 && static_cast<int>(k % every) == every - 1 ? validation : training;
  };
  size_t to_read = 0;
  for (size_t k = 0; k < rooms.size(); ++k) to_read += destination(k) != nullptr;
  const FrameFusion fusion = options.FusedFrames();
  Progress progress("rasterise", to_read, "rooms");
  for (size_t k = 0; k < rooms.size(); ++k) {
    std::vector<BevSample>* out = destination(k);
    if (out == nullptr) continue;  // the caller wants the other share only
    const bool mine =
        out == training ? static_cast<int>(training_rooms++ % world) == rank : rank == 0;
    if (!mine) {  // another rank's room: only where its frames lie in the set
      if (out == training && share != nullptr) {
        const size_t frames = db.ReadRoom(rooms[k], /*with_images=*/false).frames.size();
        share->local_of.insert(share->local_of.end(), frames, -1);
      }
      progress.Advance();
      continue;
    }
    const auto read_start = std::chrono::steady_clock::now();
    const RoomRecord room = db.ReadRoom(rooms[k], /*with_images=*/true);
    const int frames = static_cast<int>(room.frames.size());
    // The room's frames decoded, then rasterised, each on the pool: every
    // sample a pure function of its frame (and its room-mates when fused),
    // kept in the frames' order.
    std::vector<DetectionInput> scans(room.frames.size());
    std::vector<const FrameRecord*> room_frames;
    for (const FrameRecord& frame : room.frames) room_frames.push_back(&frame);
    ParallelFor(0, frames, [&](int f) {
      const FrameRecord& frame = room.frames[f];
      scans[f] = DetectionInputOf(frame, db_path + " frame " + std::to_string(frame.id));
    });
    const auto raster_start = std::chrono::steady_clock::now();
    if (stages != nullptr)
      stages->read_s += std::chrono::duration<double>(raster_start - read_start).count();
    std::vector<BevSample> samples(room.frames.size());
    ParallelFor(0, frames, [&](int f) {
      const FrameRecord& frame = room.frames[f];
      const bool fused = options.FusesFrame(frame.id);
      BevSample& sample = samples[f];
      sample.image =
          RasteriseScan(fused ? FusedScan(scans, room, f, fusion).points : scans[f].points,
                        frame.world_from_camera,
                        options.net.range_m,
                        options.net.grid);
      AddObjectsSeenBy(room,
                       fused ? room_frames : std::vector<const FrameRecord*>{&frame},
                       options.min_visibility,
                       &sample);
    });
    for (BevSample& sample : samples) {
      if (out == training && share != nullptr)
        share->local_of.push_back(static_cast<int64_t>(training->size()));
      out->push_back(std::move(sample));
    }
    if (stages != nullptr) stages->raster_s += Seconds(raster_start);
    progress.Advance();
  }
  progress.Finish();
  if (share != nullptr) share->total = share->local_of.size();
}

namespace {

// The training frames' targets (over the group's ranks' frames).
int CountTargets(const std::vector<BevSample>& training, DataParallelGroup* group) {
  std::vector<double> count{0};
  for (const BevSample& sample : training) {
    for (const BevObject& object : sample.objects) count[0] += object.target;
  }
  if (group != nullptr) group->SumDoubles(&count);
  return static_cast<int>(count[0]);
}

// A batch of the whole set's frames cut to those this rank holds, as indices
// into its own samples.
void KeepLocalPart(const SampleShare& share,
                   std::vector<size_t>* indices,
                   std::vector<char>* mirror) {
  std::vector<size_t> local;
  std::vector<char> local_mirror;
  for (size_t i = 0; i < indices->size(); ++i) {
    const int64_t at = share.local_of[(*indices)[i]];
    if (at < 0) continue;
    local.push_back(static_cast<size_t>(at));
    local_mirror.push_back((*mirror)[i]);
  }
  *indices = std::move(local);
  *mirror = std::move(local_mirror);
}

// The epoch's validation figures of `kept` (the network training returns),
// and of the last step's weights where they differ.
void ValidateEpoch(const VoteNet& kept,
                   const VoteNet* last,
                   const std::vector<BevSample>& validation,
                   const VoteNetTrainingOptions& options,
                   VoteNetEpoch* record) {
  record->last_weights_map = std::nan("");
  if (validation.empty()) return;
  // One forward pass a frame gives the loss and the maxima the mAP scores.
  std::vector<FrameOutcome> decoded;
  record->validation_terms = ValidationLoss(kept, validation, options, &decoded);
  record->validation_loss = record->validation_terms.Total();
  record->validation_map = ValidationMeanAp(decoded);
  if (last != nullptr) record->last_weights_map = ValidationMeanAp(*last, validation);
}

void PrintEpoch(const VoteNetEpoch& record, int epochs, bool validated) {
  std::string last;
  if (!std::isnan(record.last_weights_map)) {
    char text[64];
    std::snprintf(text, sizeof(text), " (last weights %.3f)", record.last_weights_map);
    last = text;
  }
  if (!validated) {
    std::fprintf(stderr,
                 "vote net: epoch %d/%d: training loss %.3f (%.0f s)\n",
                 record.epoch,
                 epochs,
                 record.train_loss,
                 record.seconds);
    return;
  }
  std::fprintf(stderr,
               "vote net: epoch %d/%d: training loss %.3f, validation loss %.3f, "
               "validation mAP@10cm %.3f%s (%.0f s)\n",
               record.epoch,
               epochs,
               record.train_loss,
               record.validation_loss,
               record.validation_map,
               last.c_str(),
               record.seconds);
}

// One epoch's steps over the shuffled `order`: each batch made (mirrored at
// random, cut to this rank's frames), the optimiser stepped on the cosine
// schedule, the weight average updated. Returns the epoch's summed loss.
struct EpochSteps {
  const std::vector<BevSample>& training;
  const VoteNetTrainingOptions& options;
  const SampleShare* share;
  VoteNet& net;
  VoteNetOptimizer& optimizer;
  std::optional<VoteNetWeightAverage>& average;
  std::mt19937_64& random;
  VoteNetTrainingSummary* summary;
  Progress& progress;
  size_t total_steps;

  double Run(int epoch, const std::vector<size_t>& order, size_t* step) const {
    double loss_sum = 0;
    for (size_t first = 0; first < order.size(); first += options.batch_size) {
      std::vector<size_t> indices(
          order.begin() + first,
          order.begin() + std::min(order.size(), first + options.batch_size));
      std::vector<char> mirror(indices.size());
      for (char& m : mirror) m = static_cast<char>(random() & 1);
      auto lap = std::chrono::steady_clock::now();
      if (share != nullptr) KeepLocalPart(*share, &indices, &mirror);
      const TrainingBatch batch = MakeTrainingBatch(training, indices, mirror, options.net.coder);
      summary->stages.batch_s += Seconds(lap);
      const VoteNetLoss loss =
          optimizer.Step(batch, CosineLearningRate(*step, total_steps, options.learning_rate));
      lap = std::chrono::steady_clock::now();
      if (average) average->Update(net);
      summary->stages.average_s += Seconds(lap);
      loss_sum += loss.Total();
      ++*step;
      char note[64];
      std::snprintf(note, sizeof(note), "epoch %d loss %.3f", epoch + 1, loss.Total());
      progress.SetNote(note);
      progress.Advance();
    }
    return loss_sum;
  }
};

// The training's state after `epochs_done` epochs, to its checkpoint file.
struct CheckpointState {
  std::string path, fingerprint;
  VoteNet* net = nullptr;
  VoteNetOptimizer* optimizer = nullptr;
  std::optional<VoteNetWeightAverage>* average = nullptr;
  std::mt19937_64* random = nullptr;

  bool enabled() const { return !path.empty(); }

  void Save(int epochs_done, size_t steps_done, const std::vector<VoteNetEpoch>& epochs) const {
    VoteNetCheckpoint checkpoint;
    checkpoint.fingerprint = fingerprint;
    checkpoint.epochs_done = epochs_done;
    checkpoint.steps_done = steps_done;
    std::ostringstream generator;
    generator << *random;
    checkpoint.generator = generator.str();
    checkpoint.net = net->Serialize();
    checkpoint.adam = optimizer->SaveState();
    if (*average) {
      checkpoint.average = (*average)->average().Serialize();
      checkpoint.average_updates = (*average)->updates();
    }
    checkpoint.epochs = epochs;
    WriteCheckpoint(path, checkpoint);
  }

  // The epochs a checkpoint of this training holds (0: none), restored.
  int Resume(size_t* step, VoteNetTrainingSummary* summary, bool quiet) const {
    const std::optional<VoteNetCheckpoint> saved = ReadCheckpoint(path, fingerprint, quiet);
    if (!saved) return 0;
    optimizer->RestoreState(VoteNet::Deserialize(saved->net, path), saved->adam, path);
    Require(saved->average.empty() == !average->has_value(),
            path + ": its weight average does not match the options'");
    if (*average)
      (*average)->Restore(VoteNet::Deserialize(saved->average, path), saved->average_updates);
    std::istringstream generator(saved->generator);
    generator >> *random;
    Require(!generator.fail(), path + ": its generator state is not readable");
    *step = saved->steps_done;
    summary->epochs = saved->epochs;
    if (!quiet)
      std::fprintf(
          stderr, "vote net: resuming after epoch %d from %s\n", saved->epochs_done, path.c_str());
    return saved->epochs_done;
  }
};

}  // namespace

VoteNet TrainVoteNetOnSamples(const std::vector<BevSample>& training,
                              const std::vector<BevSample>& validation,
                              const VoteNetTrainingOptions& options,
                              VoteNetTrainingSummary* summary,
                              const VoteNet* tune_from,
                              const SampleShare* share) {
  options.Check();
  const size_t total = share != nullptr ? share->total : training.size();
  Require(total > 0, "the vote network has no training frames");
  Require(share == nullptr || share->local_of.size() == total,
          "a data-parallel share names every frame of the set");
  DataParallelGroup* group = share != nullptr ? share->group : nullptr;
  Require(tune_from == nullptr ||
              (tune_from->Members() == 1 && tune_from->options().grid == options.net.grid),
          "fine-tuning needs one network (not an ensemble) of the training options' grid");
  const int previous_threads = TorchThreads();
  SetTorchThreads(options.threads);
  VoteNet net = tune_from != nullptr
                    ? VoteNet::Deserialize(tune_from->Serialize(), "the network to tune")
                    : VoteNet::Create(options.net, options.WeightSeed());
  net.SetPrecision(options.precision);
  VoteNetOptimizer optimizer(&net, options.loss);
  optimizer.JoinGroup(group);
  std::optional<VoteNetWeightAverage> average;
  if (options.weight_average > 0) average.emplace(net, options.weight_average);
  summary->parameters = net.Parameters();
  summary->precision = net.precision();
  summary->frames = static_cast<int>(total);
  summary->validation_frames = static_cast<int>(validation.size());
  summary->objects = CountTargets(training, group);
  std::mt19937_64 random(options.WeightSeed() * 7919 + 17);
  const size_t steps_per_epoch = (total + options.batch_size - 1) / options.batch_size;
  const size_t total_steps = steps_per_epoch * options.epochs;
  size_t step = 0;
  CheckpointState checkpoint;  // one process from scratch: not a rank, not a fine-tuning
  if (!options.checkpoint_path.empty() && group == nullptr && tune_from == nullptr) {
    checkpoint = {MemberCheckpointPath(options.checkpoint_path, options.member),
                  TrainingFingerprint(training, validation, options, net),
                  &net,
                  &optimizer,
                  &average,
                  &random};
  }
  const int resumed = checkpoint.enabled() ? checkpoint.Resume(&step, summary, options.quiet) : 0;
  Progress progress("train vote net", total_steps - step, "steps");  // what is left to do
  const EpochSteps steps{
      training, options, share, net, optimizer, average, random, summary, progress, total_steps};
  std::vector<size_t> order(total);
  const auto start = std::chrono::steady_clock::now();
  for (int epoch = resumed; epoch < options.epochs; ++epoch) {
    const auto epoch_start = std::chrono::steady_clock::now();
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), random);
    const double loss_sum = steps.Run(epoch, order, &step);
    AverageBuffersOverGroup(&net, group);
    VoteNetEpoch record;
    record.epoch = epoch + 1;
    record.train_loss = loss_sum / steps_per_epoch;
    const auto validation_start = std::chrono::steady_clock::now();
    ValidateEpoch(average ? average->average() : net,
                  average && options.keep_last_weights ? &net : nullptr,
                  validation,
                  options,
                  &record);
    summary->stages.validation_s += Seconds(validation_start);
    record.seconds = Seconds(epoch_start);
    summary->epochs.push_back(record);
    if (!options.quiet) PrintEpoch(record, options.epochs, !validation.empty());
    if (checkpoint.enabled()) checkpoint.Save(epoch + 1, step, summary->epochs);
  }
  progress.Finish();
  summary->train_s = Seconds(start);
  summary->stages.Add(optimizer.times());
  SetTorchThreads(previous_threads);
  if (!average) return net;
  if (options.keep_last_weights) summary->last_weights = net.Serialize();
  return average->Take();
}

VoteNet TrainVoteNetEnsemble(const std::vector<BevSample>& training,
                             const std::vector<BevSample>& validation,
                             const VoteNetTrainingOptions& options,
                             VoteNetTrainingSummary* summary) {
  VoteNet first = TrainVoteNetOnSamples(training, validation, options, summary);
  if (options.ensemble == 1) return first;
  std::vector<VoteNet> members;
  members.push_back(std::move(first));
  for (int m = 1; m < options.ensemble; ++m) {
    VoteNetTrainingOptions member = options;
    member.member = options.member + m;
    member.ensemble = 1;
    member.curve_png.clear();
    if (!options.quiet)
      std::fprintf(stderr, "vote net: ensemble member %d of %d\n", m + 1, options.ensemble);
    VoteNetTrainingSummary member_summary;
    members.push_back(TrainVoteNetOnSamples(training, validation, member, &member_summary));
    summary->train_s += member_summary.train_s;
    summary->stages.AddTrainingOf(member_summary.stages);
    summary->member_validation_maps.push_back(member_summary.epochs.back().validation_map);
  }
  VoteNet ensemble = VoteNet::Ensemble(std::move(members), "the vote network's ensemble");
  summary->parameters = ensemble.Parameters();
  summary->precision = ensemble.precision();
  if (!validation.empty()) {
    summary->ensemble_validation_map = ValidationMeanAp(ensemble, validation);
    if (!options.quiet)
      std::fprintf(stderr,
                   "vote net: the ensemble of %d: validation mAP@10cm %.3f\n",
                   options.ensemble,
                   summary->ensemble_validation_map);
  }
  return ensemble;
}

OperatingPoint VoteNetOperatingPoint(const VoteNet& net, const std::vector<BevSample>& validation) {
  Require(!validation.empty(), "an operating point needs validation frames");
  const std::vector<FrameOutcome> frames =
      DecodedFrames(net, validation, DetectorOptions{}.LearnedDecode(), true);
  EvaluationOptions roles;  // as evaluate counts objects: 25 % visible, within 3 m
  roles.max_distance_m = DetectorOptions{}.max_range_m;
  return ChooseOperatingPoint(frames,
                              roles,
                              kOperatingMatchM,
                              std::to_string(validation.size()) +
                                  " validation frames of the training rooms (the network's "
                                  "maxima at the default decoding)");
}

OperatingPoint VoteNetOperatingPointOnRooms(const TrainedModel& model,
                                            const std::string& model_path,
                                            const std::string& rooms_path) {
  Require(!model.vote_net.empty(),
          model_path + ": has no vote network (--training-rooms needs one)");
  VoteNet net = VoteNet::Deserialize(model.vote_net, model_path);
  net.SetPrecision(NetworkPrecision::kAuto);  // as detection runs it here
  VoteNetTrainingOptions rooms;
  rooms.net = net.options();
  std::vector<BevSample> validation;
  ReadBevSamples(rooms_path, rooms, nullptr, &validation);  // the validation rooms alone
  Require(!validation.empty(), rooms_path + ": has no validation room (every 10th room)");
  return VoteNetOperatingPoint(net, validation);
}

namespace {

// The training curve (loss, validation mAP per epoch) as a PNG.
void WriteCurve(const VoteNetTrainingSummary& summary, bool validated, const std::string& png) {
  std::vector<TrainingCurvePoint> curve;
  for (const VoteNetEpoch& e : summary.epochs)
    curve.push_back({e.epoch,
                     e.train_loss,
                     e.validation_loss,
                     validated ? e.validation_map : std::nan(""),
                     e.last_weights_map});
  WriteTrainingCurvePng(curve,
                        "vote network: " + std::to_string(summary.frames) + " frames of " +
                            std::to_string(summary.rooms) + " rooms",
                        png);
}

}  // namespace

std::string TrainVoteNet(const Catalog& catalog,
                         const std::set<std::string>& held_out,
                         const VoteNetTrainingOptions& options,
                         const std::string& rooms_db,
                         VoteNetTrainingSummary* summary) {
  options.Check();
  const Catalog training_catalog = TrainingCatalog(catalog, held_out, options);
  const GenerateOptions generate = TrainingRooms(options, training_catalog.description(), held_out);
  for (const CatalogEntry* entry : catalog.Classified())
    summary->vote_net_only_models += entry->vote_net_only && !held_out.count(entry->id);
  auto start = std::chrono::steady_clock::now();
  std::optional<CachedRooms> cached;  // locked until the rooms are read
  if (!options.rooms_cache.empty()) {
    cached.emplace(options.rooms_cache, training_catalog, generate, options.quiet);
    summary->rooms_path = cached->path();
    summary->rooms_reused = cached->rooms_present();
  } else {
    summary->rooms_path = rooms_db;
    // A database kept from an earlier run resumes (rooms already in it are
    // skipped); one of other options is refused by GenerateDataset.
    if (!options.keep_rooms || !options.room_shards.empty()) RemoveDatabaseFiles(rooms_db);
    // MergeDatasets refuses shards that lack any of the generation's rooms.
    if (!options.room_shards.empty()) MergeDatasets(options.room_shards, rooms_db);
  }
  if (!options.quiet && cached) {
    std::fprintf(stderr,
                 "vote net: %d training rooms in the rooms cache %s: %d there, %d to make\n",
                 options.rooms,
                 summary->rooms_path.c_str(),
                 summary->rooms_reused,
                 options.rooms - summary->rooms_reused);
  } else if (!options.quiet) {
    std::fprintf(stderr,
                 "vote net: %s %d training rooms into %s\n",
                 options.room_shards.empty() ? "generating" : "merged",
                 options.rooms,
                 summary->rooms_path.c_str());
  }
  const GenerateSummary generated =
      GenerateDataset(training_catalog, generate, summary->rooms_path);
  summary->rooms = generated.rooms_in_shard;
  summary->generate_s = Seconds(start);
  summary->stages.generate_s = summary->generate_s;
  start = std::chrono::steady_clock::now();
  LocalGroup group(options, summary->rooms_path);
  std::vector<BevSample> training, validation;
  SampleShare share{group.group(), 0, {}};
  ReadBevSamples(summary->rooms_path,
                 options,
                 &training,
                 &validation,
                 &summary->stages,
                 share.group ? &share : nullptr);
  cached.reset();
  summary->raster_s = Seconds(start);
  VoteNet net;
  try {
    net = share.group
              ? TrainVoteNetOnSamples(training, validation, options, summary, nullptr, &share)
              : TrainVoteNetEnsemble(training, validation, options, summary);
  } catch (const std::runtime_error& e) {
    group.Explain(e);
  }
  group.Finish();
  start = std::chrono::steady_clock::now();
  if (!validation.empty()) summary->operating_point = VoteNetOperatingPoint(net, validation);
  summary->stages.operating_point_s = Seconds(start);
  if (!validation.empty() && !summary->last_weights.empty()) {
    VoteNet last = VoteNet::Deserialize(summary->last_weights, "the last weights");
    last.SetPrecision(summary->precision);
    summary->last_operating_point = VoteNetOperatingPoint(last, validation);
  }
  if (!options.keep_rooms && options.rooms_cache.empty()) RemoveDatabaseFiles(rooms_db);
  if (!options.curve_png.empty()) WriteCurve(*summary, !validation.empty(), options.curve_png);
  return net.Serialize();
}

void TrainVoteNetWorker(const VoteNetTrainingOptions& options, const std::string& rooms_path) {
  options.Check();
  Require(options.data_parallel.Active() && options.data_parallel.rank > 0,
          "a vote-net worker has a rank above 0 of two or more");
  DataParallelGroup group(options.data_parallel);
  const std::string rooms = group.Broadcast(kRoomsKey, rooms_path);
  SampleShare share{&group, 0, {}};
  std::vector<BevSample> training, validation;
  ReadBevSamples(rooms, options, &training, &validation, nullptr, &share);
  VoteNetTrainingSummary summary;
  TrainVoteNetOnSamples(training, validation, options, &summary, nullptr, &share);
}

int GenerateTrainingRoomsShard(const Catalog& catalog,
                               const std::set<std::string>& held_out,
                               const VoteNetTrainingOptions& options,
                               int shard,
                               int shards,
                               const std::string& out) {
  options.Check();
  const Catalog training_catalog = TrainingCatalog(catalog, held_out, options);
  GenerateOptions generate = TrainingRooms(options, training_catalog.description(), held_out);
  generate.shard_index = shard;
  generate.shard_count = shards;
  return GenerateDataset(training_catalog, generate, out).rooms_in_shard;
}

}  // namespace furn

// Training of the learned vote map (issue 30) from the workbench's own rooms:
// `generate` composes rooms from the training catalog only (held-out models
// and evaluation-only entries never placed), renders them with the sensor
// model, and each frame becomes a bird's-eye-view image (RasteriseScan, as
// detection makes it) with its labelled objects as targets. The network is
// trained with Adam on a cosine schedule, mirrored images as augmentation,
// a progress bar showing the loss, and a validation loss per epoch.
//
//   VoteNetTrainingOptions options;
//   VoteNetTrainingSummary summary;
//   const std::string bytes = TrainVoteNet(catalog, held_out, options, &summary);
//   model.vote_net = bytes;
#pragma once

#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "core/learned/bev_box_coder.h"
#include "core/learned/data_parallel.h"
#include "core/learned/vote_net.h"
#include "core/learned/vote_net_training.h"
#include "core/model/operating_point.h"
#include "core/model/trained_model.h"
#include "renderers/kinect_noise.h"
#include "scenes/catalog.h"
#include "scenes/procedural_shapes.h"
#include "scenes/room_composer.h"

namespace furn {

struct FrameFusion;  // workbench/formats/scan_file.h

// Protocol E's mAP@10cm at the default budget (VoteNetTrainingOptions'
// defaults): nine fold networks of fold seeds 1-3 (docs/learned-voting.md,
// "2400 rooms"). What a figure of fewer rooms or epochs is set beside.
inline constexpr double kDefaultBudgetProtocolEMap = 0.552;

struct VoteNetTrainingOptions {
  // 2400 rooms x 4 frames, 10 epochs: twice the steps of 1200 x 10 (itself
  // 600 x 20's steps over twice the rooms: +0.025 mAP@10cm over seven paired
  // fold networks) and twice the rooms again. Two paired fold networks of
  // protocol E: mAP@10cm +0.017 and +0.152, tables +0.060 and +0.149, table
  // centre error 7.6 -> 3.7 and 8.7 -> 7.9 cm; the real set held with fewer
  // false detections. Measured on an idle 2-core machine: `train --catalog
  // default` 34.5 min (the network 25.6), 4.25 GB resident at the peak
  // (docs/learned-voting.md, "2400 rooms").
  int rooms = 2400;  // generated training rooms
  int frames_per_room = 4;
  uint64_t seed = 1;  // rooms, weights, batches, augmentation
  // An ensemble's member: member k > 0 draws its own weights, batches and
  // augmentation (WeightSeed) from the same rooms as member 0, which is the
  // plain training (VoteNet::Ensemble combines members).
  int member = 0;
  // Networks trained on the rooms, members member .. member + ensemble - 1,
  // combined into one (VoteNet::Ensemble): detection averages them. Each
  // costs one network's training; with the mirror average two cost what one
  // does at detection (member 2 answers the mirror). Three fold networks
  // with a second member: mAP@10cm +0.002 over the members' mean, tables
  // 0.000 (docs/learned-voting.md, "an ensemble of two"): 1 by default.
  int ensemble = 1;
  int epochs = 10;
  // Batch 8 at peak rate 0.004 measured better than 16 at 0.002 for the same
  // frames (seen-model rooms, mAP@10cm 0.27 against 0.17): more steps.
  int batch_size = 8;
  double learning_rate = 4e-3;  // peak; cosine decay to 5 % of it
  // Torch's intra-op threads while training; `train` gives it the CPUs the
  // run may use (the worker pool's count) unless --vote-threads is given.
  int threads = 2;
  // The arithmetic of the network's passes (core/learned/vote_net.h): auto
  // trains in bfloat16 on a CPU with AMX-BF16 (each step 1.7 to 2.2 times
  // faster), in float elsewhere.
  NetworkPrecision precision = NetworkPrecision::kAuto;
  // Objects seen less than this (visible / amodal pixels) are not targets;
  // the loss ignores the heat around them (BevCoderOptions::ignore_radius_cells).
  double min_visibility = 0.15;
  double validation_share = 0.1;  // of the rooms, for the per-epoch validation loss
  // The network kept is the exponential moving average of its weights over
  // the steps with this decay (VoteNetWeightAverage); 0: the last step's
  // weights. At 0.999, three fold networks against their own last weights:
  // mAP@10cm -0.003, tables lower on all three (docs/learned-voting.md).
  double weight_average = 0;
  // With weight_average: the last step's weights too
  // (VoteNetTrainingSummary::last_weights), for measuring the average
  // against them on one training run.
  bool keep_last_weights = false;
  VoteNetOptions net;  // with net.coder: what the targets are; net.range_m: the points rasterised
  VoteNetLossWeights loss;  // the loss terms' weights
  // Of the training rooms (evaluation-only entries never placed); sizes
  // jittered by 20 % per side so that the network learns classes, not models.
  RoomOptions room = [] {
    RoomOptions jittered;
    jittered.size_jitter = 0.2;
    return jittered;
  }();
  // The Kinect model the training rooms are rendered with (issue 69): the
  // published one, or a fit to real frames (`dataset noise --fit`,
  // `train --vote-sensor FILE`).
  KinectNoiseOptions sensor;
  // Procedural tables and sideboards per class (scenes/procedural_shapes.h)
  // added to the training rooms' catalog, never to evaluation; 0: none.
  int shape_variety = 0;
  // The share of the frames (training and validation alike) rasterised with
  // their room's other frames fused in (FuseScans, seen from the frame's own
  // camera, exact poses), as `detect --fuse` and `evaluate
  // --fuse-room-frames` see a place; their targets are the objects any of
  // the fused frames sees. 0: every frame alone (the default); 1: every
  // frame fused. Which frames: drawn from `seed` and the frame's id.
  double fused_share = 0;
  // The fused frames' room-mates with a random pose error, as odometry
  // gives them (PerturbedPose: sigma metres along and degrees about each
  // axis; planar: along x and y and about z only; drawn as `evaluate
  // --fuse-pose-noise` draws it); 0: exact poses.
  double fused_pose_noise_m = 0;
  double fused_pose_noise_deg = 0;
  bool fused_planar_noise = false;
  // Their sizes: the catalog's range, or widened to the class's usual sizes
  // with cloths on a share of the tables (scenes/procedural_shapes.h).
  ShapeSizes shape_sizes = ShapeSizes::kCatalog;
  bool keep_rooms = false;  // keep the rooms' database after training (else deleted)
  // A directory where the rooms are kept by what decides them and reused by
  // any later training of the same rooms (workbench/pipelines/rooms_cache.h);
  // empty: none. Not with keep_rooms or room_shards.
  std::string rooms_cache;
  // The training rooms made elsewhere (the tasks of `train --shards N`, each
  // by GenerateTrainingRoomsShard): merged into the rooms' database instead
  // of generating the rooms here; empty: generated here.
  std::vector<std::string> room_shards;
  std::string curve_png;  // the training curve (loss, validation mAP); empty: none
  // Data-parallel training (issue 70): `workers` processes of this machine
  // train the network together, each rasterising and training on its share
  // of the rooms, the gradients summed every step (c10d over Gloo:
  // core/learned/data_parallel.h). This process is rank 0 and starts the
  // others with worker_command (the program and its arguments; their rank,
  // the group's size, store and the rooms are appended as --vote-worker-*
  // flags) once the rooms are made. 1: one process.
  int workers = 1;
  std::vector<std::string> worker_command;
  // In a worker process: its rank, the group's size and store. With rank 0,
  // this process leads a group started elsewhere (the tasks of a Slurm
  // job, `train --vote-workers N --slurm`) and starts no workers.
  DataParallelOptions data_parallel;
  // After every epoch the training's whole state (weights, Adam's moments,
  // the generator, the average, the epochs' records) goes to this file,
  // atomically; a training that finds one of its own (same samples, options
  // and initial weights) resumes after its last epoch, to the same bytes
  // as an uninterrupted run (workbench/pipelines/vote_net_checkpoint.h).
  // Empty: none. Not in data-parallel training. An ensemble's member k > 0
  // uses "<path>.member<k>".
  std::string checkpoint_path;
  bool quiet = false;

  void Check() const;
  // Everything that decides the weights, as JSON (for caches).
  std::string Json() const;
  // The seed of the weights, batches and augmentation: `seed` for member 0.
  uint64_t WeightSeed() const;
  // Whether the frame of this id is rasterised fused (fused_share).
  bool FusesFrame(int64_t frame_id) const;
  // The fusion the fused frames get (exact poses unless a pose error is set).
  FrameFusion FusedFrames() const;
};

struct VoteNetEpoch {
  int epoch = 0;
  double train_loss = 0, validation_loss = 0;
  VoteNetLoss validation_terms;
  double validation_map = 0;  // mAP@10cm of the decoded maxima (NaN: no objects)
  // With a weight average, validation_map is the average's and this the
  // last step's weights' (else NaN).
  double last_weights_map = 0;
  double seconds = 0;
};

// Where the vote network's training time goes (issue 70), seconds: the
// rooms generated (or merged), read back from their database (rows, depth
// PNGs decoded, points), rasterised; then per step the batch made (targets
// encoded, mirrored), turned into tensors, the forward pass with the loss,
// the backward pass, Adam's update and the weight average; per epoch the
// validation (loss and the decoded maxima's mAP); at the end the operating
// point chosen.
struct VoteNetStageTimes {
  double generate_s = 0, read_s = 0, raster_s = 0;
  double batch_s = 0, tensors_s = 0, forward_s = 0, backward_s = 0, update_s = 0, average_s = 0;
  double validation_s = 0, operating_point_s = 0;
  int64_t steps = 0;
  void Add(const VoteNetStepTimes& step);
  // Another network's training stages (an ensemble's member: batches to validation).
  void AddTrainingOf(const VoteNetStageTimes& member);
  // "generate 1.0, read 2.0, ..." (seconds), for the stage-time line.
  std::string Text() const;
};

struct VoteNetTrainingSummary {
  int rooms = 0, frames = 0, objects = 0, validation_frames = 0;
  int rooms_reused = 0;          // of `rooms`, found in the rooms cache
  int vote_net_only_models = 0;  // the class map's extra models its rooms may place
  std::string rooms_path;        // where the rooms were (the cache's file, or rooms_db)
  int64_t parameters = 0;
  NetworkPrecision precision = NetworkPrecision::kFloat32;  // resolved: what the steps ran in
  std::vector<VoteNetEpoch> epochs;
  double generate_s = 0, raster_s = 0, train_s = 0;
  VoteNetStageTimes stages;  // the same time, by stage (raster_s = stages' read + raster)
  // Chosen on the validation frames (VoteNetOperatingPoint); empty without.
  OperatingPoint operating_point;
  // With keep_last_weights: the last step's network (VoteNet::Serialize) and
  // its operating point; else empty.
  std::string last_weights;
  OperatingPoint last_operating_point;
  // An ensemble's members after the first: validation mAP@10cm of each
  // after its last epoch (`epochs` are the first member's); and the
  // ensemble's own (NaN: one network or no validation frames).
  std::vector<double> member_validation_maps;
  double ensemble_validation_map = std::numeric_limits<double>::quiet_NaN();
};

// A data-parallel rank's part of the training frames (issue 70): the whole
// set's size and, per frame of the whole set in its order, the index of this
// rank's copy among its training samples (-1: another rank holds it). Every
// rank draws the whole set's batches from the same seed, and trains on the
// frames of each batch it holds, in `group`.
struct SampleShare {
  DataParallelGroup* group = nullptr;
  size_t total = 0;
  std::vector<int64_t> local_of;
};

// Trains on samples already made (tests, tools); `validation` may be empty.
// With `tune_from` (one network of options.net's grid and coder) its weights are
// trained on (fine-tuning, as `adapt --self-train` does) instead of fresh
// ones; `tune_from` itself is not changed.
VoteNet TrainVoteNetOnSamples(const std::vector<BevSample>& training,
                              const std::vector<BevSample>& validation,
                              const VoteNetTrainingOptions& options,
                              VoteNetTrainingSummary* summary,
                              const VoteNet* tune_from = nullptr,
                              const SampleShare* share = nullptr);

// TrainVoteNetOnSamples for options.ensemble networks (members
// options.member onwards) on the same samples, combined; one network when
// options.ensemble is 1. `summary->epochs` are the first member's.
VoteNet TrainVoteNetEnsemble(const std::vector<BevSample>& training,
                             const std::vector<BevSample>& validation,
                             const VoteNetTrainingOptions& options,
                             VoteNetTrainingSummary* summary);

// Per class, the heat of best F1 (matched at kOperatingMatchM) of the
// network's maxima, decoded as the detector does by default, on
// `validation` (not empty).
OperatingPoint VoteNetOperatingPoint(const VoteNet& net, const std::vector<BevSample>& validation);

// The same for a trained model, on the validation rooms of its training
// rooms database (`train --keep-rooms`: <model>.rooms.db); `model_path`
// names the model in errors.
OperatingPoint VoteNetOperatingPointOnRooms(const TrainedModel& model,
                                            const std::string& model_path,
                                            const std::string& rooms_path);

// Generates the rooms into rooms_db (resuming one already there; or merges
// options.room_shards into it, which must hold every room) or, with
// options.rooms_cache, finds them there or makes them there; rasterises
// their frames and trains; returns VoteNet::Serialize's bytes.
std::string TrainVoteNet(const Catalog& catalog,
                         const std::set<std::string>& held_out,
                         const VoteNetTrainingOptions& options,
                         const std::string& rooms_db,
                         VoteNetTrainingSummary* summary);

// What a data-parallel worker process (rank > 0 of options.data_parallel)
// does: joins the group, rasterises its share of the rooms in `rooms_path`
// (rank 0's rooms, which it tells the group, when empty: a Slurm job's
// ranks) and trains with the others; rank 0 (TrainVoteNet, with
// options.data_parallel of rank 0 when the group was started elsewhere)
// keeps the network.
void TrainVoteNetWorker(const VoteNetTrainingOptions& options, const std::string& rooms_path);

// Shard i/N of the training rooms TrainVoteNet generates, into `out`: what
// each task of `train --shards N` does. Returns the rooms written.
int GenerateTrainingRoomsShard(const Catalog& catalog,
                               const std::set<std::string>& held_out,
                               const VoteNetTrainingOptions& options,
                               int shard,
                               int shards,
                               const std::string& out);

// The frames of a dataset database as samples (noisy depth; objects seen at
// least min_visibility; a share fused with their room-mates, fused_share), split by room into
// training and validation; a null `training` or `validation` leaves its rooms unread (an operating
// point needs the validation rooms alone).
// With `stages`, adds the time reading the rooms and rasterising them.
// With `share` (its group set): only this rank's training rooms (every
// world-th, from its rank) are rasterised, and the share says where each
// frame of the whole set is; the validation rooms are rank 0's alone.
void ReadBevSamples(const std::string& db_path,
                    const VoteNetTrainingOptions& options,
                    std::vector<BevSample>* training,
                    std::vector<BevSample>* validation,
                    VoteNetStageTimes* stages = nullptr,
                    SampleShare* share = nullptr);

}  // namespace furn

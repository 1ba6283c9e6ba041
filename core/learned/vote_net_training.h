// The pieces of the vote network's training (issue 37), each apart: a
// sample (image and labelled objects), its augmentation (mirroring), a batch
// of encoded targets, the learning-rate schedule, and the optimiser (Adam)
// that steps the network on the loss of vote_net_loss.h. The loop that uses
// them, with rooms, epochs and validation, is the workbench's
// (workbench/pipelines/train_vote_net.h).
//
//   VoteNetOptimizer optimizer(&net, VoteNetLossWeights{});
//   const TrainingBatch batch = MakeTrainingBatch(samples, indices, mirror, coder);
//   const VoteNetLoss loss = optimizer.Step(batch, CosineLearningRate(step, steps, 4e-3));
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/learned/bev_box_coder.h"
#include "core/learned/data_parallel.h"
#include "core/learned/vote_net.h"
#include "core/learned/vote_net_loss.h"

namespace furn {

// One training frame: its BEV image and labelled objects (targets and the
// objects seen too little to be targets).
struct BevSample {
  BevImage image;
  std::vector<BevObject> objects;
  // Per object, the share of it in view (as evaluation counts visibility);
  // empty: unknown (every target counts as fully seen).
  std::vector<double> visibility;
  // Whether the cells away from every object are known background (a
  // labelled frame). False (a pseudo-labelled scan, whose unfound furniture
  // is unknown): only the cells within kUnknownBackgroundReachCells of a
  // target's footprint train; the rest neither reward nor punish.
  bool background_known = true;
};

// How far around a target's footprint (cells) a sample with unknown
// background still trains: its own cells and a margin of background.
inline constexpr int kUnknownBackgroundReachCells = 4;

// The sample mirrored left-right in its grid (image and objects).
BevSample MirroredSample(const BevSample& sample);

// Images and their encoded targets.
struct TrainingBatch {
  std::vector<BevImage> images;
  std::vector<BevTargets> targets;
};

// samples[indices[i]], mirrored where mirror[i] (empty: none mirrored).
TrainingBatch MakeTrainingBatch(const std::vector<BevSample>& samples,
                                const std::vector<size_t>& indices,
                                const std::vector<char>& mirror,
                                const BevCoderOptions& coder);

// Cosine decay from `peak` at step 0 to floor_share x peak at the last step.
double CosineLearningRate(size_t step, size_t total_steps, double peak, double floor_share = 0.05);

// Where a training step's time goes (seconds, summed over the steps):
// the batch's images and targets into tensors, the forward pass with the
// loss, the backward pass, and Adam's update.
struct VoteNetStepTimes {
  double tensors_s = 0, forward_s = 0, backward_s = 0, update_s = 0;
  int64_t steps = 0;
  double Total() const { return tensors_s + forward_s + backward_s + update_s; }
};

// Adam on a network; the network stays in evaluation mode between steps.
class VoteNetOptimizer {
 public:
  VoteNetOptimizer(VoteNet* net, const VoteNetLossWeights& weights);
  ~VoteNetOptimizer();
  VoteNetOptimizer(const VoteNetOptimizer&) = delete;
  VoteNetOptimizer& operator=(const VoteNetOptimizer&) = delete;

  // One step on the batch at `learning_rate`; returns the loss before it.
  // In a group, the batch is this rank's part of the group's batch (it may
  // be empty) and the loss returned is the whole batch's.
  VoteNetLoss Step(const TrainingBatch& batch, double learning_rate);
  // Data-parallel training (data_parallel.h): every step's normalisers,
  // gradients and loss are summed over the group's ranks, which then take
  // the same step. The group outlives the optimiser.
  void JoinGroup(DataParallelGroup* group);
  // The steps' times so far.
  const VoteNetStepTimes& times() const;
  // Adam's state (per parameter: its step count and both moments) as plain
  // records, for a checkpoint. RestoreState copies a checkpoint's weights
  // (and batch-norm statistics) into the network this optimiser steps, in
  // place, and reads Adam's records back; every length is the parameter's
  // own, so the bytes allocate nothing their parameters do not (InputError
  // naming `what` for records or weights of another network's shape).
  std::string SaveState() const;
  void RestoreState(const VoteNet& weights, const std::string& adam, const std::string& what);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The batch normalisations' running statistics (every floating buffer) of
// the group's copies of one network averaged over its ranks, in place: each
// rank normalised its own part of every batch.
void AverageBuffersOverGroup(VoteNet* net, DataParallelGroup* group);

// The exponential moving average of a network's weights over its training
// steps (Polyak averaging, as in YOLO's and timm's model EMA): after step t,
// average = d x average + (1 - d) x weights, with d = min(decay, (1 + t) /
// (10 + t)) so that the first steps are not held back by the random start.
// Batch norm's running statistics are averaged alike. The average of the
// last ~1 / (1 - decay) steps is meant to sit nearer the middle of the
// loss's valley than any one step; after the default cosine schedule, whose
// last epochs barely move the weights, it measured no better on unseen
// furniture (docs/learned-voting.md, "weight averaging").
class VoteNetWeightAverage {
 public:
  // Starts as a copy of `net`; decay in [0, 1).
  VoteNetWeightAverage(const VoteNet& net, double decay);
  // After each step of `net` (the network the average was made from).
  void Update(const VoteNet& net);
  const VoteNet& average() const { return average_; }
  // A checkpoint's average and its update count, in place of this one's.
  void Restore(VoteNet average, int64_t updates) {
    average_ = std::move(average);
    updates_ = updates;
  }
  // The average, moved out (the object is spent).
  VoteNet Take() { return std::move(average_); }
  int64_t updates() const { return updates_; }

 private:
  VoteNet average_;
  double decay_ = 0;
  int64_t updates_ = 0;
};

// Feature-statistics alignment (AdaBN: Li, Wang, Shi, Hou, Liu 2016,
// "Revisiting batch normalization for practical domain adaptation"): every
// batch normalisation's running mean and variance, in every member,
// re-estimated on `images` (a user's own scans; no labels) in batches of
// `batch_size`, in the given order, as the cumulative average over the
// batches; the weights stay. blend in [0, 1] mixes them: blend x the images'
// statistics + (1 - blend) x the network's (1: the images' alone, 0: nothing
// changes). Deterministic for the same images, order, batch and torch
// threads. Throws InputError for no images or a grid other than the
// network's.
struct NormalisationShift {
  int layers = 0;      // batch normalisations re-estimated (every member's)
  int64_t images = 0;  // images they were re-estimated on
  // Over every channel of every layer: mean |new mean - old mean| in units
  // of the old standard deviation, and the geometric mean of new / old
  // variance (1: unchanged).
  double mean_shift_sd = 0;
  double variance_ratio = 1;
};
NormalisationShift AdaptNormalisation(VoteNet* net,
                                      const std::vector<const BevImage*>& images,
                                      int batch_size,
                                      double blend);

// The loss of a batch without a step (evaluation mode). With `outputs`
// (a single network only), each image's answer is appended to it as
// VoteNet::Predict gives it (one forward pass for both; a batch's
// convolutions may round the last bit otherwise than one image's).
VoteNetLoss EvaluateVoteNetLoss(const VoteNet& net,
                                const TrainingBatch& batch,
                                const VoteNetLossWeights& weights,
                                std::vector<BevOutput>* outputs = nullptr);

}  // namespace furn

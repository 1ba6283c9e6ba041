// `workbench train`: virtual Kinect scans of every trainable class-mapped
// model (Embree + the sensor model, rings of viewpoints around the model),
// then core's TrainModel, saved as one model file.
//
//   TrainCommandOptions options;
//   TrainSummary summary = TrainFromCatalog(catalog, options, "model.fcm");
#pragma once

#include <set>
#include <string>
#include <vector>

#include "core/codebook/trainer.h"
#include "core/model/trained_model.h"
#include "scenes/catalog.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {

// Partial views of one model standing at the origin, yaw 0 (and of its
// scale variants, marked augmented).
std::vector<TrainingView> ScanModel(const CadModel& model,
                                    int model_index,
                                    FurnitureClass furniture_class,
                                    const ScanOptions& options);

// The mesh scaled about the model origin (the footprint centre on the floor).
TriangleMesh ScaledMesh(const TriangleMesh& mesh, const Eigen::Vector3f& scale);

struct TrainSummary {
  int models = 0;
  int views = 0;
  int segments = 0;
  int used_words = 0;
  double scan_s = 0, train_s = 0;  // train_s: TrainModel and saving
  TrainStageTimes stages;
  bool vote_net = false;  // a vote network was trained
  VoteNetTrainingSummary vote_net_training;
};

// Trains on the classified entries that are not evaluation-only and not in
// `held_out` (a leave-models-out fold); `scorer` (HypothesisScorer bytes, or
// empty) is stored in the model file as it is. With `vote_net`, a vote
// network is trained too (train_vote_net.h) on rooms generated into
// `out_path`.rooms.db from the same models.
TrainSummary TrainFromCatalog(const Catalog& catalog,
                              const ScanOptions& scan,
                              const TrainerOptions& trainer,
                              const std::string& out_path,
                              const std::set<std::string>& held_out = {},
                              const std::string& scorer = "",
                              const VoteNetTrainingOptions* vote_net = nullptr);

// Where `train --vote-keep-last-weights` writes the model with the vote
// network's last step's weights beside the averaged one: model.fcm ->
// model.last.fcm.
std::string LastWeightsModelPath(const std::string& model_path);

// The input a vote network trained with `options` was trained on, as the
// model file records it.
VoteNetInput VoteNetInputOf(const VoteNetTrainingOptions& options);
}  // namespace furn

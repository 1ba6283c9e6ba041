// The trained model (SPEC §7, §9): everything detection needs, as one
// versioned file. The codebook's vocabulary, shape model, part-subset
// library and model shapes; the CAD models' render meshes; the hypothesis
// scorer, the learned vote network (bytes: core/learned/ reads them) and the
// operating point.
//
//   TrainedModel model = LoadTrainedModel("model.fcm");
//   SaveTrainedModel(model, "copy.fcm");  // the same bytes
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/codebook/part_subsets.h"
#include "core/codebook/trainer_options.h"
#include "core/geometry/mesh.h"
#include "core/geometry/model_shape.h"
#include "core/model/furniture_class.h"
#include "core/model/operating_point.h"

namespace furn {

struct ShapeEntry {
  int word = 0;
  double probability = 0;  // p(A_word | f) of the training segment
  FurnitureClass furniture_class = FurnitureClass::kChair;
  int model_index = 0;
  Eigen::Vector2f relation = Eigen::Vector2f::Zero();  // view-aligned, metres
  float height = 0;                                    // segment centroid height (m)
};

// One part subset of a training view: its VFH and the CAD model it came from.
struct PartSubsetEntry {
  VfhDescriptor descriptor{};
  int model_index = 0;
};

// What input the vote network was trained on (model format 10): single
// frames, or a share of its frames fused with their room-mates' scans, those
// off by a random pose error (`train --vote-fused-share`,
// `--vote-fused-pose-noise`). Detection warns when it is given the other kind
// (docs/detection.md: a network trained on single frames loses on fused
// input with odometry's poses; one trained fused loses single frames'
// tables). Not recorded in a model file older than format 10.
struct VoteNetInput {
  bool recorded = false;
  double fused_share = 0;  // 0: single frames only
  double pose_noise_m = 0, pose_noise_deg = 0;
  bool planar = false;  // the error in x, y and yaw only

  bool Fused() const { return recorded && fused_share > 0; }
  // The one rule of `train` and the model reader: a share in 0..1, pose
  // errors in 0..1 m and 0..45 degrees (CheckPoseErrorSpreads), and none
  // without fused frames. Throws InputError naming the field.
  void Check() const;
  bool SingleFrames() const { return recorded && fused_share == 0; }
};

struct TrainedModel {
  TrainerOptions options;
  std::vector<std::string> model_names;
  std::vector<FurnitureClass> model_classes;
  FeatureNormalizer normalizer;
  Vocabulary vocabulary;
  std::vector<ShapeEntry> shape;  // every (segment, activated word)
  int training_segments = 0;
  std::vector<ModelShape> model_shapes;  // one per model name
  // Every part subset of every view: the CAD model it came from, and its VFH
  // in the index's principal components (PartSubsetIndex), in the same order.
  std::vector<int> part_models;
  PartSubsetIndex::State part_index;
  // A learned hypothesis scorer (HypothesisScorer::Serialize), or empty.
  std::string scorer;
  // Each model's mesh in the model frame, simplified (SimplifyMesh at
  // kRenderMeshCellM) for render-and-compare verification; one per model
  // name, or none (a model file older than format 4, or meshes not given):
  // then verification draws the model shapes' samples instead.
  std::vector<TriangleMesh> render_meshes;
  // The learned vote map (VoteNet::Serialize, issue 30), or empty: then
  // detection votes with the codebook (the paper's path).
  std::string vote_net;
  // Per class, the least score of a detection (issue 38): chosen for the best
  // F1 on validation frames when the model was trained, or by `model
  // operating-point`; empty in a model file older than format 9.
  OperatingPoint operating_point;
  // Recorded with the vote network (format 10); codebook models keep the
  // default (single frames).
  VoteNetInput vote_net_input{true};
};

// The vertex-clustering cell of TrainedModel::render_meshes (m).
constexpr float kRenderMeshCellM = 0.01f;

// One versioned binary file ("FURNMDL" + format version) holding everything;
// the same model gives the same bytes. Load throws InputError naming the file
// for a missing, foreign, truncated or newer-version file.
void SaveTrainedModel(const TrainedModel& model, const std::string& path);
TrainedModel LoadTrainedModel(const std::string& path);

// A model file read without checking its vote network's block: only for
// `workbench model upgrade`, which converts an old block
// (learned/vote_net_upgrade.h). Everything else uses LoadTrainedModel, which
// refuses a block it cannot read in one line naming the file.
TrainedModel LoadTrainedModelUnchecked(const std::string& path);

}  // namespace furn

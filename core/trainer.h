// Training (SPEC.md §7): from partial views of CAD models to a part
// vocabulary and a shape model.
//
// Each view's points go through the shared preprocessing and region growing;
// every segment gets its 24 SGFs, normalised to [0, 1] with the training set's
// per-feature range (stored; detection clamps to it). The vocabulary is
// learnt on the normalised features, and the shape model keeps, for every
// training segment, the words it activates with their probabilities, its
// class, CAD model and relation vector to the object reference point.
//
// Relation vectors are horizontal and view-aligned: expressed in a frame whose
// x axis is the horizontal direction from the sensor to the segment, so votes
// do not depend on the object's yaw (the paper's d = p - s is yaw-dependent).
//
//   TrainerOptions options;
//   TrainedModel model = TrainModel(views, model_names, options);
//   SaveTrainedModel(model, "model.fcm");
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/furniture_class.h"
#include "core/mesh.h"
#include "core/operating_point.h"
#include "core/part_subsets.h"
#include "core/preprocess.h"
#include "core/region_growing.h"
#include "core/sgf.h"
#include "core/view_segments.h"
#include "core/vocabulary.h"

namespace furn {

struct TrainingView {
  std::vector<Eigen::Vector3f> points;  // world frame; the model stands at the origin, yaw 0
  Eigen::Vector3f sensor_origin = Eigen::Vector3f::Zero();
  int model_index = 0;  // into the model names given to TrainModel
  FurnitureClass furniture_class = FurnitureClass::kChair;
  // A scan of a rescaled copy of the model (augmentation): its segments vote
  // and join the part library, but the model's shape for fitting and
  // verification comes from the true-size views only.
  bool augmented = false;
};

// The virtual scans training takes of each CAD model (pipelines' ScanModel):
// rings of viewpoints around the model standing at the origin.
struct ScanOptions {
  std::vector<double> heights_m = {0.9, 1.3, 1.7};  // camera heights, one ring each
  int azimuths = 8;                                 // views per ring (>= 1)
  double min_distance_m = 1.8;                      // ring radius grows with height (m)
  double max_distance_m = 3.2;
  uint64_t seed = 1;  // sensor noise, and the scale draws
  // Augmentation: per model, this many extra copies scaled along x, y and z
  // by factors drawn independently from [1 - scale_jitter, 1 + scale_jitter]
  // are scanned the same way (TrainingView::augmented); 0: none.
  int scale_variants = 0;
  double scale_jitter = 0.15;

  void Check() const;
};

struct TrainerOptions {
  PreprocessOptions preprocess;
  RegionGrowingOptions region_growing;
  SgfOptions sgf;
  VocabularyOptions vocabulary;
  PartSubsetOptions part_subsets;  // the part-subset library for CAD model ranking
  double shape_voxel_m = 0.02;     // grid of the stored model shapes (m, 0.005..0.1)

  void Check() const;
};

// Min/max of every feature over the training set; Apply maps to [0, 1] and
// clamps (a scene's own features never widen the range: SPEC §14).
struct FeatureNormalizer {
  SgfVector low{};
  SgfVector high{};

  static FeatureNormalizer Fit(const std::vector<SgfVector>& features);
  Eigen::VectorXd Apply(const SgfVector& feature) const;
};

struct ShapeEntry {
  int word = 0;
  double probability = 0;  // p(A_word | f) of the training segment
  FurnitureClass furniture_class = FurnitureClass::kChair;
  int model_index = 0;
  Eigen::Vector2f relation = Eigen::Vector2f::Zero();  // view-aligned, metres
  float height = 0;                                    // segment centroid height (m)
};

// A CAD model as its training scans saw it, in the model frame (origin at the
// footprint centre on the floor, yaw 0): the union of its views' points and
// normals, one per shape voxel (the first in view order). Pose fitting and
// visibility verification use it.
struct ModelShape {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;
  Eigen::Vector3f low = Eigen::Vector3f::Zero();  // bounding box of the points
  Eigen::Vector3f high = Eigen::Vector3f::Zero();
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

// Wall-clock seconds of TrainModel's stages.
struct TrainStageTimes {
  double segment_s = 0;       // preprocessing, region growing, SGFs (all views)
  double part_subsets_s = 0;  // subsets and their VFHs (all views)
  double vocabulary_s = 0;    // normalisation and k-means or RIM
  double shape_s = 0;         // model shapes and the shape model's entries
};

// Throws InputError for no views, a view naming no model, or views that
// yield fewer segments than the vocabulary has words.
TrainedModel TrainModel(const std::vector<TrainingView>& views,
                        const std::vector<std::string>& model_names,
                        const std::vector<FurnitureClass>& model_classes,
                        const TrainerOptions& options,
                        TrainStageTimes* times = nullptr);

// Segments and normalisation-free SGFs of one view (shared with detection).
struct SegmentTimings {
  double preprocess_ms = 0, segment_ms = 0, features_ms = 0;
};
// With `features` false the segments' SGFs are left empty (what learned
// voting's fits need: segments and centroids, no codebook words).
ViewSegments SegmentView(const std::vector<Eigen::Vector3f>& points,
                         const Eigen::Vector3f& sensor_origin,
                         const TrainerOptions& options,
                         SegmentTimings* timings = nullptr,
                         bool features = true);

// The cloud indices of the points of some of a view's segments.
std::vector<int> PointsOfSegments(const ViewSegments& view, const std::vector<int>& segments);

// The horizontal, view-aligned frame of a segment seen from `sensor`: x along
// the horizontal sensor-to-segment direction, y to its left.
Eigen::Matrix2f ViewAlignedFromWorld(const Eigen::Vector3f& sensor,
                                     const Eigen::Vector3f& centroid);

// One versioned binary file ("FURNMDL" + format version) holding everything;
// the same model gives the same bytes. Load throws InputError naming the file
// for a missing, foreign, truncated or newer-version file.
void SaveTrainedModel(const TrainedModel& model, const std::string& path);
TrainedModel LoadTrainedModel(const std::string& path);

}  // namespace furn

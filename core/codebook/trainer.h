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

#include "core/model/trained_model.h"

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

}  // namespace furn

#include "core/codebook/trainer.h"

#include <chrono>
#include <cmath>
#include <unordered_set>

#include "core/codebook/segment_view.h"
#include "core/geometry/voxel_key.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

namespace furn {
namespace {

// Per model: the union of its (true-size) views' preprocessed points, one per voxel.
std::vector<ModelShape> BuildModelShapes(const std::vector<TrainingView>& views,
                                         const std::vector<ViewSegments>& segmented,
                                         size_t models,
                                         double voxel_m) {
  std::vector<ModelShape> shapes(models);
  std::vector<std::unordered_set<uint64_t>> taken(models);
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].augmented) continue;  // a rescaled copy is not the model's shape
    const int m = views[v].model_index;
    const PointCloud& cloud = segmented[v].cloud;
    for (size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3f& p = cloud.points[i];
      if (!taken[m].insert(VoxelKey(p, voxel_m)).second) continue;
      shapes[m].points.push_back(p);
      shapes[m].normals.push_back(cloud.normals[i]);
    }
  }
  for (ModelShape& shape : shapes) {
    if (shape.points.empty()) continue;
    shape.low = shape.high = shape.points[0];
    for (const Eigen::Vector3f& p : shape.points) {
      shape.low = shape.low.cwiseMin(p);
      shape.high = shape.high.cwiseMax(p);
    }
  }
  return shapes;
}

}  // namespace

namespace {

// The implicit shape model: every segment of every view activates words,
// each activation an entry with the segment's relation to the model origin
// (view-aligned) and its height (SPEC §6).
std::vector<ShapeEntry> BuildShapeEntries(const std::vector<TrainingView>& views,
                                          const std::vector<ViewSegments>& segmented,
                                          const Vocabulary& vocabulary,
                                          const std::vector<Eigen::VectorXd>& normalised) {
  std::vector<ShapeEntry> shape;
  size_t next = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    for (size_t s = 0; s < segmented[v].segments.size(); ++s, ++next) {
      const Eigen::Vector3f& centroid = segmented[v].centroids[s];
      // The reference point is the model origin (footprint centre on the floor).
      const Eigen::Vector2f relation =
          ViewAlignedFromWorld(views[v].sensor_origin, centroid) * (-centroid.head<2>());
      for (const WordActivation& activation : vocabulary.Activate(normalised[next])) {
        shape.push_back({activation.word,
                         activation.probability,
                         views[v].furniture_class,
                         views[v].model_index,
                         relation,
                         centroid.z()});
      }
    }
  }
  return shape;
}

// Each view's part subsets described by VFH, on every core, in order.
std::vector<std::vector<PartSubsetEntry>> DescribePartSubsets(
    const std::vector<TrainingView>& views,
    const std::vector<ViewSegments>& segmented,
    const PartSubsetOptions& options) {
  std::vector<std::vector<PartSubsetEntry>> subsets(views.size());
  ParallelFor(0, static_cast<int>(views.size()), [&](int i) {
    for (const std::vector<int>& subset : PartSubsets(segmented[i], options)) {
      subsets[i].push_back({ComputeVfh(segmented[i].cloud,
                                       PointsOfSegments(segmented[i], subset),
                                       views[i].sensor_origin,
                                       options.vfh_size_component),
                            views[i].model_index});
    }
  });
  return subsets;
}

void CheckTrainingInput(const std::vector<TrainingView>& views,
                        const std::vector<std::string>& model_names,
                        const std::vector<FurnitureClass>& model_classes,
                        const TrainerOptions& options) {
  options.Check();
  Require(!views.empty(), "training needs at least one view");
  Require(model_names.size() == model_classes.size(), "training: one class per model name");
  for (const TrainingView& view : views) {
    Require(
        view.model_index >= 0 && view.model_index < static_cast<int>(model_names.size()),
        "training view names model " + std::to_string(view.model_index) + ", which does not exist");
  }
}

}  // namespace

TrainedModel TrainModel(const std::vector<TrainingView>& views,
                        const std::vector<std::string>& model_names,
                        const std::vector<FurnitureClass>& model_classes,
                        const TrainerOptions& options,
                        TrainStageTimes* times) {
  using Clock = std::chrono::steady_clock;
  TrainStageTimes local;
  if (times == nullptr) times = &local;
  auto lap = [last = Clock::now()](double* seconds) mutable {
    const auto now = Clock::now();
    *seconds = std::chrono::duration<double>(now - last).count();
    last = now;
  };
  CheckTrainingInput(views, model_names, model_classes, options);
  // Views are independent: segment them, then describe their part subsets,
  // on every core, keeping the order.
  std::vector<ViewSegments> segmented(views.size());
  lap(&times->segment_s);
  ParallelFor(0, static_cast<int>(views.size()), [&](int i) {
    segmented[i] = SegmentView(views[i].points, views[i].sensor_origin, options);
  });
  lap(&times->segment_s);
  const std::vector<std::vector<PartSubsetEntry>> subsets =
      DescribePartSubsets(views, segmented, options.part_subsets);
  lap(&times->part_subsets_s);
  std::vector<SgfVector> features;
  for (const ViewSegments& view : segmented)
    features.insert(features.end(), view.features.begin(), view.features.end());
  Require(static_cast<int>(features.size()) >= options.vocabulary.words,
          "training views yield " + std::to_string(features.size()) + " segments, fewer than the " +
              std::to_string(options.vocabulary.words) +
              " words asked for (more views, or a smaller vocabulary)");

  TrainedModel model;
  model.options = options;
  model.model_names = model_names;
  model.model_classes = model_classes;
  model.normalizer = FeatureNormalizer::Fit(features);
  std::vector<Eigen::VectorXd> normalised;
  for (const SgfVector& f : features) normalised.push_back(model.normalizer.Apply(f));
  model.vocabulary = Vocabulary::Train(normalised, options.vocabulary);
  lap(&times->vocabulary_s);
  model.training_segments = static_cast<int>(features.size());
  std::vector<VfhDescriptor> descriptors;
  for (const std::vector<PartSubsetEntry>& view : subsets) {
    for (const PartSubsetEntry& entry : view) {
      model.part_models.push_back(entry.model_index);
      descriptors.push_back(entry.descriptor);
    }
  }
  Require(!descriptors.empty(), "the training views gave no part subsets");
  model.part_index = PartSubsetIndex(descriptors).state();
  model.model_shapes =
      BuildModelShapes(views, segmented, model_names.size(), options.shape_voxel_m);
  model.shape = BuildShapeEntries(views, segmented, model.vocabulary, normalised);
  lap(&times->shape_s);
  return model;
}

void ScanOptions::Check() const {
  Require(!heights_m.empty(), "scan heights must not be empty");
  for (double h : heights_m)
    Require(h > 0 && h < 5, "scan height " + std::to_string(h) + " m must be in (0, 5)");
  Require(azimuths >= 1 && azimuths <= 360, "scan azimuths must be in 1..360");
  Require(min_distance_m > 0.5 && max_distance_m >= min_distance_m && max_distance_m < 10,
          "scan distances must satisfy 0.5 < min <= max < 10 m");
  Require(scale_variants >= 0 && scale_variants <= 10,
          "scale variants " + std::to_string(scale_variants) + " must be in 0..10");
  Require(scale_jitter >= 0 && scale_jitter <= 0.5,
          "scale jitter " + std::to_string(scale_jitter) + " must be in 0..0.5");
}

}  // namespace furn

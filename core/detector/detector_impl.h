// Internal to the detector's stage files (core/detector/*.cc): the trained model
// indexed for detection, shared by every stage. Not a public header.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <vector>

#include "core/detector/detector.h"
#include "core/detector/hypothesis_source.h"
#include "core/learned/vote_net.h"

namespace furn {

inline constexpr int kClasses = static_cast<int>(kAllClasses.size());

// Times the stages of one call into a StageTimings.
class StageTimer {
 public:
  using Clock = std::chrono::steady_clock;
  explicit StageTimer(StageTimings* out) : out_(out) {}
  void Lap(DetectionStage stage) {
    const auto now = Clock::now();
    out_->Add(stage, std::chrono::duration<double, std::milli>(now - last_).count());
    last_ = now;
  }
  void Restart() { last_ = Clock::now(); }
  void Total() {
    out_->Add(DetectionStage::kTotal,
              std::chrono::duration<double, std::milli>(Clock::now() - start_).count());
  }

 private:
  StageTimings* out_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_ = start_;
};

// A scan's occupancy grid and depth image, made by whichever of two threads
// is free first: Detect's segmentation branch offers the scan's points in
// the world frame before it segments them; the network's branch, when it
// ends first (real frames: the segmentation is the longer), keeps the depth
// image and builds the grid, else the segmentation branch does once it is
// done (dataset frames). Both are the same whoever makes them (the grid's
// construction is serial or split-independent).
//
// The network's branch keeps the image and builds the grid only once the
// segmentation's MLS fit (its one stage on every core) is over: built beside
// the fit, the grid took a third of both cores from it; built beside region
// growing (serial), it uses the core that would idle (real frames' median
// 46.8 -> 43.4 ms, the two schedules alternated in one build).
class OccupancyHandoff {
 public:
  void Offer(std::vector<Eigen::Vector3f> world, const Eigen::Vector3f& sensor, double voxel_m);
  // Builds the grid when it was offered and no other thread has claimed
  // it, its time as kOccupancy in `timings`; true when this call built it.
  bool BuildIfFree(StageTimings* timings);
  // After both threads ended.
  std::optional<OccupancyGrid> Take() { return std::move(grid_); }

  // True for the first thread to ask: it keeps the scan's depth image.
  bool ClaimDepthImage() { return !depth_image_claimed_.exchange(true); }

  // The segmentation's branch: its MLS fit is over (or it ended or threw;
  // calling again does nothing).
  void MarkPreprocessed();
  // Returns once MarkPreprocessed was called.
  void WaitUntilPreprocessed();

 private:
  std::atomic<bool> offered_{false}, claimed_{false}, depth_image_claimed_{false};
  std::mutex preprocessed_mutex_;
  std::condition_variable preprocessed_changed_;
  bool preprocessed_ = false;  // guarded by preprocessed_mutex_
  std::vector<Eigen::Vector3f> world_;
  Eigen::Vector3f sensor_ = Eigen::Vector3f::Zero();
  double voxel_m_ = 0;
  std::optional<OccupancyGrid> grid_;
};

// An organised scan's depth image and intrinsics, which render-and-compare
// needs; nothing for unorganised scans.
void KeepDepthImage(const DetectionInput& input, double max_range_m, PreparedScan* scan);

struct Detector::Impl {
  TrainedModel model;
  DetectorOptions options;
  std::vector<std::vector<int>> entries_of_word;             // shape entries per word
  std::vector<std::array<int, kClasses>> entries_per_class;  // #(A_i, o)
  std::array<double, kClasses> class_width{};  // median footprint width per class (m); 0: none
  std::vector<ModelFitter> fitters;            // one per model
  // Segments reaching higher than this (the tallest model plus the fit's
  // above_m) are structure, like walls: no model can explain them.
  float structure_height_m = 0;
  std::unique_ptr<PartSubsetIndex> parts;
  HypothesisScorer scorer;  // empty: the fixed gates decide
  bool scored = false;      // the scorer decides (the model has one and use_scorer)
  VoteNet vote_net;         // empty: the model has none
  bool learned = false;     // hypotheses from vote_net
  // Where the hypotheses come from: LearnedSource when learned, else
  // CodebookSource.
  std::unique_ptr<HypothesisSource> source;
  OperatingPoint operating_point;  // the model's, under the options' overrides
  // Ray casts the models' meshes for render-and-compare; null for a model
  // file without meshes (its shape samples are splatted instead).
  std::unique_ptr<ModelMeshCaster> mesh_caster;

  // The hypotheses of one class from its smoothed grid (codebook_vote.cc).
  std::vector<DetectionDebug::Hypothesis> Maxima(const cv::Mat& grid,
                                                 int class_index,
                                                 const Eigen::Vector2f& origin,
                                                 DetectionDebug::VoteGrid* debug) const;
  // The segments behind a hypothesis and its candidate CAD models
  // (codebook_rank.cc).
  std::map<int, double> Support(const std::vector<HoughVote>& class_votes,
                                DetectionDebug::Hypothesis* hypothesis) const;
  // Per segment of the scan, the nearest part subsets (VFH) of those that
  // back any of `supports` (segment -> weight); empty for the rest.
  std::vector<std::vector<int>> SegmentNeighbours(
      const PreparedScan& scan, const std::vector<std::map<int, double>>& supports) const;
  void Rank(const std::map<int, double>& support,
            const std::vector<std::vector<int>>& segment_neighbours,
            DetectionDebug::Hypothesis* hypothesis) const;
  // The covered share counting only segments mostly inside the fit's box
  // (fit.cc).
  double ExplainedOwnPoints(const PreparedScan& scan,
                            int model_index,
                            const PlanarPose& pose,
                            const std::vector<Eigen::Vector3f>& scene_points,
                            const std::vector<int>& cloud_index) const;
};

}  // namespace furn

// Learned hypothesis scoring (issue 16, step 3): the detection score of a
// fitted hypothesis as a calibrated probability that it is an object of its
// class within 10 cm, learnt from hypotheses on labelled rooms.
//
// The fixed hard gates (coverage, seen share, verification) were tuned on the
// very CAD models trained on; a category-level decision needs all the cues at
// once. A random forest (OpenCV ml, regression on 0/1 labels) maps the
// hypothesis' features to a raw score; Platt scaling, fitted on frames the
// forest did not see, maps that to a probability.
//
//   std::vector<ScorerSample> samples = ...;  // features + label per hypothesis
//   HypothesisScorer scorer = HypothesisScorer::Train(samples, ScorerOptions{});
//   double p = scorer.Probability(hypothesis.features);
//   std::string bytes = scorer.Serialize();  // stored in the model file
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/model/furniture_class.h"

namespace furn {

// The scorer's view of a hypothesis' best fit, by name (the detector's
// score stage fills it; Vector() lays it out for the forest).
struct HypothesisFeatures {
  FurnitureClass furniture_class = FurnitureClass::kChair;  // one-hot in the vector
  float log_vote_weight = 0;    // log(1 + smoothed vote weight at the maximum)
  float relative_weight = 0;    // (vote - min) / (max - min) of its class grid
  float segments = 0;           // segments that voted for it
  float covered = 0;            // share of the box's scene points the fit explains
  float verification = 0;       // visibility score vs
  float seen_occupied = 0;      // share of the fit's observable surface seen
  float free_share = 0;         // of the model's points, where the sensor saw through
  float occluded_share = 0;     // of the model's points, hidden from the sensor
  float log_points_in_box = 0;  // log(1 + scene points in the fit's box)
  float model_width = 0, model_depth = 0, model_height = 0;  // the fitted model's size (m)
  float observed_height = 0;      // the highest explained scene point (m)
  float range = 0;                // horizontal distance from the sensor (m)
  float second_fit_ratio = 0;     // second-best over best fit score
  float fits = 0;                 // candidates that gave a pose
  float candidate_rank = 0;       // the best fit's rank among the candidates
  float log_points_in_reach = 0;  // log(1 + scene points within the candidates' reach)
  float seen_through = -1;        // render-and-compare shares; -1 for unorganised scans
  float render_support = -1;

  // The forest's input, in kHypothesisFeatureNames order.
  std::array<float, 25> Vector() const;
};

// The forest's input: the class one-hot of the paper's four classes, the
// named features above in their order, then the sofa's one-hot slot (last,
// so that scorers trained without sofas keep the 24-feature layout of
// model files up to version 7).
inline constexpr int kHypothesisFeatures = 25;
inline constexpr int kHypothesisFeaturesWithoutSofa = 24;
using FeatureVector = std::array<float, kHypothesisFeatures>;
extern const char* const kHypothesisFeatureNames[kHypothesisFeatures];

inline constexpr size_t kMinScorerSamples = 20;  // Train's minimum

struct ScorerSample {
  FeatureVector features{};
  bool positive = false;  // right class within 10 cm of a true object
  uint64_t group = 0;     // frame id: calibration holds out whole frames
};

struct ScorerOptions {
  int trees = 100;
  int max_depth = 12;
  int min_sample_count = 5;
  double calibration_share = 0.25;  // of the frames, held out of the forest for Platt scaling
  uint64_t seed = 1;                // the forest's bootstrap and feature draws

  void Check() const;
};

class HypothesisScorer {
 public:
  HypothesisScorer();
  ~HypothesisScorer();
  HypothesisScorer(HypothesisScorer&&) noexcept;
  HypothesisScorer& operator=(HypothesisScorer&&) noexcept;

  // Whether Train accepts these: kMinScorerSamples or more, with both labels.
  static bool CanTrain(const std::vector<ScorerSample>& samples);
  // Throws InputError with fewer than 20 samples or no positive or negative
  // one. Deterministic: the same samples give the same scorer. The forest
  // sees the sofa's slot only when a sample has it set.
  static HypothesisScorer Train(const std::vector<ScorerSample>& samples,
                                const ScorerOptions& options);
  // Throws InputError naming `source` for bytes that are not a scorer.
  static HypothesisScorer Deserialize(const std::string& bytes, const std::string& source);
  std::string Serialize() const;

  bool empty() const;
  double RawScore(const FeatureVector& features) const;     // the forest's output
  double Probability(const FeatureVector& features) const;  // calibrated, in (0, 1)
  // Features the forest reads: 24 (no sofa slot) or 25.
  int feature_count() const;
  double platt_a() const { return platt_a_; }
  double platt_b() const { return platt_b_; }
  int training_samples() const { return samples_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double platt_a_ = 1, platt_b_ = 0;  // p = 1 / (1 + exp(-(a raw + b)))
  int samples_ = 0;
};

// Platt scaling: a, b minimising the log loss of 1 / (1 + exp(-(a s + b)))
// against the labels (Newton's method, with Platt's smoothed targets).
void FitPlatt(const std::vector<double>& scores,
              const std::vector<bool>& labels,
              double* a,
              double* b);

}  // namespace furn

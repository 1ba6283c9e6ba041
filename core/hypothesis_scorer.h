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

namespace furn {

// The features of a hypothesis' best fit, in this order (see
// kHypothesisFeatureNames): class one-hot (4), log(1 + vote weight), relative
// vote weight, supporting segments, covered fraction, visibility score,
// seen-occupied share, free and occluded shares of the model's points,
// log(1 + scene points in the box), the fitted model's width, depth and
// height, the observed height (highest explained point), range from the
// sensor, second-best over best fit score, fits, the fitted model's
// candidate rank, log(1 + scene points within reach), and render-and-compare's
// seen-through share and support share (-1 each for unorganised scans).
inline constexpr int kHypothesisFeatures = 24;
using HypothesisFeatures = std::array<float, kHypothesisFeatures>;
extern const char* const kHypothesisFeatureNames[kHypothesisFeatures];

inline constexpr size_t kMinScorerSamples = 20;  // Train's minimum

struct ScorerSample {
  HypothesisFeatures features{};
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
  // one. Deterministic: the same samples give the same scorer.
  static HypothesisScorer Train(const std::vector<ScorerSample>& samples,
                                const ScorerOptions& options);
  // Throws InputError naming `source` for bytes that are not a scorer.
  static HypothesisScorer Deserialize(const std::string& bytes, const std::string& source);
  std::string Serialize() const;

  bool empty() const;
  double RawScore(const HypothesisFeatures& features) const;     // the forest's output
  double Probability(const HypothesisFeatures& features) const;  // calibrated, in (0, 1)
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

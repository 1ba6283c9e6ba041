#include "core/codebook/hypothesis_scorer.h"

#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>
#include <sstream>

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {

const char* const kHypothesisFeatureNames[kHypothesisFeatures] = {
    "class_chair",       "class_armchair",
    "class_table",       "class_sideboard",
    "log_vote_weight",   "relative_weight",
    "segments",          "covered",
    "verification",      "seen_occupied",
    "free_share",        "occluded_share",
    "log_points_in_box", "model_width",
    "model_depth",       "model_height",
    "observed_height",   "range",
    "second_fit_ratio",  "fits",
    "candidate_rank",    "log_points_in_reach",
    "seen_through",      "render_support",
    "class_sofa"};

FeatureVector HypothesisFeatures::Vector() const {
  FeatureVector v{};
  const int one_hot = furniture_class == FurnitureClass::kSofa ? kHypothesisFeatures - 1
                                                               : static_cast<int>(furniture_class);
  v[one_hot] = 1;
  const float named[] = {log_vote_weight,   relative_weight,
                         segments,          covered,
                         verification,      seen_occupied,
                         free_share,        occluded_share,
                         log_points_in_box, model_width,
                         model_depth,       model_height,
                         observed_height,   range,
                         second_fit_ratio,  fits,
                         candidate_rank,    log_points_in_reach,
                         seen_through,      render_support};
  for (size_t k = 0; k < std::size(named); ++k) v[4 + k] = named[k];
  return v;
}

namespace {

constexpr char kHeader[] = "furnidet-scorer 1";

// The first `count` features as one sample row.
cv::Mat Row(const FeatureVector& features, int count) {
  cv::Mat row(1, count, CV_32F);
  for (int i = 0; i < count; ++i) row.at<float>(0, i) = features[i];
  return row;
}

// 25 when a sample has the sofa's slot set, else the 24 of the older layout.
int FeatureCount(const std::vector<ScorerSample>& samples) {
  for (const ScorerSample& s : samples) {
    if (s.features[kHypothesisFeatures - 1] != 0) return kHypothesisFeatures;
  }
  return kHypothesisFeaturesWithoutSofa;
}

}  // namespace

struct HypothesisScorer::Impl {
  cv::Ptr<cv::ml::RTrees> forest;
};

void ScorerOptions::Check() const {
  Require(trees >= 1 && trees <= 2000, "scorer trees must be in 1..2000");
  Require(max_depth >= 1 && max_depth <= 64, "scorer max depth must be in 1..64");
  Require(min_sample_count >= 1, "scorer min sample count must be >= 1");
  Require(calibration_share > 0 && calibration_share < 1,
          "scorer calibration share must be in (0, 1)");
}

HypothesisScorer::HypothesisScorer() : impl_(std::make_unique<Impl>()) {}
HypothesisScorer::~HypothesisScorer() = default;
HypothesisScorer::HypothesisScorer(HypothesisScorer&&) noexcept = default;
HypothesisScorer& HypothesisScorer::operator=(HypothesisScorer&&) noexcept = default;

bool HypothesisScorer::empty() const { return impl_->forest.empty(); }

void FitPlatt(const std::vector<double>& scores,
              const std::vector<bool>& labels,
              double* a,
              double* b) {
  size_t positives = 0;
  for (bool l : labels) positives += l;
  const double negatives = static_cast<double>(labels.size() - positives);
  // Platt's targets keep the fit finite when the classes separate.
  const double high = (positives + 1.0) / (positives + 2.0);
  const double low = 1.0 / (negatives + 2.0);
  double pa = 1, pb = 0;
  for (int iteration = 0; iteration < 100; ++iteration) {
    double g0 = 0, g1 = 0, h00 = 1e-9, h01 = 0, h11 = 1e-9;
    for (size_t i = 0; i < scores.size(); ++i) {
      const double t = labels[i] ? high : low;
      const double p = 1 / (1 + std::exp(-(pa * scores[i] + pb)));
      const double w = p * (1 - p);
      g0 += (p - t) * scores[i];
      g1 += p - t;
      h00 += w * scores[i] * scores[i];
      h01 += w * scores[i];
      h11 += w;
    }
    const double det = h00 * h11 - h01 * h01;
    if (std::abs(det) < 1e-18) break;
    const double da = (h11 * g0 - h01 * g1) / det;
    const double db = (h00 * g1 - h01 * g0) / det;
    pa -= da;
    pb -= db;
    if (std::abs(da) < 1e-9 && std::abs(db) < 1e-9) break;
  }
  *a = pa;
  *b = pb;
}

bool HypothesisScorer::CanTrain(const std::vector<ScorerSample>& samples) {
  size_t positives = 0;
  for (const ScorerSample& s : samples) positives += s.positive;
  return samples.size() >= kMinScorerSamples && positives > 0 && positives < samples.size();
}

HypothesisScorer HypothesisScorer::Train(const std::vector<ScorerSample>& samples,
                                         const ScorerOptions& options) {
  options.Check();
  size_t positives = 0;
  for (const ScorerSample& s : samples) positives += s.positive;
  Require(CanTrain(samples),
          "the hypothesis scorer needs at least " + std::to_string(kMinScorerSamples) +
              " samples with both labels (got " + std::to_string(samples.size()) + ", " +
              std::to_string(positives) + " positive)");
  // Whole frames go to calibration, chosen by a hash of their id.
  const auto calibration_frame = [&](uint64_t group) {
    return (DeriveSeed(0x5c0e, group) % 1000) < options.calibration_share * 1000;
  };
  const int count = FeatureCount(samples);
  cv::Mat train_x, train_y;
  std::vector<const ScorerSample*> calibration;
  for (const ScorerSample& s : samples) {
    if (calibration_frame(s.group)) {
      calibration.push_back(&s);
      continue;
    }
    train_x.push_back(Row(s.features, count));
    train_y.push_back(s.positive ? 1.0f : 0.0f);
  }
  if (train_x.rows < 10 || calibration.empty()) {  // too few frames to split: calibrate in-sample
    train_x.release();
    train_y.release();
    calibration.clear();
    for (const ScorerSample& s : samples) {
      train_x.push_back(Row(s.features, count));
      train_y.push_back(s.positive ? 1.0f : 0.0f);
      calibration.push_back(&s);
    }
  }
  HypothesisScorer scorer;
  cv::Ptr<cv::ml::RTrees> forest = cv::ml::RTrees::create();
  forest->setMaxDepth(options.max_depth);
  forest->setMinSampleCount(options.min_sample_count);
  forest->setRegressionAccuracy(0);
  forest->setUseSurrogates(false);
  forest->setCalculateVarImportance(false);
  forest->setActiveVarCount(0);  // sqrt of the feature count
  forest->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, options.trees, 0));
  // OpenCV draws the bootstrap samples and split features from its
  // thread-local generator: seeded here, the same samples give the same forest.
  const cv::RNG saved = cv::theRNG();
  cv::theRNG() = cv::RNG(options.seed);
  forest->train(cv::ml::TrainData::create(train_x, cv::ml::ROW_SAMPLE, train_y));
  cv::theRNG() = saved;
  scorer.impl_->forest = forest;
  scorer.samples_ = static_cast<int>(samples.size());
  std::vector<double> raw;
  std::vector<bool> labels;
  for (const ScorerSample* s : calibration) {
    raw.push_back(scorer.RawScore(s->features));
    labels.push_back(s->positive);
  }
  FitPlatt(raw, labels, &scorer.platt_a_, &scorer.platt_b_);
  return scorer;
}

int HypothesisScorer::feature_count() const { return empty() ? 0 : impl_->forest->getVarCount(); }

double HypothesisScorer::RawScore(const FeatureVector& features) const {
  Require(!empty(), "the hypothesis scorer is empty");
  return impl_->forest->predict(Row(features, feature_count()));
}

double HypothesisScorer::Probability(const FeatureVector& features) const {
  return 1 / (1 + std::exp(-(platt_a_ * RawScore(features) + platt_b_)));
}

std::string HypothesisScorer::Serialize() const {
  if (empty()) return "";
  cv::FileStorage storage(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  storage << "forest"
          << "{";
  impl_->forest->write(storage);
  storage << "}";
  char header[128];
  std::snprintf(
      header, sizeof(header), "%s\n%.17g %.17g %d\n", kHeader, platt_a_, platt_b_, samples_);
  return header + storage.releaseAndGetString();
}

HypothesisScorer HypothesisScorer::Deserialize(const std::string& bytes,
                                               const std::string& source) {
  HypothesisScorer scorer;
  if (bytes.empty()) return scorer;
  std::istringstream in(bytes);
  std::string header;
  std::getline(in, header);
  Require(header == kHeader, source + ": not a hypothesis scorer (header '" + header + "')");
  in >> scorer.platt_a_ >> scorer.platt_b_ >> scorer.samples_;
  Require(!in.fail() && std::isfinite(scorer.platt_a_) && std::isfinite(scorer.platt_b_),
          source + ": hypothesis scorer has no valid calibration line");
  in.ignore(1);
  const std::string yaml(std::istreambuf_iterator<char>(in), {});
  try {
    cv::FileStorage storage(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    cv::Ptr<cv::ml::RTrees> forest = cv::ml::RTrees::create();
    forest->read(storage["forest"]);
    Require(forest->isTrained() && (forest->getVarCount() == kHypothesisFeatures ||
                                    forest->getVarCount() == kHypothesisFeaturesWithoutSofa),
            source + ": hypothesis scorer is not a trained forest over " +
                std::to_string(kHypothesisFeaturesWithoutSofa) + " or " +
                std::to_string(kHypothesisFeatures) + " features");
    scorer.impl_->forest = forest;
  } catch (const cv::Exception& e) {
    throw InputError(source + ": hypothesis scorer cannot be read (" + e.err + ")");
  }
  return scorer;
}

}  // namespace furn

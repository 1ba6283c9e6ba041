// The learned hypothesis scorer: it learns a rule hidden in the features,
// its probabilities are calibrated, it is deterministic and survives the
// model file; bad bytes and too few samples are clear errors.
#include "core/codebook/hypothesis_scorer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "tests/test_util.h"

namespace furn {
namespace {

// Positive with probability rising with "covered" (feature 7) and falling
// with "free_share" (10); the other features are noise.
std::vector<ScorerSample> Samples(int count, uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<float> unit(0, 1);
  std::vector<ScorerSample> samples;
  for (int i = 0; i < count; ++i) {
    ScorerSample s;
    for (float& f : s.features) f = unit(random);
    const double logit = 8 * (s.features[7] - 0.5) - 6 * (s.features[10] - 0.5);
    s.positive = unit(random) < 1 / (1 + std::exp(-logit));
    s.group = static_cast<uint64_t>(i / 5);  // five hypotheses per "frame"
    samples.push_back(s);
  }
  return samples;
}

TEST(HypothesisScorer, EveryFeatureHasAName) {
  for (int i = 0; i < kHypothesisFeatures; ++i) {
    ASSERT_NE(kHypothesisFeatureNames[i], nullptr) << i;
    EXPECT_GT(std::strlen(kHypothesisFeatureNames[i]), 2u) << i;
  }
}

TEST(HypothesisScorer, LearnsTheHiddenRuleWithCalibratedProbabilities) {
  ScorerOptions options;
  options.trees = 60;
  const HypothesisScorer scorer = HypothesisScorer::Train(Samples(3000, 1), options);
  ASSERT_FALSE(scorer.empty());
  EXPECT_EQ(scorer.training_samples(), 3000);
  // On fresh samples: ranked well (AUC) and calibrated (binned |share - p|).
  const std::vector<ScorerSample> test = Samples(3000, 2);
  std::vector<std::pair<double, bool>> scored;
  double bins_n[10] = {}, bins_p[10] = {}, bins_pos[10] = {};
  for (const ScorerSample& s : test) {
    const double p = scorer.Probability(s.features);
    ASSERT_GT(p, 0);
    ASSERT_LT(p, 1);
    scored.emplace_back(p, s.positive);
    const int b = std::min(9, static_cast<int>(p * 10));
    bins_n[b] += 1;
    bins_p[b] += p;
    bins_pos[b] += s.positive;
  }
  std::sort(scored.begin(), scored.end());
  double rank_sum = 0, positives = 0;
  for (size_t i = 0; i < scored.size(); ++i) {
    if (scored[i].second) {
      rank_sum += static_cast<double>(i + 1);
      positives += 1;
    }
  }
  const double negatives = static_cast<double>(scored.size()) - positives;
  const double auc = (rank_sum - positives * (positives + 1) / 2) / (positives * negatives);
  EXPECT_GT(auc, 0.85);  // the Bayes-optimal AUC of this rule is about 0.9
  double ece = 0;
  for (int b = 0; b < 10; ++b) ece += std::abs(bins_pos[b] - bins_p[b]) / test.size();
  EXPECT_LT(ece, 0.06);
}

TEST(HypothesisScorer, SameSamplesSameBytesAndTheBytesRoundTrip) {
  ScorerOptions options;
  options.trees = 20;
  const std::vector<ScorerSample> samples = Samples(500, 3);
  const std::string bytes = HypothesisScorer::Train(samples, options).Serialize();
  EXPECT_EQ(bytes, HypothesisScorer::Train(samples, options).Serialize());
  const HypothesisScorer original = HypothesisScorer::Train(samples, options);
  const HypothesisScorer loaded = HypothesisScorer::Deserialize(bytes, "test");
  for (const ScorerSample& s : Samples(50, 4))
    EXPECT_NEAR(loaded.Probability(s.features), original.Probability(s.features), 1e-6);

  // Through a model file; a model without a scorer stays without one.
  TrainedModel model;
  model.model_names = {"m"};
  model.model_classes = {FurnitureClass::kChair};
  model.model_shapes.resize(1);
  model.scorer = bytes;
  const std::string path = testing::ScratchDir() + "/scored.fcm";
  SaveTrainedModel(model, path);
  EXPECT_EQ(LoadTrainedModel(path).scorer, bytes);
  model.scorer.clear();
  SaveTrainedModel(model, path);
  EXPECT_TRUE(LoadTrainedModel(path).scorer.empty());
  // A version-2 file (before scorers: no trailing scorer string) still loads.
  std::string v2 = ReadFileBytes(path);
  // No dimensions, scorer, meshes, VFH flag, vote net, operating point (8 + 4 + 5 x 36 bytes),
  // vote net input (3 x 8 + 4 bytes) or checksum.
  v2.resize(v2.size() - 28 - 192 - 28);
  const uint32_t version = 2;
  std::memcpy(&v2[8], &version, sizeof(version));  // after the 8-byte magic
  WriteFileAtomically(path, v2);
  EXPECT_TRUE(LoadTrainedModel(path).scorer.empty());
}

TEST(HypothesisScorer, TooFewSamplesAndForeignBytesAreClearErrors) {
  std::vector<ScorerSample> few = Samples(10, 5);
  EXPECT_NE(testing::ErrorOf([&] {
              HypothesisScorer::Train(few, ScorerOptions{});
            }).find("needs at least 20 samples"),
            std::string::npos);
  std::vector<ScorerSample> one_label = Samples(100, 6);
  for (ScorerSample& s : one_label) s.positive = false;
  EXPECT_NE(testing::ErrorOf([&] {
              HypothesisScorer::Train(one_label, ScorerOptions{});
            }).find("0 positive"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              HypothesisScorer::Deserialize("hello\n", "s.yml");
            }).find("s.yml: not a hypothesis scorer"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              HypothesisScorer::Deserialize("furnidet-scorer 1\n1 0 5\nnot yaml: [", "s.yml");
            }).find("s.yml: hypothesis scorer"),
            std::string::npos);
  EXPECT_TRUE(HypothesisScorer::Deserialize("", "s.yml").empty());
}

TEST(FitPlatt, RecoversAKnownSigmoid) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<double> scores;
  std::vector<bool> labels;
  for (int i = 0; i < 20000; ++i) {
    const double s = unit(random);
    scores.push_back(s);
    labels.push_back(unit(random) < 1 / (1 + std::exp(-(6 * s - 2))));
  }
  double a = 0, b = 0;
  FitPlatt(scores, labels, &a, &b);
  EXPECT_NEAR(a, 6, 0.4);
  EXPECT_NEAR(b, -2, 0.2);
}

// The sofa bug of the index-filled features: a sofa's one-hot slot was
// kSofa == 4, the slot of log(1 + vote weight), which then overwrote it, so
// a sofa hypothesis looked like one of no class. Named features keep both.
TEST(HypothesisFeatures, ASofaKeepsItsClassAndItsVoteWeight) {
  HypothesisFeatures sofa;
  sofa.furniture_class = FurnitureClass::kSofa;
  sofa.log_vote_weight = 0.7f;
  sofa.covered = 0.8f;
  const FeatureVector v = sofa.Vector();
  EXPECT_EQ(v[kHypothesisFeatures - 1], 1.0f) << "the sofa's one-hot slot";
  EXPECT_FLOAT_EQ(v[4], 0.7f) << "log vote weight, not overwritten";
  for (int c = 0; c < 4; ++c) EXPECT_EQ(v[c], 0.0f) << "no other class' slot";
  EXPECT_STREQ(kHypothesisFeatureNames[kHypothesisFeatures - 1], "class_sofa");
  EXPECT_STREQ(kHypothesisFeatureNames[4], "log_vote_weight");
  EXPECT_STREQ(kHypothesisFeatureNames[7], "covered");
  EXPECT_FLOAT_EQ(v[7], 0.8f);

  HypothesisFeatures chair = sofa;
  chair.furniture_class = FurnitureClass::kChair;
  const FeatureVector w = chair.Vector();
  EXPECT_EQ(w[0], 1.0f);
  EXPECT_EQ(w[kHypothesisFeatures - 1], 0.0f);
  EXPECT_FLOAT_EQ(w[4], 0.7f);
}

// A scorer learns from the sofa's slot when its samples have sofas; without
// sofas it keeps the 24 features of model files up to version 7.
TEST(HypothesisScorer, LearnsTheSofaSlotOnlyFromSamplesWithSofas) {
  ScorerOptions options;
  options.trees = 20;
  std::vector<ScorerSample> without = Samples(400, 3);
  for (ScorerSample& s : without) s.features[kHypothesisFeatures - 1] = 0;
  EXPECT_EQ(HypothesisScorer::Train(without, options).feature_count(),
            kHypothesisFeaturesWithoutSofa);
  // Sofas are the positives: only the sofa slot tells them apart.
  std::vector<ScorerSample> with = without;
  for (size_t i = 0; i < with.size(); ++i) {
    with[i].positive = i % 2 == 0;
    with[i].features[kHypothesisFeatures - 1] = with[i].positive ? 1.0f : 0.0f;
  }
  const HypothesisScorer scorer = HypothesisScorer::Train(with, options);
  EXPECT_EQ(scorer.feature_count(), kHypothesisFeatures);
  HypothesisFeatures sofa, chair;
  sofa.furniture_class = FurnitureClass::kSofa;
  chair.furniture_class = FurnitureClass::kChair;
  EXPECT_GT(scorer.Probability(sofa.Vector()), 0.8);
  EXPECT_LT(scorer.Probability(chair.Vector()), 0.2);
  const HypothesisScorer back = HypothesisScorer::Deserialize(scorer.Serialize(), "s.yml");
  EXPECT_EQ(back.feature_count(), kHypothesisFeatures);
  EXPECT_NEAR(back.Probability(sofa.Vector()), scorer.Probability(sofa.Vector()), 1e-9);
}

}  // namespace
}  // namespace furn

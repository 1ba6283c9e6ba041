#include "core/codebook/vocabulary.h"

#include <gtest/gtest.h>

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {
namespace {

// `per_blob` points around each of the given centres, Gaussian with `sigma`.
std::vector<Eigen::VectorXd> Blobs(const std::vector<Eigen::VectorXd>& centres,
                                   int per_blob,
                                   double sigma,
                                   std::vector<int>* truth) {
  FastRng rng(42);
  std::vector<Eigen::VectorXd> points;
  for (size_t c = 0; c < centres.size(); ++c) {
    for (int i = 0; i < per_blob; ++i) {
      Eigen::VectorXd p = centres[c];
      for (Eigen::Index d = 0; d < p.size(); ++d) p(d) += sigma * rng.Normal();
      points.push_back(p);
      truth->push_back(static_cast<int>(c));
    }
  }
  return points;
}

std::vector<Eigen::VectorXd> ThreeBlobs(std::vector<int>* truth) {
  Eigen::VectorXd a(4), b(4), c(4);
  a << 0.2, 0.2, 0.8, 0.5;
  b << 0.8, 0.3, 0.2, 0.5;
  c << 0.5, 0.9, 0.5, 0.1;
  return Blobs({a, b, c}, 80, 0.04, truth);
}

std::vector<int> ArgmaxLabels(const Vocabulary& vocabulary,
                              const std::vector<Eigen::VectorXd>& points) {
  std::vector<int> labels;
  for (const Eigen::VectorXd& p : points) {
    const auto activations = vocabulary.Activate(p);
    int best = activations[0].word;
    double best_p = activations[0].probability;
    for (const WordActivation& a : activations) {
      if (a.probability > best_p) {
        best = a.word;
        best_p = a.probability;
      }
    }
    labels.push_back(best);
  }
  return labels;
}

TEST(Rim, AnalyticGradientMatchesNumericGradient) {
  std::vector<int> truth;
  const std::vector<Eigen::VectorXd> points = ThreeBlobs(&truth);
  const int k = 4, d = 4;
  FastRng rng(7);
  Eigen::VectorXd parameters((d + 1) * k);
  for (Eigen::Index i = 0; i < parameters.size(); ++i) parameters(i) = rng.Normal();
  Eigen::VectorXd analytic;
  RimObjective(points, parameters, k, 0.01, &analytic);
  for (Eigen::Index i = 0; i < parameters.size(); ++i) {
    const double h = 1e-6;
    Eigen::VectorXd plus = parameters, minus = parameters;
    plus(i) += h;
    minus(i) -= h;
    const double numeric = (RimObjective(points, plus, k, 0.01, nullptr) -
                            RimObjective(points, minus, k, 0.01, nullptr)) /
                           (2 * h);
    EXPECT_NEAR(analytic(i), numeric, 1e-6 + 1e-4 * std::abs(numeric)) << "parameter " << i;
  }
}

TEST(Rim, RecoversBlobsAndKillsSurplusWords) {
  std::vector<int> truth;
  const std::vector<Eigen::VectorXd> points = ThreeBlobs(&truth);
  for (RimInit init : {RimInit::kKMeans, RimInit::kPcaSplit}) {
    VocabularyOptions options;
    options.kind = VocabularyKind::kRim;
    options.rim_init = init;
    options.words = 6;  // twice as many as there are blobs
    options.rim_lambda = 1e-3;
    const Vocabulary vocabulary = Vocabulary::Train(points, options);
    EXPECT_GE(NormalizedMutualInformation(truth, ArgmaxLabels(vocabulary, points)), 0.9);
    EXPECT_EQ(vocabulary.NumUsedWords(), 3)
        << (init == RimInit::kKMeans ? "k-means init" : "PCA init");
  }
}

TEST(KMeans, RecoversBlobsDeterministically) {
  std::vector<int> truth;
  const std::vector<Eigen::VectorXd> points = ThreeBlobs(&truth);
  VocabularyOptions options;
  options.kind = VocabularyKind::kKMeans;
  options.words = 3;
  options.activated_words = 1;
  const Vocabulary vocabulary = Vocabulary::Train(points, options);
  EXPECT_GE(NormalizedMutualInformation(truth, ArgmaxLabels(vocabulary, points)), 0.99);
  const auto a = KMeans(points, 3, 3, 50, 9), b = KMeans(points, 3, 3, 50, 9);
  for (size_t c = 0; c < a.size(); ++c) EXPECT_EQ(a[c], b[c]);
  // Activations are p(A_i | f) = w_i / sum w_j over the nearest words.
  options.activated_words = 3;
  const auto activations = Vocabulary::Train(points, options).Activate(points[0]);
  ASSERT_EQ(activations.size(), 3u);
  double total = 0;
  for (const WordActivation& a : activations) total += a.probability;
  EXPECT_NEAR(total, 1, 1e-12);
}

TEST(PcaSplit, IsDeterministicAndSeparatesBlobs) {
  std::vector<int> truth;
  const std::vector<Eigen::VectorXd> points = ThreeBlobs(&truth);
  const auto a = PcaSplit(points, 3), b = PcaSplit(points, 3);
  ASSERT_EQ(a.size(), 3u);
  for (size_t c = 0; c < a.size(); ++c) EXPECT_EQ(a[c], b[c]);
  EXPECT_GE(NormalizedMutualInformation(truth, AssignToNearest(points, a)), 0.9);
}

TEST(Vocabulary, SameSeedSameWords) {
  std::vector<int> truth;
  const std::vector<Eigen::VectorXd> points = ThreeBlobs(&truth);
  VocabularyOptions options;
  options.words = 5;
  const Vocabulary a = Vocabulary::Train(points, options), b = Vocabulary::Train(points, options);
  for (size_t i = 0; i < points.size(); i += 17) {
    const auto x = a.Activate(points[i]), y = b.Activate(points[i]);
    ASSERT_EQ(x.size(), y.size());
    for (size_t j = 0; j < x.size(); ++j) EXPECT_EQ(x[j].probability, y[j].probability);
  }
}

TEST(Vocabulary, BadInputsAreRejected) {
  std::vector<int> truth;
  const std::vector<Eigen::VectorXd> points = ThreeBlobs(&truth);
  VocabularyOptions options;
  options.words = 1;
  EXPECT_THROW(Vocabulary::Train(points, options), InputError);
  options.words = 500;
  EXPECT_THROW(Vocabulary::Train(points, options), InputError);  // more words than features
  options.words = 3;
  EXPECT_THROW(Vocabulary::Train({}, options), InputError);
  std::vector<Eigen::VectorXd> mixed = points;
  mixed.push_back(Eigen::VectorXd::Zero(2));
  EXPECT_THROW(Vocabulary::Train(mixed, options), InputError);
}

TEST(Nmi, KnownValues) {
  EXPECT_NEAR(NormalizedMutualInformation({0, 0, 1, 1}, {5, 5, 7, 7}), 1, 1e-12);
  EXPECT_NEAR(NormalizedMutualInformation({0, 1, 0, 1}, {0, 0, 1, 1}), 0, 1e-12);
}

}  // namespace
}  // namespace furn

// The part vocabulary (SPEC.md §7.5): words are clusters of normalised SGF
// vectors, learnt by k-means or by RIM (Regularized Information Maximization,
// Gomes, Krause and Perona 2010), and a feature activates the words with
// probabilities p(A_i | f).
//
//  - k-means: k-means++ seeding, Lloyd iterations, the best of several
//    restarts (lowest SSE), all from the seed. p(A_i | f) = w_i / sum_j w_j
//    with w_i = 1 / ||A_i - f||^2 over the activated (nearest) words.
//  - RIM: a softmax model p(k | x) = exp(w_k . x + b_k) / Z maximising
//    I = H(mean_i p_i) - mean_i H(p_i) - lambda * sum_k ||w_k||^2 (biases are not
//    penalised, so unneeded words die: model selection), with Ceres'
//    GradientProblemSolver (L-BFGS). Initialised from k-means centres or from
//    the deterministic PCA split, via w_k = c_k / s^2, b_k = -||c_k||^2 / (2 s^2).
//
//   VocabularyOptions options;
//   options.kind = VocabularyKind::kRim;
//   Vocabulary vocabulary = Vocabulary::Train(features, options);
//   for (const WordActivation& a : vocabulary.Activate(f)) { ... }
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace furn {

enum class VocabularyKind { kKMeans, kRim };
enum class RimInit { kKMeans, kPcaSplit };

struct VocabularyOptions {
  VocabularyKind kind = VocabularyKind::kRim;
  RimInit rim_init = RimInit::kKMeans;
  int words = 50;                 // k (2..1000); RIM may leave some unused
  int kmeans_restarts = 5;        // (>= 1)
  int kmeans_iterations = 100;    // Lloyd iterations per restart (>= 1)
  double rim_lambda = 1e-4;       // weight penalty (>= 0)
  int rim_iterations = 300;       // L-BFGS iterations (>= 1)
  int activated_words = 3;        // k-means: nearest words a feature activates (>= 1)
  double min_probability = 1e-3;  // RIM: activations below this are dropped (0..1)
  uint64_t seed = 1;

  // Throws InputError naming the field and the rule.
  void Check() const;
};

struct WordActivation {
  int word = 0;
  double probability = 0;  // p(A_word | f); the activations of a feature sum to 1
};

// Cluster assignment helpers, exposed for tests and reports.
std::vector<int> AssignToNearest(const std::vector<Eigen::VectorXd>& points,
                                 const std::vector<Eigen::VectorXd>& centres);
// k-means++ with restarts; returns the centres of the lowest-SSE run.
std::vector<Eigen::VectorXd> KMeans(
    const std::vector<Eigen::VectorXd>& points, int k, int restarts, int iterations, uint64_t seed);
// Deterministic: start with one cluster; split the one with the largest SSE by
// the hyperplane through its mean orthogonal to its first principal component.
std::vector<Eigen::VectorXd> PcaSplit(const std::vector<Eigen::VectorXd>& points, int k);
// Normalised mutual information of two labellings (0..1), for evaluation.
double NormalizedMutualInformation(const std::vector<int>& a, const std::vector<int>& b);

// RIM objective I (to be maximised) and its gradient over the packed
// parameters [w_0 (D), ..., w_{K-1} (D), b_0, ..., b_{K-1}].
double RimObjective(const std::vector<Eigen::VectorXd>& points,
                    const Eigen::VectorXd& parameters,
                    int k,
                    double lambda,
                    Eigen::VectorXd* gradient);

class Vocabulary {
 public:
  // Throws InputError for bad options, fewer features than words, or
  // features of unequal or zero dimension.
  static Vocabulary Train(const std::vector<Eigen::VectorXd>& features,
                          const VocabularyOptions& options);

  std::vector<WordActivation> Activate(const Eigen::VectorXd& feature) const;
  int NumWords() const {
    return kind_ == VocabularyKind::kKMeans ? static_cast<int>(centres_.size())
                                            : static_cast<int>(biases_.size());
  }
  // Words some training feature falls in most (RIM kills the others).
  int NumUsedWords() const { return used_words_; }
  VocabularyKind kind() const { return kind_; }

  // The plain state, for model files.
  struct State {
    VocabularyKind kind = VocabularyKind::kKMeans;
    std::vector<Eigen::VectorXd> centres;
    Eigen::MatrixXd weights;
    Eigen::VectorXd biases;
    int activated_words = 3;
    double min_probability = 1e-3;
    int used_words = 0;
  };
  State GetState() const {
    return {kind_, centres_, weights_, biases_, activated_words_, min_probability_, used_words_};
  }
  static Vocabulary FromState(const State& state) {
    Vocabulary v;
    v.kind_ = state.kind;
    v.centres_ = state.centres;
    v.weights_ = state.weights;
    v.biases_ = state.biases;
    v.activated_words_ = state.activated_words;
    v.min_probability_ = state.min_probability;
    v.used_words_ = state.used_words;
    return v;
  }

 private:
  VocabularyKind kind_ = VocabularyKind::kKMeans;
  std::vector<Eigen::VectorXd> centres_;  // k-means
  Eigen::MatrixXd weights_;               // RIM: K x D
  Eigen::VectorXd biases_;                // RIM: K
  int activated_words_ = 3;
  double min_probability_ = 1e-3;
  int used_words_ = 0;
};

}  // namespace furn

#include "core/codebook/vocabulary.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {
namespace {

double SquaredDistance(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).squaredNorm();
}

double Sse(const std::vector<Eigen::VectorXd>& points,
           const std::vector<Eigen::VectorXd>& centres,
           const std::vector<int>& labels) {
  double sse = 0;
  for (size_t i = 0; i < points.size(); ++i) sse += SquaredDistance(points[i], centres[labels[i]]);
  return sse;
}

std::vector<Eigen::VectorXd> KMeansPlusPlus(const std::vector<Eigen::VectorXd>& points,
                                            int k,
                                            Rng* rng) {
  std::vector<Eigen::VectorXd> centres = {
      points[rng->UniformInt(0, static_cast<int64_t>(points.size()) - 1)]};
  std::vector<double> nearest(points.size(), std::numeric_limits<double>::infinity());
  while (static_cast<int>(centres.size()) < k) {
    double total = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      nearest[i] = std::min(nearest[i], SquaredDistance(points[i], centres.back()));
      total += nearest[i];
    }
    if (total <= 0) {  // fewer distinct points than k: repeat one
      centres.push_back(points[rng->UniformInt(0, static_cast<int64_t>(points.size()) - 1)]);
      continue;
    }
    double target = rng->Uniform01() * total;
    size_t chosen = points.size() - 1;
    for (size_t i = 0; i < points.size(); ++i) {
      target -= nearest[i];
      if (target < 0) {
        chosen = i;
        break;
      }
    }
    centres.push_back(points[chosen]);
  }
  return centres;
}

// Softmax probabilities of every point under the packed RIM parameters.
Eigen::MatrixXd RimProbabilities(const std::vector<Eigen::VectorXd>& points,
                                 const Eigen::VectorXd& parameters,
                                 int k) {
  const int d = static_cast<int>(points[0].size());
  const Eigen::Map<const Eigen::MatrixXd> weights(parameters.data(), d, k);  // column k is w_k
  const Eigen::Map<const Eigen::VectorXd> biases(parameters.data() + d * k, k);
  Eigen::MatrixXd p(points.size(), k);
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::VectorXd logits = weights.transpose() * points[i] + biases;
    logits.array() -= logits.maxCoeff();
    const Eigen::VectorXd e = logits.array().exp();
    p.row(i) = (e / e.sum()).transpose();
  }
  return p;
}

class RimFunction : public ceres::FirstOrderFunction {
 public:
  RimFunction(const std::vector<Eigen::VectorXd>& points, int k, double lambda)
      : points_(points), k_(k), lambda_(lambda) {}
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    const Eigen::Map<const Eigen::VectorXd> x(parameters, NumParameters());
    Eigen::VectorXd g;
    const double objective = RimObjective(points_, x, k_, lambda_, gradient ? &g : nullptr);
    *cost = -objective;  // Ceres minimises
    if (gradient) Eigen::Map<Eigen::VectorXd>(gradient, NumParameters()) = -g;
    return std::isfinite(objective);
  }
  int NumParameters() const override { return (static_cast<int>(points_[0].size()) + 1) * k_; }

 private:
  const std::vector<Eigen::VectorXd>& points_;
  const int k_;
  const double lambda_;
};

void CheckFeatures(const std::vector<Eigen::VectorXd>& features, int k) {
  Require(!features.empty() && features[0].size() > 0, "vocabulary: no features to learn from");
  for (const Eigen::VectorXd& f : features) {
    Require(f.size() == features[0].size(), "vocabulary: features have different dimensions");
    Require(f.allFinite(), "vocabulary: a feature is not finite");
  }
  Require(static_cast<int>(features.size()) >= k,
          "vocabulary: " + std::to_string(features.size()) + " features cannot make " +
              std::to_string(k) + " words");
}

}  // namespace

void VocabularyOptions::Check() const {
  Require(words >= 2 && words <= 1000, "words " + std::to_string(words) + " must be in 2..1000");
  Require(kmeans_restarts >= 1, "kmeans_restarts must be >= 1");
  Require(kmeans_iterations >= 1, "kmeans_iterations must be >= 1");
  Require(rim_lambda >= 0 && std::isfinite(rim_lambda), "rim_lambda must be >= 0");
  Require(rim_iterations >= 1, "rim_iterations must be >= 1");
  Require(activated_words >= 1, "activated_words must be >= 1");
  Require(min_probability >= 0 && min_probability < 1, "min_probability must be in [0, 1)");
}

std::vector<int> AssignToNearest(const std::vector<Eigen::VectorXd>& points,
                                 const std::vector<Eigen::VectorXd>& centres) {
  std::vector<int> labels(points.size(), 0);
  for (size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (size_t c = 0; c < centres.size(); ++c) {
      const double d = SquaredDistance(points[i], centres[c]);
      if (d < best) {
        best = d;
        labels[i] = static_cast<int>(c);
      }
    }
  }
  return labels;
}

std::vector<Eigen::VectorXd> KMeans(const std::vector<Eigen::VectorXd>& points,
                                    int k,
                                    int restarts,
                                    int iterations,
                                    uint64_t seed) {
  CheckFeatures(points, k);
  std::vector<Eigen::VectorXd> best;
  double best_sse = std::numeric_limits<double>::infinity();
  for (int restart = 0; restart < restarts; ++restart) {
    Rng rng(DeriveSeed(seed, static_cast<uint64_t>(restart)));
    std::vector<Eigen::VectorXd> centres = KMeansPlusPlus(points, k, &rng);
    std::vector<int> labels = AssignToNearest(points, centres);
    for (int iteration = 0; iteration < iterations; ++iteration) {
      std::vector<Eigen::VectorXd> sums(k, Eigen::VectorXd::Zero(points[0].size()));
      std::vector<int> counts(k, 0);
      for (size_t i = 0; i < points.size(); ++i) {
        sums[labels[i]] += points[i];
        ++counts[labels[i]];
      }
      for (int c = 0; c < k; ++c) {
        if (counts[c] > 0) centres[c] = sums[c] / counts[c];  // an empty cluster keeps its centre
      }
      std::vector<int> next = AssignToNearest(points, centres);
      if (next == labels) break;
      labels = std::move(next);
    }
    const double sse = Sse(points, centres, labels);
    if (sse < best_sse) {
      best_sse = sse;
      best = centres;
    }
  }
  return best;
}

std::vector<Eigen::VectorXd> PcaSplit(const std::vector<Eigen::VectorXd>& points, int k) {
  CheckFeatures(points, k);
  std::vector<int> labels(points.size(), 0);
  std::vector<Eigen::VectorXd> centres;
  auto mean_of = [&](int cluster) {
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(points[0].size());
    int count = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      if (labels[i] == cluster) {
        sum += points[i];
        ++count;
      }
    }
    return Eigen::VectorXd(sum / std::max(1, count));
  };
  centres.push_back(mean_of(0));
  while (static_cast<int>(centres.size()) < k) {
    // The cluster with the largest SSE.
    std::vector<double> sse(centres.size(), 0);
    for (size_t i = 0; i < points.size(); ++i)
      sse[labels[i]] += SquaredDistance(points[i], centres[labels[i]]);
    const int worst = static_cast<int>(std::max_element(sse.begin(), sse.end()) - sse.begin());
    if (sse[worst] <= 0) break;  // every cluster is a single point value
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(points[0].size(), points[0].size());
    for (size_t i = 0; i < points.size(); ++i) {
      if (labels[i] != worst) continue;
      const Eigen::VectorXd d = points[i] - centres[worst];
      covariance += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(covariance);
    Eigen::VectorXd axis = solver.eigenvectors().col(points[0].size() - 1);
    // Fix the sign, so which side gets the new label does not depend on the solver.
    Eigen::Index largest;
    axis.cwiseAbs().maxCoeff(&largest);
    if (axis(largest) < 0) axis = -axis;
    const int added = static_cast<int>(centres.size());
    for (size_t i = 0; i < points.size(); ++i) {
      if (labels[i] == worst && (points[i] - centres[worst]).dot(axis) > 0) labels[i] = added;
    }
    centres.push_back(Eigen::VectorXd());
    centres[worst] = mean_of(worst);
    centres[added] = mean_of(added);
  }
  while (static_cast<int>(centres.size()) < k) centres.push_back(centres.back());
  return centres;
}

double NormalizedMutualInformation(const std::vector<int>& a, const std::vector<int>& b) {
  Require(a.size() == b.size() && !a.empty(),
          "NMI needs two labellings of the same, non-zero length");
  const double n = static_cast<double>(a.size());
  std::map<int, double> pa, pb;
  std::map<std::pair<int, int>, double> pab;
  for (size_t i = 0; i < a.size(); ++i) {
    pa[a[i]] += 1 / n;
    pb[b[i]] += 1 / n;
    pab[{a[i], b[i]}] += 1 / n;
  }
  double mutual = 0, ha = 0, hb = 0;
  for (const auto& [key, p] : pab) mutual += p * std::log(p / (pa[key.first] * pb[key.second]));
  for (const auto& [key, p] : pa) ha -= p * std::log(p);
  for (const auto& [key, p] : pb) hb -= p * std::log(p);
  return ha > 0 && hb > 0 ? mutual / std::sqrt(ha * hb) : (ha == hb ? 1.0 : 0.0);
}

double RimObjective(const std::vector<Eigen::VectorXd>& points,
                    const Eigen::VectorXd& parameters,
                    int k,
                    double lambda,
                    Eigen::VectorXd* gradient) {
  const int d = static_cast<int>(points[0].size());
  const double n = static_cast<double>(points.size());
  const Eigen::MatrixXd p = RimProbabilities(points, parameters, k);
  const Eigen::VectorXd mean = p.colwise().mean().transpose();
  constexpr double kTiny = 1e-300;
  double marginal_entropy = 0, conditional_entropy = 0;
  for (int j = 0; j < k; ++j) marginal_entropy -= mean(j) * std::log(std::max(mean(j), kTiny));
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    for (int j = 0; j < k; ++j)
      conditional_entropy -= p(i, j) * std::log(std::max(p(i, j), kTiny)) / n;
  }
  const Eigen::Map<const Eigen::MatrixXd> weights(parameters.data(), d, k);
  const double objective = marginal_entropy - conditional_entropy - lambda * weights.squaredNorm();
  if (gradient != nullptr) {
    gradient->setZero(parameters.size());
    Eigen::Map<Eigen::MatrixXd> grad_w(gradient->data(), d, k);
    Eigen::Map<Eigen::VectorXd> grad_b(gradient->data() + d * k, k);
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      // dI/da_ij = (1/N) p_ij [log(p_ij / pbar_j) - sum_k p_ik log(p_ik / pbar_k)]
      Eigen::VectorXd log_ratio(k);
      for (int j = 0; j < k; ++j)
        log_ratio(j) = std::log(std::max(p(i, j), kTiny) / std::max(mean(j), kTiny));
      const double expected = p.row(i).dot(log_ratio);
      for (int j = 0; j < k; ++j) {
        const double da = p(i, j) * (log_ratio(j) - expected) / n;
        grad_w.col(j) += da * points[i];
        grad_b(j) += da;
      }
    }
    grad_w -= 2 * lambda * weights;
  }
  return objective;
}

Vocabulary Vocabulary::Train(const std::vector<Eigen::VectorXd>& features,
                             const VocabularyOptions& options) {
  options.Check();
  CheckFeatures(features, options.words);
  Vocabulary vocabulary;
  vocabulary.kind_ = options.kind;
  vocabulary.activated_words_ = options.activated_words;
  vocabulary.min_probability_ = options.min_probability;
  const std::vector<Eigen::VectorXd> centres =
      options.kind == VocabularyKind::kRim && options.rim_init == RimInit::kPcaSplit
          ? PcaSplit(features, options.words)
          : KMeans(features,
                   options.words,
                   options.kmeans_restarts,
                   options.kmeans_iterations,
                   options.seed);
  if (options.kind == VocabularyKind::kKMeans) {
    vocabulary.centres_ = centres;
    const std::vector<int> labels = AssignToNearest(features, centres);
    std::vector<bool> used(centres.size(), false);
    for (int label : labels) used[label] = true;
    vocabulary.used_words_ = static_cast<int>(std::count(used.begin(), used.end(), true));
    return vocabulary;
  }
  // RIM from the centres: softmax of -||x - c_k||^2 / (2 s^2). s^2 is the
  // features' total variance per dimension: a soft start. (The within-cluster
  // variance gives near-hard assignments with weights so large that the
  // penalty dominates the first steps and L-BFGS falls into the stationary
  // point where every feature shares one word.)
  const int d = static_cast<int>(features[0].size()), k = options.words;
  Eigen::VectorXd global_mean = Eigen::VectorXd::Zero(d);
  for (const Eigen::VectorXd& f : features) global_mean += f;
  global_mean /= static_cast<double>(features.size());
  double total_variance = 0;
  for (const Eigen::VectorXd& f : features) total_variance += SquaredDistance(f, global_mean);
  const double s2 = std::max(1e-6, total_variance / (features.size() * d));
  Eigen::VectorXd parameters((d + 1) * k);
  for (int j = 0; j < k; ++j) {
    parameters.segment(j * d, d) = centres[j] / s2;
    parameters(d * k + j) = -centres[j].squaredNorm() / (2 * s2);
  }
  ceres::GradientProblem problem(new RimFunction(features, k, options.rim_lambda));
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  solver_options.max_num_iterations = options.rim_iterations;
  solver_options.logging_type = ceres::SILENT;
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(solver_options, problem, parameters.data(), &summary);
  vocabulary.weights_ = Eigen::Map<const Eigen::MatrixXd>(parameters.data(), d, k).transpose();
  vocabulary.biases_ = parameters.tail(k);
  const Eigen::MatrixXd p = RimProbabilities(features, parameters, k);
  std::vector<bool> used(k, false);
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    Eigen::Index best;
    p.row(i).maxCoeff(&best);
    used[best] = true;
  }
  vocabulary.used_words_ = static_cast<int>(std::count(used.begin(), used.end(), true));
  return vocabulary;
}

std::vector<WordActivation> Vocabulary::Activate(const Eigen::VectorXd& feature) const {
  std::vector<WordActivation> activations;
  if (kind_ == VocabularyKind::kKMeans) {
    std::vector<std::pair<double, int>> distances;
    for (size_t c = 0; c < centres_.size(); ++c)
      distances.emplace_back(SquaredDistance(feature, centres_[c]), c);
    const size_t count = std::min<size_t>(activated_words_, distances.size());
    std::partial_sort(distances.begin(), distances.begin() + count, distances.end());
    double total = 0;
    for (size_t i = 0; i < count; ++i) total += 1 / std::max(distances[i].first, 1e-12);
    for (size_t i = 0; i < count; ++i) {
      activations.push_back({distances[i].second, 1 / std::max(distances[i].first, 1e-12) / total});
    }
    return activations;
  }
  Eigen::VectorXd logits = weights_ * feature + biases_;
  logits.array() -= logits.maxCoeff();
  const Eigen::VectorXd e = logits.array().exp();
  const Eigen::VectorXd p = e / e.sum();
  double kept = 0;
  for (Eigen::Index j = 0; j < p.size(); ++j) {
    if (p(j) >= min_probability_) kept += p(j);
  }
  for (Eigen::Index j = 0; j < p.size(); ++j) {
    if (p(j) >= min_probability_) activations.push_back({static_cast<int>(j), p(j) / kept});
  }
  return activations;
}

}  // namespace furn

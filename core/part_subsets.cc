#include "core/part_subsets.h"

#include <pcl/features/vfh.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <numeric>
#include <set>

#include "core/error.h"
#include "core/pcl_conversion.h"

namespace furn {

void PartSubsetOptions::Check() const {
  Require(max_subset_size >= 1 && max_subset_size <= 3, "max_subset_size must be in 1..3");
  Require(min_subset_size >= 1 && min_subset_size <= max_subset_size,
          "min_subset_size must be in 1..max_subset_size");
  Require(max_subsets_per_view >= 1, "max_subsets_per_view must be >= 1");
  Require(adjacency_m > 0, "adjacency_m must be > 0");
}

std::vector<std::vector<int>> PartSubsets(const ViewSegments& view,
                                          const PartSubsetOptions& options) {
  options.Check();
  const int segments = static_cast<int>(view.segments.size());
  std::vector<std::vector<int>> subsets;
  for (int s = 0; s < segments; ++s) subsets.push_back({s});
  if (options.max_subset_size == 1 || segments < 2) {
    subsets.resize(std::min<size_t>(subsets.size(), options.max_subsets_per_view));
    return subsets;
  }
  // Which segments touch: label every point, search each point's neighbourhood.
  std::vector<int> label(view.cloud.size(), -1);
  for (int s = 0; s < segments; ++s) {
    for (int i : view.segments[s]) label[i] = s;
  }
  const auto points = ToPclPoints(view.cloud.points);
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(points);
  std::set<std::pair<int, int>> adjacent;
  std::vector<int> neighbours;
  std::vector<float> distances;
  for (size_t i = 0; i < view.cloud.size(); ++i) {
    if (label[i] < 0) continue;
    tree.radiusSearch(static_cast<int>(i), options.adjacency_m, neighbours, distances);
    for (int q : neighbours) {
      if (label[q] >= 0 && label[q] != label[i])
        adjacent.emplace(std::min(label[i], label[q]), std::max(label[i], label[q]));
    }
  }
  for (const auto& [a, b] : adjacent) subsets.push_back({a, b});
  if (options.max_subset_size == 3) {
    std::set<std::vector<int>> triples;
    for (const auto& [a, b] : adjacent) {
      for (const auto& [c, d] : adjacent) {
        // Connected triples: two pairs sharing one segment.
        std::set<int> members = {a, b, c, d};
        if (members.size() == 3) triples.insert(std::vector<int>(members.begin(), members.end()));
      }
    }
    subsets.insert(subsets.end(), triples.begin(), triples.end());
  }
  subsets.erase(std::remove_if(subsets.begin(),
                               subsets.end(),
                               [&](const std::vector<int>& subset) {
                                 return static_cast<int>(subset.size()) < options.min_subset_size;
                               }),
                subsets.end());
  subsets.resize(std::min<size_t>(subsets.size(), options.max_subsets_per_view));
  return subsets;
}

VfhDescriptor ComputeVfh(const PointCloud& cloud,
                         const std::vector<int>& indices,
                         const Eigen::Vector3f& viewpoint) {
  Require(indices.size() >= 3, "VFH needs at least 3 points");
  const auto [points, normals] = ToPclPointsWithNormals(cloud, indices);
  pcl::VFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::VFHSignature308> vfh;
  vfh.setInputCloud(points);
  vfh.setInputNormals(normals);
  vfh.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  vfh.setViewPoint(viewpoint.x(), viewpoint.y(), viewpoint.z());
  pcl::PointCloud<pcl::VFHSignature308> signature;
  vfh.compute(signature);
  VfhDescriptor descriptor{};
  if (!signature.empty())
    std::copy(signature[0].histogram, signature[0].histogram + 308, descriptor.begin());
  return descriptor;
}

struct PartSubsetIndex::Impl {
  State state;
  Eigen::VectorXf squared_norms;  // of the projected rows
};

PartSubsetIndex::PartSubsetIndex(const std::vector<VfhDescriptor>& descriptors, int dimensions)
    : PartSubsetIndex(
          descriptors.size(),
          [&](size_t i) -> const VfhDescriptor& { return descriptors[i]; },
          dimensions) {}

PartSubsetIndex::PartSubsetIndex(size_t count,
                                 const std::function<const VfhDescriptor&(size_t)>& descriptor,
                                 int dimensions)
    : impl_(std::make_unique<Impl>()) {
  Require(count > 0, "a part-subset index needs at least one descriptor");
  constexpr int kBins = static_cast<int>(std::tuple_size<VfhDescriptor>::value);
  Require(dimensions >= 1 && dimensions <= kBins, "index dimensions must be in 1..308");
  const Eigen::Index n = static_cast<Eigen::Index>(count);
  auto row = [&](Eigen::Index i) {
    return Eigen::Map<const Eigen::RowVectorXf>(descriptor(static_cast<size_t>(i)).data(), kBins);
  };
  Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(kBins);
  for (Eigen::Index i = 0; i < n; ++i) sum += row(i).cast<double>();
  impl_->state.mean = (sum / static_cast<double>(n)).cast<float>();
  // Principal components from an even subsample of at most 4000 descriptors.
  const Eigen::Index stride = std::max<Eigen::Index>(1, n / 4000);
  Eigen::MatrixXd sample((n + stride - 1) / stride, kBins);
  for (Eigen::Index i = 0, r = 0; i < n; i += stride, ++r)
    sample.row(r) = (row(i) - impl_->state.mean).cast<double>();
  const Eigen::MatrixXd covariance =
      sample.transpose() * sample / std::max<Eigen::Index>(1, sample.rows());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(covariance);
  // Eigenvalues ascend: the last columns are the strongest components.
  impl_->state.basis =
      solver.eigenvectors().rightCols(dimensions).rowwise().reverse().cast<float>();
  // Projected in blocks of rows: no n x 308 copy of the descriptors.
  impl_->state.projected.resize(n, dimensions);
  constexpr Eigen::Index kBlock = 2048;
  Eigen::MatrixXf block(kBlock, kBins);
  for (Eigen::Index first = 0; first < n; first += kBlock) {
    const Eigen::Index rows = std::min(kBlock, n - first);
    for (Eigen::Index r = 0; r < rows; ++r) block.row(r) = row(first + r) - impl_->state.mean;
    impl_->state.projected.middleRows(first, rows).noalias() =
        block.topRows(rows) * impl_->state.basis;
  }
  impl_->squared_norms = impl_->state.projected.rowwise().squaredNorm();
}

PartSubsetIndex::PartSubsetIndex(State state) : impl_(std::make_unique<Impl>()) {
  constexpr int kBins = static_cast<int>(std::tuple_size<VfhDescriptor>::value);
  Require(state.mean.size() == kBins && state.basis.rows() == kBins && state.basis.cols() >= 1 &&
              state.projected.cols() == state.basis.cols() && state.projected.rows() >= 1,
          "part-subset index of inconsistent sizes");
  impl_->state = std::move(state);
  impl_->squared_norms = impl_->state.projected.rowwise().squaredNorm();
}

PartSubsetIndex::~PartSubsetIndex() = default;

const PartSubsetIndex::State& PartSubsetIndex::state() const { return impl_->state; }

size_t PartSubsetIndex::size() const { return static_cast<size_t>(impl_->state.projected.rows()); }

std::vector<int> PartSubsetIndex::Nearest(const VfhDescriptor& query, int k) const {
  constexpr int kBins = static_cast<int>(std::tuple_size<VfhDescriptor>::value);
  const Eigen::RowVectorXf q =
      (Eigen::Map<const Eigen::RowVectorXf>(query.data(), kBins) - impl_->state.mean) *
      impl_->state.basis;
  // |p - q|^2 = |p|^2 - 2 p.q + |q|^2: one matrix-vector product; |q|^2 is
  // the same for every p and left out.
  const Eigen::VectorXf distances =
      impl_->squared_norms - 2.0f * (impl_->state.projected * q.transpose());
  std::vector<int> order(distances.size());
  std::iota(order.begin(), order.end(), 0);
  const size_t count = std::min<size_t>(std::max(k, 0), order.size());
  std::partial_sort(order.begin(), order.begin() + count, order.end(), [&](int a, int b) {
    return distances[a] != distances[b] ? distances[a] < distances[b] : a < b;
  });
  order.resize(count);
  return order;
}

}  // namespace furn

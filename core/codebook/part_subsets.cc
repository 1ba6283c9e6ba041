#include "core/codebook/part_subsets.h"

#include <pcl/features/vfh.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <numeric>
#include <set>

#include "core/geometry/pcl_conversion.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

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
                         const Eigen::Vector3f& viewpoint,
                         bool size_component) {
  Require(indices.size() >= 3, "VFH needs at least 3 points");
  const auto [points, normals] = ToPclPointsWithNormals(cloud, indices);
  pcl::VFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::VFHSignature308> vfh;
  vfh.setInputCloud(points);
  vfh.setInputNormals(normals);
  vfh.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  vfh.setViewPoint(viewpoint.x(), viewpoint.y(), viewpoint.z());
  if (size_component) {  // distances from the centroid in centimetre bins (0..44 cm)
    vfh.setNormalizeDistance(false);
    vfh.setFillSizeComponent(true);
  }
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
  return NearestMany({query}, k).front();
}

std::vector<std::vector<int>> PartSubsetIndex::NearestMany(
    const std::vector<VfhDescriptor>& queries, int k) const {
  constexpr int kBins = static_cast<int>(std::tuple_size<VfhDescriptor>::value);
  const State& state = impl_->state;
  const Eigen::Index n = state.projected.rows();
  const Eigen::Index m = static_cast<Eigen::Index>(queries.size());
  const size_t count = std::min<size_t>(std::max(k, 0), static_cast<size_t>(n));
  // The queries in principal components, one per column.
  Eigen::MatrixXf projected_queries(state.basis.cols(), m);
  for (Eigen::Index j = 0; j < m; ++j) {
    projected_queries.col(j) =
        ((Eigen::Map<const Eigen::RowVectorXf>(queries[j].data(), kBins) - state.mean) *
         state.basis)
            .transpose();
  }
  // |p - q|^2 = |p|^2 - 2 p.q + |q|^2, |q|^2 the same for every p and left
  // out. The library is read block of rows by block, every query searched
  // while a block is in cache (the library is read once, not once per
  // query), each block on a core of its own; each query keeps its `count`
  // best of every block. A block's products are matrix-vector products as
  // over the whole library, so the distances are the same to the bit
  // whatever the blocks; candidates compare by (distance, index), a total
  // order, so the result does not depend on the blocks either.
  using Candidate = std::pair<float, int>;
  constexpr Eigen::Index kBlock = 8192;
  const int blocks = static_cast<int>((n + kBlock - 1) / kBlock);
  std::vector<std::vector<std::vector<Candidate>>> best_of_block(
      blocks, std::vector<std::vector<Candidate>>(m));
  ParallelFor(0, blocks, [&](int b) {
    const Eigen::Index first = b * kBlock;
    const Eigen::Index rows = std::min(kBlock, n - first);
    const auto block = state.projected.middleRows(first, rows);
    Eigen::VectorXf products(rows);
    for (Eigen::Index j = 0; j < m; ++j) {
      products.noalias() = block * projected_queries.col(j);
      std::vector<Candidate>& heap = best_of_block[b][j];  // a max-heap of the best so far
      heap.reserve(count + 1);
      for (Eigen::Index r = 0; r < rows && count > 0; ++r) {
        const Candidate candidate(impl_->squared_norms[first + r] - 2.0f * products[r],
                                  static_cast<int>(first + r));
        if (heap.size() < count) {
          heap.push_back(candidate);
          std::push_heap(heap.begin(), heap.end());
        } else if (candidate < heap.front()) {
          std::pop_heap(heap.begin(), heap.end());
          heap.back() = candidate;
          std::push_heap(heap.begin(), heap.end());
        }
      }
    }
  });
  std::vector<std::vector<int>> nearest(m);
  for (Eigen::Index j = 0; j < m; ++j) {
    std::vector<Candidate> candidates;
    for (int b = 0; b < blocks; ++b)
      candidates.insert(candidates.end(), best_of_block[b][j].begin(), best_of_block[b][j].end());
    std::partial_sort(candidates.begin(), candidates.begin() + count, candidates.end());
    for (size_t i = 0; i < count; ++i) nearest[j].push_back(candidates[i].second);
  }
  return nearest;
}

}  // namespace furn

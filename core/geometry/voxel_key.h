// The one voxel key of the project: a point's cell on a cubic grid packed
// into 64 bits, 21 bits per axis, centred (cells -2^20 .. 2^20 - 1 per axis:
// +-40 km at 4 cm, far beyond any room). For hash sets and maps of voxels.
//
//   std::unordered_set<uint64_t> taken;
//   if (taken.insert(VoxelKey(p, 0.05)).second) kept.push_back(p);
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>

namespace furn {

// static_cast<int>(std::floor(t)), without libm's floor (x86-64 without
// SSE4.1 has no rounding instruction: a call per coordinate): the same
// value wherever that cast is defined (|t| < 2^31), std::floor elsewhere.
template <class Real>
inline int FloorToInt(Real t) {
  if (!(std::abs(t) < Real(2147483648.0))) return static_cast<int>(std::floor(t));
  const int truncated = static_cast<int>(t);  // towards zero; exact as a Real
  return static_cast<Real>(truncated) > t ? truncated - 1 : truncated;
}

// The cell of `p` on a grid of `voxel_m` cubes with a corner at the origin.
inline Eigen::Vector3i VoxelCell(const Eigen::Vector3f& p, double voxel_m) {
  return Eigen::Vector3i(
      FloorToInt(p.x() / voxel_m), FloorToInt(p.y() / voxel_m), FloorToInt(p.z() / voxel_m));
}

inline uint64_t VoxelKey(const Eigen::Vector3i& cell) {
  constexpr uint64_t kMask = (uint64_t{1} << 21) - 1;
  constexpr int kOffset = 1 << 20;
  return ((static_cast<uint64_t>(cell.x() + kOffset) & kMask) << 42) |
         ((static_cast<uint64_t>(cell.y() + kOffset) & kMask) << 21) |
         (static_cast<uint64_t>(cell.z() + kOffset) & kMask);
}

inline uint64_t VoxelKey(const Eigen::Vector3f& p, double voxel_m) {
  return VoxelKey(VoxelCell(p, voxel_m));
}

}  // namespace furn

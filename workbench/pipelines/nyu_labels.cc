// DeriveNyuLabels: the floor plane and furniture instances of one NYU frame,
// from its class mask and depth (convert_nyu.h states the rules).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <map>
#include <random>

#include "core/geometry/floor.h"
#include "core/util/error.h"
#include "workbench/pipelines/convert_nyu.h"

namespace furn {
namespace {

// NYU-40 ids (Gupta et al. 2013; the masks store id - 1).
constexpr int kNyuFloor = 2, kNyuFloorMat = 20;

// A group of NYU-40 classes that forms one kind of instance.
struct NyuGroup {
  std::array<int, 2> nyu_ids;  // 0: unused
  FurnitureClass furniture_class;
  double max_length_m;  // pieces merge only while the merged footprint is shorter
  const char* ignored;  // non-empty: never a target (a detection there is neither right nor wrong)
};

// Chairs include stools and office chairs; desks are tables; a dresser is a
// sideboard. Cabinets and night stands look like sideboards to a depth
// sensor but are mostly built-in kitchen units or small: ignored.
constexpr NyuGroup kGroups[] = {
    {{5, 0}, FurnitureClass::kChair, 1.0, ""},
    {{6, 0}, FurnitureClass::kSofa, 3.5, ""},
    {{7, 14}, FurnitureClass::kTable, 3.0, ""},
    {{17, 0}, FurnitureClass::kSideboard, 3.0, ""},
    {{3, 32},
     FurnitureClass::kSideboard,
     4.0,
     "a cabinet or night stand (not labelled as furniture)"},
};
constexpr int kNoGroup = -1;

int GroupOf(uint8_t stored_label) {
  const int nyu_id = stored_label + 1;
  for (int g = 0; g < static_cast<int>(std::size(kGroups)); ++g) {
    for (int id : kGroups[g].nyu_ids) {
      if (id != 0 && id == nyu_id) return g;
    }
  }
  return kNoGroup;
}

Eigen::Vector3d BackProject(int index, float depth) {
  const int u = index % kNyuWidth, v = index / kNyuWidth;
  return {(u - kNyuCx) * depth / kNyuFx, (v - kNyuCy) * depth / kNyuFy, depth};
}

// A plane n.p + d = 0 with n towards the camera (d > 0) by RANSAC over a
// fixed-seed draw, refined by least squares on its inliers.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  double offset = 0;
  int inliers = 0;
  double rms = 0;
};

Plane RefinePlane(const std::vector<Eigen::Vector3d>& points, const Plane& start, double band) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<const Eigen::Vector3d*> inliers;
  for (const Eigen::Vector3d& p : points) {
    if (std::abs(start.normal.dot(p) + start.offset) <= band) inliers.push_back(&p);
  }
  if (inliers.size() < 3) return start;
  for (const Eigen::Vector3d* p : inliers) mean += *p;
  mean /= static_cast<double>(inliers.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d* p : inliers) scatter += (*p - mean) * (*p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  Plane plane;
  plane.normal = solver.eigenvectors().col(0);
  plane.offset = -plane.normal.dot(mean);
  if (plane.offset < 0) {
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  double squares = 0;
  for (const Eigen::Vector3d* p : inliers) {
    const double r = plane.normal.dot(*p) + plane.offset;
    squares += r * r;
  }
  plane.inliers = static_cast<int>(inliers.size());
  plane.rms = std::sqrt(squares / static_cast<double>(inliers.size()));
  return plane;
}

Plane FitFloorPlane(const std::vector<Eigen::Vector3d>& points, double band) {
  std::mt19937 random(20121006);  // fixed: the same frame gives the same labels
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  Plane best;
  for (int iteration = 0; iteration < 300; ++iteration) {
    const Eigen::Vector3d& a = points[pick(random)];
    const Eigen::Vector3d& b = points[pick(random)];
    const Eigen::Vector3d& c = points[pick(random)];
    Eigen::Vector3d normal = (b - a).cross(c - a);
    if (normal.norm() < 1e-9) continue;
    normal.normalize();
    Plane candidate{normal, -normal.dot(a), 0, 0};
    for (size_t i = 0; i < points.size(); i += 4) {
      candidate.inliers += std::abs(normal.dot(points[i]) + candidate.offset) <= band;
    }
    if (candidate.inliers > best.inliers) best = candidate;
  }
  return RefinePlane(points, RefinePlane(points, best, band), band);
}

// The floor: a plane through the frame's floor pixels, trusted when the
// camera is above it within the mounting heights.
bool FitFloor(const std::vector<float>& depth_m,
              const std::vector<uint8_t>& labels,
              const NyuDeriveOptions& options,
              NyuFrameLabels* frame) {
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < labels.size(); ++i) {
    const int nyu_id = labels[i] + 1;
    if ((nyu_id == kNyuFloor || nyu_id == kNyuFloorMat) && depth_m[i] > 0)
      points.push_back(BackProject(static_cast<int>(i), depth_m[i]));
  }
  frame->floor_pixels = static_cast<int>(points.size());
  if (frame->floor_pixels < options.min_floor_pixels) {
    frame->reason = "too little floor in view";
    return false;
  }
  const Plane plane = FitFloorPlane(points, options.floor_inlier_m);
  frame->floor_rms_m = plane.rms;
  // The floor is below the camera: its normal towards the camera points up,
  // i.e. against the optical frame's y (down).
  if (plane.normal.y() > -0.3 || plane.inliers < 0.6 * points.size()) {
    frame->reason = "the floor pixels are not one plane below the camera";
    return false;
  }
  if (plane.offset < options.min_camera_height_m || plane.offset > options.max_camera_height_m) {
    frame->reason = "camera height outside the mounting range";
    return false;
  }
  frame->world_from_camera = WorldOfFloor(plane.normal, plane.offset);
  return true;
}

bool Joined(float a, float b, const NyuDeriveOptions& options) {
  return a > 0 && b > 0 &&
         std::abs(a - b) < std::max(options.depth_jump_m, options.depth_jump_fraction * a);
}

// Pixels of one group joined 4-connected where depth is continuous.
std::vector<std::vector<int>> Components(const std::vector<float>& depth_m,
                                         const std::vector<int>& group,
                                         const NyuDeriveOptions& options) {
  std::vector<bool> seen(group.size(), false);
  std::vector<std::vector<int>> components;
  for (size_t start = 0; start < group.size(); ++start) {
    if (seen[start] || group[start] == kNoGroup || depth_m[start] <= 0) continue;
    std::vector<int> pixels;
    std::deque<int> queue{static_cast<int>(start)};
    seen[start] = true;
    while (!queue.empty()) {
      const int i = queue.front();
      queue.pop_front();
      pixels.push_back(i);
      const int u = i % kNyuWidth, v = i / kNyuWidth;
      const int neighbours[4][2] = {{u - 1, v}, {u + 1, v}, {u, v - 1}, {u, v + 1}};
      for (const auto& [nu, nv] : neighbours) {
        if (nu < 0 || nv < 0 || nu >= kNyuWidth || nv >= kNyuHeight) continue;
        const int j = nv * kNyuWidth + nu;
        if (seen[j] || group[j] != group[i] || !Joined(depth_m[i], depth_m[j], options)) continue;
        seen[j] = true;
        queue.push_back(j);
      }
    }
    if (static_cast<int>(pixels.size()) >= options.min_component_pixels)
      components.push_back(std::move(pixels));
  }
  return components;
}

// A piece of an instance: its pixels and their points on the floor frame.
struct Piece {
  int group = kNoGroup;
  std::vector<int> pixels;
  std::vector<Eigen::Vector3d> points;  // label frame
  Eigen::Vector2d low, high;            // footprint bounds (m), trimmed
};

// Bounds of the points' middle 96 % in x and y: filled depth bleeds at edges.
void TrimmedBounds(Piece* piece) {
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<double> values;
    for (const Eigen::Vector3d& p : piece->points) values.push_back(p[axis]);
    const size_t low = values.size() * 2 / 100, high = values.size() - 1 - low;
    std::nth_element(values.begin(), values.begin() + low, values.end());
    piece->low[axis] = values[low];
    std::nth_element(values.begin(), values.begin() + high, values.end());
    piece->high[axis] = values[high];
  }
}

bool ShouldMerge(const Piece& a, const Piece& b, double gap) {
  if (a.group != b.group) return false;
  const Eigen::Vector2d low = a.low.cwiseMin(b.low), high = a.high.cwiseMax(b.high);
  const bool touch = (a.low.array() <= b.high.array() + gap).all() &&
                     (b.low.array() <= a.high.array() + gap).all();
  return touch && (high - low).maxCoeff() <= kGroups[a.group].max_length_m;
}

// Merges pieces of one object split by an occluder (a chair behind a table).
void MergePieces(std::vector<Piece>* pieces, double gap) {
  for (bool merged = true; merged;) {
    merged = false;
    for (size_t i = 0; i < pieces->size() && !merged; ++i) {
      for (size_t j = i + 1; j < pieces->size() && !merged; ++j) {
        Piece& a = (*pieces)[i];
        Piece& b = (*pieces)[j];
        if (!ShouldMerge(a, b, gap)) continue;
        a.pixels.insert(a.pixels.end(), b.pixels.begin(), b.pixels.end());
        a.points.insert(a.points.end(), b.points.begin(), b.points.end());
        a.low = a.low.cwiseMin(b.low);
        a.high = a.high.cwiseMax(b.high);
        pieces->erase(pieces->begin() + static_cast<long>(j));
        merged = true;
      }
    }
  }
}

// The floor cells (5 cm) a piece's points cover, at least 3 points each: each
// place counts once however densely the camera samples it (a table top seen
// at a grazing angle gets few pixels, its front many), and stray filled-depth
// pixels at edges fall away.
std::vector<Eigen::Vector2d> OccupiedCells(const std::vector<Eigen::Vector3d>& points) {
  constexpr double kCellM = 0.05;
  std::map<std::pair<long, long>, int> counts;
  for (const Eigen::Vector3d& p : points)
    ++counts[{std::lround(p.x() / kCellM), std::lround(p.y() / kCellM)}];
  std::vector<Eigen::Vector2d> cells;
  for (const auto& [key, count] : counts) {
    if (count >= 3) cells.emplace_back(key.first * kCellM, key.second * kCellM);
  }
  if (cells.empty()) {  // a piece too sparse for any cell: its points themselves
    for (const Eigen::Vector3d& p : points) cells.push_back(p.head<2>());
  }
  return cells;
}

// The footprint rectangle of the occupied cells along their principal axis:
// centre, sides and the long side's yaw; the top is the points' 98th
// percentile height.
void Footprint(const Piece& piece, NyuInstance* instance) {
  const std::vector<Eigen::Vector2d> cells = OccupiedCells(piece.points);
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& c : cells) mean += c;
  mean /= static_cast<double>(cells.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector2d& c : cells) scatter += (c - mean) * (c - mean).transpose();
  const Eigen::Vector2d axis =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter).eigenvectors().col(1);
  const Eigen::Vector2d across(-axis.y(), axis.x());
  Eigen::Vector2d low(1e9, 1e9), high(-1e9, -1e9);
  for (const Eigen::Vector2d& c : cells) {
    const Eigen::Vector2d local((c - mean).dot(axis), (c - mean).dot(across));
    low = low.cwiseMin(local);
    high = high.cwiseMax(local);
  }
  constexpr double kHalfCellM = 0.025;
  low.array() -= kHalfCellM;
  high.array() += kHalfCellM;
  std::vector<double> heights;
  for (const Eigen::Vector3d& p : piece.points) heights.push_back(p.z());
  const size_t top = (heights.size() - 1) * 98 / 100;
  std::nth_element(heights.begin(), heights.begin() + static_cast<long>(top), heights.end());
  const Eigen::Vector2d centre =
      mean + axis * (low.x() + high.x()) / 2 + across * (low.y() + high.y()) / 2;
  instance->x = centre.x();
  instance->y = centre.y();
  instance->yaw = std::atan2(axis.y(), axis.x());
  instance->size = Eigen::Vector3d(high.x() - low.x(), high.y() - low.y(), heights[top]);
  instance->range_m = centre.norm();
}

double BorderShare(const std::vector<int>& pixels, double band) {
  int near_edge = 0;
  for (int i : pixels) {
    const int u = i % kNyuWidth, v = i / kNyuWidth;
    near_edge += u < band || v < band || u >= kNyuWidth - band || v >= kNyuHeight - band;
  }
  return static_cast<double>(near_edge) / static_cast<double>(pixels.size());
}

// Why an instance is not a target, or "" when it is.
std::string IgnoredBecause(const Piece& piece,
                           const NyuInstance& instance,
                           const NyuDeriveOptions& options) {
  if (kGroups[piece.group].ignored[0] != '\0') return kGroups[piece.group].ignored;
  if (instance.pixels < options.min_object_pixels) return "too few pixels";
  if (instance.range_m > options.max_range_m) return "beyond the range";
  if (instance.size.z() < options.min_top_m) return "top too low (only legs or a seat edge)";
  if (BorderShare(piece.pixels, options.border_band_px) > options.max_border_share)
    return "cut by the image edge";
  return "";
}

NyuInstance InstanceOf(const Piece& piece, const NyuDeriveOptions& options) {
  NyuInstance instance;
  instance.furniture_class = kGroups[piece.group].furniture_class;
  instance.nyu_class = kGroups[piece.group].nyu_ids[0];
  instance.pixels = static_cast<int>(piece.pixels.size());
  instance.pixel_indices = piece.pixels;
  Footprint(piece, &instance);
  if (instance.furniture_class == FurnitureClass::kSofa &&
      std::max(instance.size.x(), instance.size.y()) < options.armchair_max_length_m)
    instance.furniture_class = FurnitureClass::kArmchair;
  instance.ignored = IgnoredBecause(piece, instance, options);
  return instance;
}

std::vector<Piece> Pieces(const std::vector<float>& depth_m,
                          const std::vector<uint8_t>& labels,
                          const Eigen::Isometry3d& world_from_camera,
                          const NyuDeriveOptions& options) {
  std::vector<int> group(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) group[i] = GroupOf(labels[i]);
  std::vector<Piece> pieces;
  for (std::vector<int>& pixels : Components(depth_m, group, options)) {
    Piece piece;
    piece.group = group[pixels.front()];
    for (int i : pixels) piece.points.push_back(world_from_camera * BackProject(i, depth_m[i]));
    piece.pixels = std::move(pixels);
    TrimmedBounds(&piece);
    pieces.push_back(std::move(piece));
  }
  return pieces;
}

}  // namespace

void NyuDeriveOptions::Check() const {
  Require(min_floor_pixels >= 3, "NYU: min floor pixels must be >= 3");
  Require(floor_inlier_m > 0 && floor_inlier_m <= 1, "NYU: floor inlier band must be in (0, 1] m");
  Require(min_camera_height_m >= 0 && min_camera_height_m < max_camera_height_m,
          "NYU: camera heights must be 0 <= min < max");
  Require(depth_jump_m > 0 && depth_jump_fraction >= 0, "NYU: depth jumps must be positive");
  Require(min_component_pixels >= 1 && min_object_pixels >= 1, "NYU: pixel counts must be >= 1");
  Require(merge_gap_m >= 0 && max_range_m > 0 && min_top_m >= 0, "NYU: distances must be >= 0");
  Require(border_band_px >= 0 && max_border_share >= 0 && max_border_share <= 1,
          "NYU: the border share must be in 0..1");
}

NyuFrameLabels DeriveNyuLabels(const std::vector<float>& depth_m,
                               const std::vector<uint8_t>& labels,
                               const NyuDeriveOptions& options) {
  options.Check();
  const size_t pixels = static_cast<size_t>(kNyuWidth) * kNyuHeight;
  Require(depth_m.size() == pixels && labels.size() == pixels,
          "NYU: depth and labels must be 640x480 each");
  NyuFrameLabels frame;
  if (!FitFloor(depth_m, labels, options, &frame)) return frame;
  frame.usable = true;
  std::vector<Piece> pieces = Pieces(depth_m, labels, frame.world_from_camera, options);
  MergePieces(&pieces, options.merge_gap_m);
  for (const Piece& piece : pieces) frame.instances.push_back(InstanceOf(piece, options));
  return frame;
}

}  // namespace furn

#include "core/learned/bev_box_coder.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/util/angles.h"
#include "core/util/error.h"

namespace furn {
namespace {

namespace ch = bev_channels;

constexpr double kMinSizeM = 0.05;  // log-size targets are clamped below this
constexpr float kMinLogSize = -3.0f, kMaxLogSize = 1.5f;

size_t PlaneIndex(const BevGridSpec& spec, int row, int col) {
  return static_cast<size_t>(row) * spec.cols + col;
}

// The regression a cell should output for `object`: offset to its centre
// (cell coordinates -> kOffsetUnitM), log footprint and symmetric yaw.
struct CellBox {
  Eigen::Vector2d offset_cells = Eigen::Vector2d::Zero();  // (row, col)
  float log_width = 0, log_depth = 0;
  float yaw_cos = 1, yaw_sin = 0;
};

CellBox EncodeBox(const BevObject& object,
                  const Eigen::Vector2d& cell_centre,
                  const BevFrame& frame,
                  const BevGridSpec& spec) {
  CellBox box;
  box.offset_cells = frame.CellOf(object.Centre(), spec) - cell_centre;
  box.log_width = static_cast<float>(std::log(std::max(object.width, kMinSizeM)));
  box.log_depth = static_cast<float>(std::log(std::max(object.depth, kMinSizeM)));
  const double yaw = BevYawSymmetry(object.furniture_class) * (object.yaw - frame.heading);
  box.yaw_cos = static_cast<float>(std::cos(yaw));
  box.yaw_sin = static_cast<float>(std::sin(yaw));
  return box;
}

double OffsetScale(const BevGridSpec& spec) { return spec.cell_m / ch::kOffsetUnitM; }

void WriteBox(const CellBox& box, const BevGridSpec& spec, size_t at, std::vector<float>* values) {
  const size_t plane = static_cast<size_t>(spec.rows) * spec.cols;
  auto put = [&](int channel, double value) {
    (*values)[channel * plane + at] = static_cast<float>(value);
  };
  put(ch::kOffset[0], box.offset_cells.x() * OffsetScale(spec));
  put(ch::kOffset[1], box.offset_cells.y() * OffsetScale(spec));
  put(ch::kLogSize[0], box.log_width);
  put(ch::kLogSize[1], box.log_depth);
  put(ch::kYaw[0], box.yaw_cos);
  put(ch::kYaw[1], box.yaw_sin);
}

// What a cell of the network's output says about the object it belongs to.
struct CellVote {
  Eigen::Vector2d centre_cells;  // the voted centre, continuous cell coordinates
  double log_width = 0, log_depth = 0, yaw_cos = 1, yaw_sin = 0;
  double membership = 0;
};

CellVote DecodeCell(const BevOutput& output, int row, int col) {
  const double scale = 1 / OffsetScale(output.spec);
  CellVote vote;
  vote.centre_cells = Eigen::Vector2d(row + 0.5 + output.At(ch::kOffset[0], row, col) * scale,
                                      col + 0.5 + output.At(ch::kOffset[1], row, col) * scale);
  vote.log_width = std::clamp(output.At(ch::kLogSize[0], row, col), kMinLogSize, kMaxLogSize);
  vote.log_depth = std::clamp(output.At(ch::kLogSize[1], row, col), kMinLogSize, kMaxLogSize);
  vote.yaw_cos = output.At(ch::kYaw[0], row, col);
  vote.yaw_sin = output.At(ch::kYaw[1], row, col);
  vote.membership = output.At(ch::kMembership.first, row, col);
  return vote;
}

// Whether world point `xy` lies in the object's footprint widened by margin.
bool InFootprint(const BevObject& object, const Eigen::Vector2d& xy, double margin) {
  const Eigen::Vector2d local = Eigen::Rotation2Dd(-object.yaw) * (xy - object.Centre());
  return std::abs(local.x()) <= object.width / 2 + margin &&
         std::abs(local.y()) <= object.depth / 2 + margin;
}

void SplatHeat(const Eigen::Vector2d& cell, double sigma, const BevGridSpec& spec, float* heat) {
  const int row = static_cast<int>(std::floor(cell.x()));
  const int col = static_cast<int>(std::floor(cell.y()));
  const int reach = static_cast<int>(std::ceil(3 * sigma));
  for (int r = std::max(0, row - reach); r <= std::min(spec.rows - 1, row + reach); ++r) {
    for (int c = std::max(0, col - reach); c <= std::min(spec.cols - 1, col + reach); ++c) {
      const double d2 = (r - row) * (r - row) + (c - col) * (c - col);
      float& h = heat[PlaneIndex(spec, r, c)];
      h = std::max(h, static_cast<float>(std::exp(-d2 / (2 * sigma * sigma))));
    }
  }
}

void ClearDisc(const Eigen::Vector2d& cell, double radius, const BevGridSpec& spec, float* weight) {
  if (radius <= 0) return;
  const int reach = static_cast<int>(std::ceil(radius));
  const int row = static_cast<int>(std::floor(cell.x()));
  const int col = static_cast<int>(std::floor(cell.y()));
  for (int r = std::max(0, row - reach); r <= std::min(spec.rows - 1, row + reach); ++r) {
    for (int c = std::max(0, col - reach); c <= std::min(spec.cols - 1, col + reach); ++c) {
      if (std::hypot(r - row, c - col) <= radius) weight[PlaneIndex(spec, r, c)] = 0.0f;
    }
  }
}

bool InGrid(const Eigen::Vector2d& cell, const BevGridSpec& spec) {
  return cell.x() >= 0 && cell.x() < spec.rows && cell.y() >= 0 && cell.y() < spec.cols;
}

// The index of the target nearest world point `xy` whose footprint widened
// by `margin` holds it; -1: none.
int OwnerOf(const std::vector<BevObject>& objects, const Eigen::Vector2d& xy, double margin) {
  int owner = -1;
  double nearest = 1e30;
  for (size_t i = 0; i < objects.size(); ++i) {
    const double distance = (objects[i].Centre() - xy).norm();
    if (objects[i].target && distance < nearest && InFootprint(objects[i], xy, margin))
      owner = static_cast<int>(i), nearest = distance;
  }
  return owner;
}

// Each occupied cell votes for the nearest target whose widened footprint
// holds it.
void EncodeVotes(const std::vector<BevObject>& objects,
                 const BevImage& image,
                 const BevCoderOptions& options,
                 BevTargets* targets) {
  const BevGridSpec& spec = image.spec;
  const size_t plane = static_cast<size_t>(spec.rows) * spec.cols;
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      if (!image.Occupied(r, c)) continue;
      const Eigen::Vector2d cell_centre(r + 0.5, c + 0.5);
      const int owner =
          OwnerOf(objects, image.frame.WorldOf(cell_centre, spec), options.vote_margin_m);
      if (owner < 0) continue;
      const size_t at = PlaneIndex(spec, r, c);
      WriteBox(
          EncodeBox(objects[owner], cell_centre, image.frame, spec), spec, at, &targets->values);
      targets->values[ch::kMembership.first * plane + at] = 1.0f;
      targets->votes[at] = 1.0f;
    }
  }
}

// The bounding box of an object's footprint in continuous cell coordinates:
// (row min, row max, col min, col max).
Eigen::Vector4d FootprintBoxCells(const BevObject& object, const BevImage& image) {
  Eigen::Vector4d box(1e30, -1e30, 1e30, -1e30);
  const Eigen::Rotation2Dd rotation(object.yaw);
  for (const double sx : {-0.5, 0.5}) {
    for (const double sy : {-0.5, 0.5}) {
      const Eigen::Vector2d corner =
          object.Centre() + rotation * Eigen::Vector2d(sx * object.width, sy * object.depth);
      const Eigen::Vector2d cell = image.frame.CellOf(corner, image.spec);
      box[0] = std::min(box[0], cell.x());
      box[1] = std::max(box[1], cell.x());
      box[2] = std::min(box[2], cell.y());
      box[3] = std::max(box[3], cell.y());
    }
  }
  return box;
}

// Each occupied cell inside a target's widened footprint (the nearest centre
// wins) regresses log(distance + kEdgeEpsM) to the four sides of that
// target's box, and has membership 1 (cells of nothing, whose distances are
// never trained, do not vote).
void EncodeEdges(const std::vector<BevObject>& objects,
                 const BevImage& image,
                 const BevCoderOptions& options,
                 BevTargets* targets) {
  const BevGridSpec& spec = image.spec;
  const size_t plane = static_cast<size_t>(spec.rows) * spec.cols;
  std::vector<Eigen::Vector4d> boxes;
  for (const BevObject& object : objects) boxes.push_back(FootprintBoxCells(object, image));
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      if (!image.Occupied(r, c)) continue;
      const int owner =
          OwnerOf(objects, image.frame.WorldOf({r + 0.5, c + 0.5}, spec), options.vote_margin_m);
      if (owner < 0) continue;
      const Eigen::Vector4d& box = boxes[owner];
      const double distances[4] = {
          r + 0.5 - box[0], box[1] - r - 0.5, c + 0.5 - box[2], box[3] - c - 0.5};
      const size_t at = PlaneIndex(spec, r, c);
      for (int side = 0; side < 4; ++side) {
        const double metres = std::max(0.0, distances[side]) * spec.cell_m;
        targets->values[ch::kEdges[side] * plane + at] =
            static_cast<float>(std::log(metres + ch::kEdgeEpsM));
      }
      targets->edges[at] = 1.0f;
      // The cell belongs to a target: its edge votes count at decoding.
      targets->values[ch::kMembership.first * plane + at] = 1.0f;
    }
  }
}

struct Cell {
  int class_index = 0, row = 0, col = 0;
  float heat = 0;
};

// Cells of one heat plane at least `min_heat` and not below any of their 8
// neighbours (of equal neighbours the first in row-major order wins).
std::vector<Cell> MaximaOf(const BevOutput& output, int class_index, double min_heat) {
  const BevGridSpec& spec = output.spec;
  const int channel = ch::kHeat[class_index];
  std::vector<Cell> maxima;
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const float heat = output.At(channel, r, c);
      if (heat < min_heat) continue;
      bool maximum = true;
      for (int dr = -1; dr <= 1 && maximum; ++dr) {
        for (int dc = -1; dc <= 1 && maximum; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if ((dr == 0 && dc == 0) || rr < 0 || rr >= spec.rows || cc < 0 || cc >= spec.cols)
            continue;
          const float other = output.At(channel, rr, cc);
          const bool earlier = dr < 0 || (dr == 0 && dc < 0);
          if (other > heat || (other == heat && earlier)) maximum = false;
        }
      }
      if (maximum) maxima.push_back({class_index, r, c, heat});
    }
  }
  return maxima;
}

bool Stronger(const Cell& a, const Cell& b) { return a.heat > b.heat; }

// The box a set of weighted votes agrees on.
struct VotedBox {
  Eigen::Vector2d centre_cells;
  double log_width = 0, log_depth = 0, yaw_cos = 0, yaw_sin = 0;
  double weight = 0;
};

// Mean shift of the votes of the occupied cells around `start` (VoteNet's
// vote clustering, one cluster per maximum): a Gaussian kernel of
// vote_bandwidth_m on where each vote lands, times its membership.
VotedBox MeanShiftVotes(const BevImage& image,
                        const BevOutput& output,
                        int class_index,
                        const CellVote& start,
                        const BevDecodeOptions& options) {
  const BevGridSpec& spec = output.spec;
  // The cells that may belong to the object: within its regressed
  // footprint's half-diagonal (and a margin) of the start.
  const double reach =
      std::hypot(std::exp(start.log_width), std::exp(start.log_depth)) / 2 / spec.cell_m + 2;
  std::vector<CellVote> votes;
  const int row0 = static_cast<int>(std::floor(start.centre_cells.x()));
  const int col0 = static_cast<int>(std::floor(start.centre_cells.y()));
  const int span = static_cast<int>(std::ceil(reach));
  for (int r = std::max(0, row0 - span); r <= std::min(spec.rows - 1, row0 + span); ++r) {
    for (int c = std::max(0, col0 - span); c <= std::min(spec.cols - 1, col0 + span); ++c) {
      if (!image.Occupied(r, c)) continue;
      CellVote vote = DecodeCell(output, r, c);
      if (vote.membership < options.min_membership) continue;
      if (options.vote_heat_power > 0)  // membership becomes the vote's weight
        vote.membership *=
            std::pow(output.At(ch::kHeat[class_index], r, c), options.vote_heat_power);
      votes.push_back(vote);
    }
  }
  const double bandwidth = options.vote_bandwidth_m / spec.cell_m;
  VotedBox box;
  box.centre_cells = start.centre_cells;
  for (int iteration = 0; iteration < options.mean_shift_iterations; ++iteration) {
    VotedBox next;
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (const CellVote& vote : votes) {
      const double d2 = (vote.centre_cells - box.centre_cells).squaredNorm();
      const double w = vote.membership * std::exp(-d2 / (2 * bandwidth * bandwidth));
      sum += w * vote.centre_cells;
      next.log_width += w * vote.log_width;
      next.log_depth += w * vote.log_depth;
      next.yaw_cos += w * vote.yaw_cos;
      next.yaw_sin += w * vote.yaw_sin;
      next.weight += w;
    }
    if (next.weight < 1e-6) break;  // no vote near: the maximum's own
    next.centre_cells = sum / next.weight;
    next.log_width /= next.weight;
    next.log_depth /= next.weight;
    box = next;
  }
  return box;
}

// The centre between the four sides the cells around `start` place (FCOS's
// edge distances): each occupied cell of at least min_membership (trained
// on every cell of a target) whose distances put the centre within
// edge_agree_m of `start` says where each side lies, its say on a side
// falling off with its distance to it (times its membership), so each side
// is placed by the cells nearest it. Two rounds, the second around the first's centre. `cells`
// receives how many cells voted (0: `start` is kept).
Eigen::Vector2d EdgeCentre(const BevImage& image,
                           const BevOutput& output,
                           const Eigen::Vector2d& start,
                           double reach_cells,
                           const BevDecodeOptions& options,
                           int* cells) {
  const BevGridSpec& spec = output.spec;
  struct EdgeVote {
    Eigen::Vector4d sides;     // row min, row max, col min, col max (cells)
    Eigen::Vector4d distance;  // to each (cells)
    Eigen::Vector2d centre;
    double membership = 0;
  };
  std::vector<EdgeVote> votes;
  const int row0 = static_cast<int>(std::floor(start.x()));
  const int col0 = static_cast<int>(std::floor(start.y()));
  const int span = static_cast<int>(std::ceil(reach_cells));
  for (int r = std::max(0, row0 - span); r <= std::min(spec.rows - 1, row0 + span); ++r) {
    for (int c = std::max(0, col0 - span); c <= std::min(spec.cols - 1, col0 + span); ++c) {
      if (!image.Occupied(r, c)) continue;
      EdgeVote vote;
      vote.membership = output.At(ch::kMembership.first, r, c);
      if (vote.membership < options.min_membership) continue;
      for (int side = 0; side < 4; ++side) {
        const double metres =
            std::exp(std::clamp(output.At(ch::kEdges[side], r, c), -5.0f, 2.0f)) - ch::kEdgeEpsM;
        vote.distance[side] = std::max(0.0, metres) / spec.cell_m;
      }
      vote.sides = {r + 0.5 - vote.distance[0],
                    r + 0.5 + vote.distance[1],
                    c + 0.5 - vote.distance[2],
                    c + 0.5 + vote.distance[3]};
      vote.centre = {(vote.sides[0] + vote.sides[1]) / 2, (vote.sides[2] + vote.sides[3]) / 2};
      votes.push_back(vote);
    }
  }
  const double agree = options.edge_agree_m / spec.cell_m;
  const double near = options.edge_near_m / spec.cell_m;
  Eigen::Vector2d centre = start;
  *cells = 0;
  for (int round = 0; round < 2; ++round) {
    std::vector<const EdgeVote*> agreeing;
    for (const EdgeVote& vote : votes)
      if ((vote.centre - centre).norm() <= agree) agreeing.push_back(&vote);
    if (agreeing.empty()) break;
    Eigen::Vector4d sides;
    for (int side = 0; side < 4; ++side) {
      double closest = 1e30;
      for (const EdgeVote* vote : agreeing) closest = std::min(closest, vote->distance[side]);
      double sum = 0, weight = 0;
      for (const EdgeVote* vote : agreeing) {
        const double w = vote->membership * std::exp(-(vote->distance[side] - closest) / near);
        sum += w * vote->sides[side];
        weight += w;
      }
      sides[side] = sum / weight;
    }
    centre = {(sides[0] + sides[1]) / 2, (sides[2] + sides[3]) / 2};
    *cells = static_cast<int>(agreeing.size());
  }
  return centre;
}

BevPeak PeakOf(const BevImage& image,
               const BevOutput& output,
               const Cell& cell,
               const BevDecodeOptions& options) {
  const CellVote own = DecodeCell(output, cell.row, cell.col);
  BevPeak peak;
  peak.furniture_class = kAllClasses[cell.class_index];
  peak.heat = cell.heat;
  const Eigen::Vector2d own_xy = image.frame.WorldOf(own.centre_cells, output.spec);
  peak.peak_x = own_xy.x();
  peak.peak_y = own_xy.y();
  VotedBox box{own.centre_cells, own.log_width, own.log_depth, own.yaw_cos, own.yaw_sin, 0};
  if (options.centre == BevCentre::kVotes && output.dense_votes) {
    const VotedBox voted = MeanShiftVotes(image, output, cell.class_index, own, options);
    if (voted.weight > 0) box = voted;
  }
  if (output.edge_votes && UsesEdges(options.edge_classes, peak.furniture_class)) {
    const double reach =
        std::hypot(std::exp(box.log_width), std::exp(box.log_depth)) / 2 / output.spec.cell_m + 2;
    box.centre_cells =
        EdgeCentre(image, output, box.centre_cells, reach, options, &peak.edge_cells);
  }
  const Eigen::Vector2d xy = image.frame.WorldOf(box.centre_cells, output.spec);
  peak.x = xy.x();
  peak.y = xy.y();
  peak.votes = box.weight;
  peak.width = std::exp(box.log_width);
  peak.depth = std::exp(box.log_depth);
  peak.yaw = WrapAngle(std::atan2(box.yaw_sin, box.yaw_cos) / BevYawSymmetry(peak.furniture_class) +
                       image.frame.heading);
  return peak;
}

// A target's centre cell always regresses its box, seen or not (a table's
// centre under its top may hold no point when the top was not seen); so do
// the cells within `radius` cells of it that no dense vote took, each for
// the nearest such centre.
void EncodeCentreCells(const std::vector<BevObject>& objects,
                       const BevImage& image,
                       double radius,
                       BevTargets* targets) {
  const BevGridSpec& spec = image.spec;
  const size_t plane = static_cast<size_t>(spec.rows) * spec.cols;
  const int reach = static_cast<int>(std::floor(radius));
  std::vector<float> taken_at(plane, std::numeric_limits<float>::infinity());
  for (size_t i = 0; i < plane; ++i) {
    if (targets->votes[i] > 0) taken_at[i] = -1;  // a dense vote's
  }
  for (const BevObject& object : objects) {
    const Eigen::Vector2d cell = image.frame.CellOf(object.Centre(), spec);
    if (!object.target || !InGrid(cell, spec)) continue;
    const int row = static_cast<int>(std::floor(cell.x())),
              col = static_cast<int>(std::floor(cell.y()));
    for (int r = std::max(0, row - reach); r <= std::min(spec.rows - 1, row + reach); ++r) {
      for (int c = std::max(0, col - reach); c <= std::min(spec.cols - 1, col + reach); ++c) {
        const float distance = static_cast<float>(std::hypot(r - row, c - col));
        const size_t at = PlaneIndex(spec, r, c);
        if (distance > radius || distance >= taken_at[at]) continue;
        taken_at[at] = distance;
        WriteBox(
            EncodeBox(object, {r + 0.5, c + 0.5}, image.frame, spec), spec, at, &targets->values);
        targets->values[ch::kMembership.first * plane + at] = 1.0f;
        targets->votes[at] = 1.0f;
      }
    }
  }
}

// Whether a peak of peak's class lies within distance_m of it.
bool NearOneOfItsClass(const std::vector<BevPeak>& peaks, const BevPeak& peak, double distance_m) {
  return std::any_of(peaks.begin(), peaks.end(), [&](const BevPeak& kept) {
    return kept.furniture_class == peak.furniture_class &&
           std::hypot(kept.x - peak.x, kept.y - peak.y) < distance_m;
  });
}

}  // namespace

bool UsesEdges(BevEdgeClasses classes, FurnitureClass furniture_class) {
  switch (classes) {
    case BevEdgeClasses::kNone:
      return false;
    case BevEdgeClasses::kAll:
      return true;
    case BevEdgeClasses::kLarge:
      return furniture_class == FurnitureClass::kTable ||
             furniture_class == FurnitureClass::kSideboard ||
             furniture_class == FurnitureClass::kSofa;
  }
  return false;
}

int BevYawSymmetry(FurnitureClass furniture_class) {
  return furniture_class == FurnitureClass::kTable ? 2 : 1;
}

BevCoderOptions BevCoderOptions::Dense() {
  BevCoderOptions dense;
  dense.heat_sigma_cells = 1.5;
  dense.dense_votes = true;
  dense.ignore_radius_cells = 3;
  return dense;
}

bool BevCoderOptions::operator==(const BevCoderOptions& other) const {
  return heat_sigma_cells == other.heat_sigma_cells && dense_votes == other.dense_votes &&
         vote_margin_m == other.vote_margin_m && ignore_radius_cells == other.ignore_radius_cells &&
         edge_votes == other.edge_votes && centre_radius_cells == other.centre_radius_cells;
}

double BevSplatSigma(double width_m, double depth_m, const BevGridSpec& spec) {
  return std::clamp(std::min(width_m, depth_m) / (6 * spec.cell_m), 1.0, 3.0);
}

void BevCoderOptions::Check() const {
  Require(heat_sigma_cells == 0 || (heat_sigma_cells >= 0.5 && heat_sigma_cells <= 10),
          "BEV heat sigma " + std::to_string(heat_sigma_cells) +
              " cells must be 0 (from the footprint) or in 0.5..10");
  Require(vote_margin_m >= 0 && vote_margin_m <= 1,
          "BEV vote margin " + std::to_string(vote_margin_m) + " m must be in 0..1");
  Require(ignore_radius_cells >= 0 && ignore_radius_cells <= 20,
          "BEV ignore radius " + std::to_string(ignore_radius_cells) + " cells must be in 0..20");
  Require(centre_radius_cells >= 0 && centre_radius_cells <= 10,
          "BEV centre radius " + std::to_string(centre_radius_cells) + " cells must be in 0..10");
}

void BevDecodeOptions::Check() const {
  Require(min_heat >= 0 && min_heat <= 1,
          "learned min heat " + std::to_string(min_heat) + " must be in 0..1");
  Require(max_per_class >= 1 && max_per_class <= 1000,
          "learned maxima per class " + std::to_string(max_per_class) + " must be in 1..1000");
  Require(same_class_m >= 0 && same_class_m <= 5,
          "learned same-class separation " + std::to_string(same_class_m) + " m must be in 0..5");
  Require(max_distance_m > 0,
          "learned maxima range " + std::to_string(max_distance_m) + " m must be > 0");
  Require(suppress_m >= 0 && suppress_m <= 5,
          "learned suppression radius " + std::to_string(suppress_m) + " m must be in 0..5");
  Require(vote_bandwidth_m > 0 && vote_bandwidth_m <= 1,
          "vote bandwidth " + std::to_string(vote_bandwidth_m) + " m must be in (0, 1]");
  Require(min_membership >= 0 && min_membership <= 1,
          "vote min membership " + std::to_string(min_membership) + " must be in 0..1");
  Require(vote_heat_power >= 0 && vote_heat_power <= 8,
          "vote heat power " + std::to_string(vote_heat_power) + " must be in 0..8");
  Require(mean_shift_iterations >= 1 && mean_shift_iterations <= 100,
          "mean shift iterations must be in 1..100");
  Require(edge_near_m > 0 && edge_near_m <= 5,
          "edge vote reach " + std::to_string(edge_near_m) + " m must be in (0, 5]");
  Require(edge_agree_m > 0 && edge_agree_m <= 5,
          "edge vote agreement " + std::to_string(edge_agree_m) + " m must be in (0, 5]");
}

BevTargets EncodeBevTargets(const std::vector<BevObject>& objects,
                            const BevImage& image,
                            const BevCoderOptions& options) {
  const BevGridSpec& spec = image.spec;
  const size_t plane = static_cast<size_t>(spec.rows) * spec.cols;
  BevTargets targets;
  targets.channels = options.Channels();
  targets.values.assign(targets.channels * plane, 0.0f);
  targets.votes.assign(plane, 0.0f);
  targets.weight.assign(plane, 1.0f);
  if (options.edge_votes) targets.edges.assign(plane, 0.0f);
  for (const BevObject& object : objects) {
    const Eigen::Vector2d cell = image.frame.CellOf(object.Centre(), spec);
    if (!InGrid(cell, spec)) continue;
    if (!object.target) {
      ClearDisc(cell, options.ignore_radius_cells, spec, targets.weight.data());
      continue;
    }
    ++targets.objects;
    const int k = static_cast<int>(object.furniture_class);
    const double sigma = options.heat_sigma_cells > 0
                             ? options.heat_sigma_cells
                             : BevSplatSigma(object.width, object.depth, spec);
    SplatHeat(cell, sigma, spec, &targets.values[ch::kHeat[k] * plane]);
  }
  if (options.dense_votes) EncodeVotes(objects, image, options, &targets);
  if (options.edge_votes) EncodeEdges(objects, image, options, &targets);
  EncodeCentreCells(
      objects, image, options.dense_votes ? 0 : options.centre_radius_cells, &targets);
  return targets;
}

std::vector<BevPeak> DecodeBevOutput(const BevImage& image,
                                     const BevOutput& output,
                                     const BevDecodeOptions& options) {
  options.Check();
  Require(output.values.size() == static_cast<size_t>(ch::CountOf(output.edge_votes)) *
                                      output.spec.rows * output.spec.cols,
          "a vote network output has the wrong number of channels");
  std::vector<Cell> cells;
  for (int k = 0; k < kBevClasses; ++k) {
    std::vector<Cell> of_class = MaximaOf(output, k, options.min_heat);
    std::stable_sort(of_class.begin(), of_class.end(), Stronger);
    if (of_class.size() > static_cast<size_t>(options.max_per_class))
      of_class.resize(options.max_per_class);
    cells.insert(cells.end(), of_class.begin(), of_class.end());
  }
  std::stable_sort(cells.begin(), cells.end(), Stronger);
  std::vector<BevPeak> peaks;
  for (const Cell& cell : cells) {
    BevPeak peak = PeakOf(image, output, cell, options);
    if ((Eigen::Vector2d(peak.x, peak.y) - image.frame.origin).norm() > options.max_distance_m)
      continue;
    if (NearOneOfItsClass(peaks, peak, options.same_class_m)) continue;
    for (const BevPeak& kept : peaks) {
      const double distance = std::hypot(kept.x - peak.x, kept.y - peak.y);
      if (options.suppress_m > 0 && !kept.suppressed && distance < options.suppress_m) {
        peak.suppressed = true;
        peak.suppressed_by_m = distance;
        break;
      }
    }
    peaks.push_back(peak);
  }
  return peaks;
}

}  // namespace furn

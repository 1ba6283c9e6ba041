// The box coder of the learned vote map: what targets say (heat at centres,
// dense votes on each target's occupied cells, ignore regions), and that
// decoding the targets themselves gives back the objects, by the peak cell
// and by the votes; the votes' mean shift outvotes one wrong peak cell;
// cross-class suppression is an option, a class's maximum seen twice is
// one object; edge votes place a long table's sides where its centre cell
// guessed wrong.
#include "core/learned/bev_box_coder.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/util/angles.h"

namespace furn {
namespace {

namespace ch = bev_channels;

// The grid of a sensor at the origin looking along +x; the cells of each
// object's footprint occupied, as a scan seen from above would make them.
BevImage ImageWith(const std::vector<BevObject>& objects) {
  BevImage image;
  image.values.assign(static_cast<size_t>(kBevChannels) * image.spec.rows * image.spec.cols, 0.0f);
  for (int r = 0; r < image.spec.rows; ++r) {
    for (int c = 0; c < image.spec.cols; ++c) {
      const Eigen::Vector2d xy = image.frame.WorldOf({r + 0.5, c + 0.5}, image.spec);
      for (const BevObject& object : objects) {
        const Eigen::Vector2d local = Eigen::Rotation2Dd(-object.yaw) * (xy - object.Centre());
        if (std::abs(local.x()) < object.width / 2 && std::abs(local.y()) < object.depth / 2)
          image.At(3, r, c) = 0.5f;  // points 0.5-0.8 m
      }
    }
  }
  return image;
}

// The targets as if the network had output them exactly.
BevOutput PerfectOutput(const BevTargets& targets,
                        const BevGridSpec& spec,
                        bool dense_votes = true) {
  return BevOutput{spec, targets.values, dense_votes};
}

size_t At(const BevGridSpec& spec, int channel, int row, int col) {
  return (static_cast<size_t>(channel) * spec.rows + row) * spec.cols + col;
}

const BevObject kTable{{2.012, 0.537, 0.3, 1.2, 0.8}, FurnitureClass::kTable};
const BevObject kChair{{1.013, -0.513, 2.0, 0.5, 0.55}, FurnitureClass::kChair};

TEST(BevBoxCoder, HeatPeaksAtCentresAndOccupiedFootprintCellsVote) {
  const BevObject outside{{-1.0, 0.0, 0.0, 0.5, 0.5}, FurnitureClass::kChair};
  const BevImage image = ImageWith({kTable, kChair});
  const BevGridSpec& spec = image.spec;
  const BevTargets t = EncodeBevTargets({kTable, kChair, outside}, image, BevCoderOptions::Dense());
  EXPECT_EQ(t.objects, 2);
  const Eigen::Vector2d cell = image.frame.CellOf(kTable.Centre(), spec);
  const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
  const int table = ch::kHeat[static_cast<int>(FurnitureClass::kTable)];
  EXPECT_FLOAT_EQ(t.values[At(spec, table, row, col)], 1.0f);
  EXPECT_NEAR(t.values[At(spec, table, row, col + 2)], std::exp(-4 / (2 * 1.5 * 1.5)), 1e-6);
  EXPECT_EQ(t.values[At(spec, ch::kHeat[static_cast<int>(FurnitureClass::kChair)], row, col)], 0);
  // A cell near the table's corner votes for its centre, in tenths of a metre.
  const Eigen::Vector2d corner_xy =
      kTable.Centre() + Eigen::Rotation2Dd(kTable.yaw) * Eigen::Vector2d(0.5, 0.3);
  const Eigen::Vector2d corner = image.frame.CellOf(corner_xy, spec);
  const int cr = static_cast<int>(corner.x()), cc = static_cast<int>(corner.y());
  EXPECT_EQ(t.votes[static_cast<size_t>(cr) * spec.cols + cc], 1.0f);
  EXPECT_EQ(t.values[At(spec, ch::kMembership.first, cr, cc)], 1.0f);
  const Eigen::Vector2d to_centre = (cell - Eigen::Vector2d(cr + 0.5, cc + 0.5)) * spec.cell_m;
  EXPECT_NEAR(t.values[At(spec, ch::kOffset[0], cr, cc)], to_centre.x() / ch::kOffsetUnitM, 1e-5);
  EXPECT_NEAR(t.values[At(spec, ch::kOffset[1], cr, cc)], to_centre.y() / ch::kOffsetUnitM, 1e-5);
  EXPECT_NEAR(std::exp(t.values[At(spec, ch::kLogSize[0], cr, cc)]), 1.2, 1e-5);
  EXPECT_NEAR(std::exp(t.values[At(spec, ch::kLogSize[1], cr, cc)]), 0.8, 1e-5);
  EXPECT_NEAR(t.values[At(spec, ch::kYaw[0], cr, cc)], std::cos(0.6), 1e-5);  // 2 x yaw
  // Free floor between the objects: no vote, membership 0, heat loss counts.
  const Eigen::Vector2d free = image.frame.CellOf({1.5, 0.0}, spec);
  const size_t free_at = static_cast<size_t>(free.x()) * spec.cols + static_cast<size_t>(free.y());
  EXPECT_EQ(t.votes[free_at], 0.0f);
  EXPECT_EQ(t.weight[free_at], 1.0f);
  // A table turned half a turn is the same table: the same yaw target.
  const BevObject turned{{kTable.x, kTable.y, 0.3 + M_PI, 1.2, 0.8}, FurnitureClass::kTable};
  const BevTargets u = EncodeBevTargets({turned}, image, BevCoderOptions::Dense());
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(
        u.values[At(spec, ch::kYaw[k], row, col)], t.values[At(spec, ch::kYaw[k], row, col)], 1e-5);
  }
}

TEST(BevBoxCoder, ObjectsSeenTooLittleAreIgnoredNotPunished) {
  BevObject glimpsed = kChair;
  glimpsed.target = false;
  const BevImage image = ImageWith({kTable, glimpsed});
  const BevTargets t = EncodeBevTargets({kTable, glimpsed}, image, BevCoderOptions::Dense());
  EXPECT_EQ(t.objects, 1);
  const Eigen::Vector2d cell = image.frame.CellOf(glimpsed.Centre(), image.spec);
  const size_t at = static_cast<size_t>(cell.x()) * image.spec.cols + static_cast<size_t>(cell.y());
  EXPECT_EQ(t.weight[at], 0.0f);
  EXPECT_EQ(t.votes[at], 0.0f);
  EXPECT_EQ(t.values[At(
                image.spec, ch::kHeat[0], static_cast<int>(cell.x()), static_cast<int>(cell.y()))],
            0.0f);
  // Four cells away the loss counts again (radius 3 cells).
  EXPECT_EQ(t.weight[at + 4], 1.0f);
}

TEST(BevBoxCoder, DecodingTheTargetsGivesBackTheObjects) {
  const BevImage image = ImageWith({kTable, kChair});
  const BevTargets t = EncodeBevTargets({kTable, kChair}, image, BevCoderOptions::Dense());
  for (const BevCentre centre : {BevCentre::kPeak, BevCentre::kVotes}) {
    BevDecodeOptions options;
    options.centre = centre;
    const std::vector<BevPeak> peaks =
        DecodeBevOutput(image, PerfectOutput(t, image.spec), options);
    ASSERT_EQ(peaks.size(), 2u) << EnumName(centre);
    for (const BevObject& object : {kTable, kChair}) {
      const BevPeak* found = nullptr;
      for (const BevPeak& peak : peaks) {
        if (peak.furniture_class == object.furniture_class) found = &peak;
      }
      ASSERT_NE(found, nullptr);
      EXPECT_NEAR(found->x, object.Centre().x(), 1e-4) << EnumName(centre);
      EXPECT_NEAR(found->y, object.Centre().y(), 1e-4) << EnumName(centre);
      EXPECT_NEAR(found->width, object.width, 1e-4);
      EXPECT_NEAR(found->depth, object.depth, 1e-4);
      const double period = 2 * M_PI / BevYawSymmetry(object.furniture_class);
      EXPECT_NEAR(std::remainder(found->yaw - object.yaw, period), 0, 1e-4) << EnumName(centre);
      EXPECT_FLOAT_EQ(found->heat, 1.0f);
      EXPECT_EQ(found->votes > 0, centre == BevCentre::kVotes);
    }
  }
}

// One wrong guess at the peak cell moves the peak decoding by 15 cm; the
// table's hundreds of agreeing votes keep the vote decoding on its centre.
TEST(BevBoxCoder, VotesOutvoteOneWrongPeakCell) {
  const BevImage image = ImageWith({kTable});
  const BevTargets t = EncodeBevTargets({kTable}, image, BevCoderOptions::Dense());
  BevOutput output = PerfectOutput(t, image.spec);
  const Eigen::Vector2d cell = image.frame.CellOf(kTable.Centre(), image.spec);
  const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
  output.values[At(image.spec, ch::kOffset[1], row, col)] += 1.5f;  // 15 cm to the left
  BevDecodeOptions options;
  options.centre = BevCentre::kPeak;
  const BevPeak peak = DecodeBevOutput(image, output, options).front();
  options.centre = BevCentre::kVotes;
  const BevPeak voted = DecodeBevOutput(image, output, options).front();
  EXPECT_NEAR(std::hypot(peak.x - kTable.Centre().x(), peak.y - kTable.Centre().y()), 0.15, 1e-4);
  EXPECT_LT(std::hypot(voted.x - kTable.Centre().x(), voted.y - kTable.Centre().y()), 0.01);
  EXPECT_NEAR(voted.peak_x, peak.x, 1e-9);  // the peak cell's own vote, reported
  EXPECT_GT(voted.votes, 100);
  // A network trained without dense votes: its other cells' offsets mean
  // nothing, so the peak decides whatever the option says.
  output.dense_votes = false;
  const BevPeak undense = DecodeBevOutput(image, output, options).front();
  EXPECT_NEAR(undense.x, peak.x, 1e-9);
  EXPECT_EQ(undense.votes, 0);
}

// Issue 30's encoding (the default): the heat's width from the footprint,
// the centre cell alone regresses, objects seen too little left out.
TEST(BevBoxCoder, CentreCellEncodingRegressesAtTheCentreOnly) {
  BevObject glimpsed = kChair;
  glimpsed.target = false;
  const BevImage image = ImageWith({kTable, glimpsed});
  const BevGridSpec& spec = image.spec;
  const BevTargets t = EncodeBevTargets({kTable, glimpsed}, image, BevCoderOptions{});
  EXPECT_EQ(t.objects, 1);
  const Eigen::Vector2d cell = image.frame.CellOf(kTable.Centre(), spec);
  const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
  const int table = ch::kHeat[static_cast<int>(FurnitureClass::kTable)];
  const double sigma = BevSplatSigma(kTable.width, kTable.depth, spec);
  EXPECT_NEAR(sigma, 2.67, 0.01);
  EXPECT_NEAR(t.values[At(spec, table, row, col + 2)], std::exp(-4 / (2 * sigma * sigma)), 1e-6);
  double voting = 0, weight = 0;
  for (size_t i = 0; i < t.votes.size(); ++i) voting += t.votes[i], weight += t.weight[i];
  EXPECT_EQ(voting, 1);                                     // the table's centre cell
  EXPECT_EQ(weight, static_cast<double>(t.weight.size()));  // no ignore region
  EXPECT_EQ(t.votes[static_cast<size_t>(row) * spec.cols + col], 1.0f);
  const std::vector<BevPeak> peaks =
      DecodeBevOutput(image, PerfectOutput(t, spec, /*dense_votes=*/false), BevDecodeOptions{});
  ASSERT_EQ(peaks.size(), 1u);
  EXPECT_NEAR(peaks[0].x, kTable.Centre().x(), 1e-4);
  EXPECT_NEAR(peaks[0].y, kTable.Centre().y(), 1e-4);
  EXPECT_NEAR(peaks[0].width, kTable.width, 1e-4);
}

// The centre cells' radius: the cells within 2 cells of each centre regress
// the box too, each for its nearest centre (two chairs 3 cells apart share
// none), so a heat peak that lands a cell off the centre decodes to the
// centre; the centre cell alone (radius 0) is the encoding as before.
TEST(BevBoxCoder, CentreRadiusCellsRegressTheCentreTheyAreNear) {
  const BevObject left{{1.512, 0.312, 0.2, 0.5, 0.5}, FurnitureClass::kChair};
  const BevObject right{{1.512, 0.162, 0.2, 0.5, 0.5}, FurnitureClass::kChair};
  const BevImage image = ImageWith({left, right});
  const BevGridSpec& spec = image.spec;
  BevCoderOptions coder;
  coder.centre_radius_cells = 2;
  const BevTargets wide = EncodeBevTargets({left, right}, image, coder);
  const BevTargets alone = EncodeBevTargets({left, right}, image, BevCoderOptions{});
  double voting = 0, voting_alone = 0;
  for (size_t i = 0; i < wide.votes.size(); ++i) voting += wide.votes[i];
  for (size_t i = 0; i < alone.votes.size(); ++i) voting_alone += alone.votes[i];
  EXPECT_EQ(voting_alone, 2);
  EXPECT_GT(voting, 2 * 9);  // a disc of 13 cells each, less what the other took
  EXPECT_LT(voting, 2 * 13);
  // A peak one cell towards the other chair, on each side of the midline,
  // regresses the centre of the chair it is nearer.
  for (const int toward : {-1, 1}) {  // columns grow to the left: -1 is rightwards
    const BevObject& chair = toward < 0 ? left : right;
    const Eigen::Vector2d cell = image.frame.CellOf(chair.Centre(), spec);
    const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
    BevOutput output = PerfectOutput(wide, spec, /*dense_votes=*/false);
    const int heat = ch::kHeat[static_cast<int>(FurnitureClass::kChair)];
    for (int dc = -2; dc <= 2; ++dc)  // the heat's peak moved one cell
      output.values[At(spec, heat, row, col + dc)] = dc == toward ? 1.0f : 0.5f;
    BevDecodeOptions decode;
    decode.centre = BevCentre::kPeak;
    decode.same_class_m = 0;  // two chairs closer than any two stand
    const BevPeak* nearest = nullptr;
    const std::vector<BevPeak> peaks = DecodeBevOutput(image, output, decode);
    for (const BevPeak& peak : peaks) {
      if (!nearest ||
          std::hypot(peak.x - chair.Centre().x(), peak.y - chair.Centre().y()) <
              std::hypot(nearest->x - chair.Centre().x(), nearest->y - chair.Centre().y()))
        nearest = &peak;
    }
    ASSERT_NE(nearest, nullptr);
    EXPECT_NEAR(nearest->x, chair.Centre().x(), 1e-4);
    EXPECT_NEAR(nearest->y, chair.Centre().y(), 1e-4);
  }
  coder.centre_radius_cells = 10.5;
  EXPECT_THROW(coder.Check(), InputError);
}

// Edge votes: every occupied cell of a target regresses its distances to
// the sides of the footprint's box in the grid; decoding centres a table
// between the sides its cells place, where its centre cell's own vote slid
// 20 cm along its length, and leaves a chair beside it (whose cells place
// another box) and the chair's own centre alone.
TEST(BevBoxCoder, EdgeVotesCentreALongTableWhereItsPeakSlid) {
  const BevObject table{{2.1, 0.2, 0.3, 2.0, 0.9}, FurnitureClass::kTable};
  const BevObject chair{{2.0, -0.85, 1.8, 0.5, 0.5}, FurnitureClass::kChair};
  const BevImage image = ImageWith({table, chair});
  const BevGridSpec& spec = image.spec;
  BevCoderOptions coder;
  coder.edge_votes = true;
  BevTargets t = EncodeBevTargets({table, chair}, image, coder);
  ASSERT_EQ(t.channels, ch::kCountWithEdges);
  ASSERT_EQ(t.values.size(), static_cast<size_t>(ch::kCountWithEdges) * spec.rows * spec.cols);
  // A cell of the table: log(distance + eps) to each side of its box.
  const Eigen::Vector2d probe = image.frame.CellOf({2.5, 0.35}, spec);
  const int pr = static_cast<int>(probe.x()), pc = static_cast<int>(probe.y());
  ASSERT_EQ(t.edges[static_cast<size_t>(pr) * spec.cols + pc], 1.0f);
  double row_min = 1e9, row_max = -1e9;
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      const Eigen::Vector2d corner =
          table.Centre() + Eigen::Rotation2Dd(table.yaw) * Eigen::Vector2d(sx * 1.0, sy * 0.45);
      row_min = std::min(row_min, image.frame.CellOf(corner, spec).x());
      row_max = std::max(row_max, image.frame.CellOf(corner, spec).x());
    }
  }
  EXPECT_NEAR(std::exp(t.values[At(spec, ch::kEdges[0], pr, pc)]) - ch::kEdgeEpsM,
              (pr + 0.5 - row_min) * spec.cell_m,
              1e-5);
  EXPECT_NEAR(std::exp(t.values[At(spec, ch::kEdges[1], pr, pc)]) - ch::kEdgeEpsM,
              (row_max - pr - 0.5) * spec.cell_m,
              1e-5);
  // Free floor: no edge loss.
  const Eigen::Vector2d free = image.frame.CellOf({1.0, 1.0}, spec);
  EXPECT_EQ(t.edges[static_cast<size_t>(free.x()) * spec.cols + static_cast<size_t>(free.y())], 0);

  // A shelf behind the table (no target: its cells' distances are never
  // trained, and here claim the table's far side at their own row, with a
  // centre 12.5 cm beyond the table's) has membership 0 and does not vote.
  const BevObject shelf{{3.45, 0.2, 0.0, 0.3, 1.5}, FurnitureClass::kSideboard, false};
  const BevImage with_shelf = ImageWith({table, chair, shelf});
  const BevTargets t2 = EncodeBevTargets({table, chair, shelf}, with_shelf, coder);
  EXPECT_EQ(t2.values, t.values);  // the shelf encodes nothing
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const Eigen::Vector2d xy = with_shelf.frame.WorldOf({r + 0.5, c + 0.5}, spec);
      if (!with_shelf.Occupied(r, c) || image.Occupied(r, c)) continue;
      ASSERT_GT(xy.x(), 3.25);
      t.values[At(spec, ch::kEdges[1], r, c)] = std::log(0.0f + ch::kEdgeEpsM);
      t.values[At(spec, ch::kEdges[0], r, c)] = std::log(static_cast<float>(
          (r + 0.5 - image.frame.CellOf(table.Centre(), spec).x()) * 2 * spec.cell_m - 0.25 +
          ch::kEdgeEpsM));
    }
  }

  // The table's centre cell votes 20 cm off along the grid's rows.
  const Eigen::Vector2d cell = image.frame.CellOf(table.Centre(), spec);
  const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
  t.values[At(spec, ch::kOffset[0], row, col)] += 0.2f / ch::kOffsetUnitM;
  BevOutput output{spec, t.values, /*dense_votes=*/false, /*edge_votes=*/true};
  BevDecodeOptions options;
  options.edge_classes = BevEdgeClasses::kNone;
  auto of_class = [](const std::vector<BevPeak>& peaks, FurnitureClass c) {
    for (const BevPeak& peak : peaks)
      if (peak.furniture_class == c) return peak;
    ADD_FAILURE() << "no " << ClassName(c);
    return BevPeak{};
  };
  const BevPeak slid =
      of_class(DecodeBevOutput(with_shelf, output, options), FurnitureClass::kTable);
  EXPECT_NEAR(std::hypot(slid.x - table.Centre().x(), slid.y - table.Centre().y()), 0.2, 1e-3);
  EXPECT_EQ(slid.edge_cells, 0);
  options.edge_classes = BevEdgeClasses::kAll;
  const std::vector<BevPeak> peaks = DecodeBevOutput(with_shelf, output, options);
  const BevPeak placed = of_class(peaks, FurnitureClass::kTable);
  EXPECT_LT(std::hypot(placed.x - table.Centre().x(), placed.y - table.Centre().y()), 0.01);
  // Were the shelf's cells members, they would pull the far side in.
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      if (with_shelf.Occupied(r, c) && !image.Occupied(r, c))
        output.values[At(spec, ch::kMembership.first, r, c)] = 1.0f;
    }
  }
  const BevPeak pulled =
      of_class(DecodeBevOutput(with_shelf, output, options), FurnitureClass::kTable);
  EXPECT_GT(std::hypot(pulled.x - table.Centre().x(), pulled.y - table.Centre().y()), 0.02);
  EXPECT_GT(placed.edge_cells, 300);  // 2 x 0.9 m of 5 cm cells: about 720
  const BevPeak seat = of_class(peaks, FurnitureClass::kChair);
  EXPECT_LT(std::hypot(seat.x - chair.Centre().x(), seat.y - chair.Centre().y()), 0.01);
  EXPECT_LT(seat.edge_cells, 150);  // its own cells, not the table's
  EXPECT_GT(seat.edge_cells, 50);
}

TEST(BevBoxCoder, CrossClassSuppressionIsAnOption) {
  // A chair and an armchair maximum at one place (the armchair weaker).
  const BevImage image = ImageWith({kChair});
  BevObject armchair = kChair;
  armchair.furniture_class = FurnitureClass::kArmchair;
  BevTargets t = EncodeBevTargets({kChair, armchair}, image, BevCoderOptions::Dense());
  const Eigen::Vector2d cell = image.frame.CellOf(kChair.Centre(), image.spec);
  t.values[At(image.spec,
              ch::kHeat[static_cast<int>(FurnitureClass::kArmchair)],
              static_cast<int>(cell.x()),
              static_cast<int>(cell.y()))] = 0.6f;
  BevDecodeOptions options;  // suppression off by default
  std::vector<BevPeak> peaks = DecodeBevOutput(image, PerfectOutput(t, image.spec), options);
  ASSERT_EQ(peaks.size(), 2u);
  EXPECT_FALSE(peaks[0].suppressed);
  EXPECT_FALSE(peaks[1].suppressed);
  options.suppress_m = 0.3;
  peaks = DecodeBevOutput(image, PerfectOutput(t, image.spec), options);
  ASSERT_EQ(peaks.size(), 2u);
  EXPECT_EQ(peaks[0].furniture_class, FurnitureClass::kChair);
  EXPECT_TRUE(peaks[1].suppressed);
  EXPECT_LT(peaks[1].suppressed_by_m, 0.01);
}

TEST(BevBoxCoder, AClassMaximumSeenTwiceIsOneObject) {
  // Two chairs 0.6 m apart; the first's heat has a second, weaker maximum
  // three cells off, whose votes centre it on the same chair.
  BevObject neighbour = kChair;
  neighbour.y += 0.6;
  const BevImage image = ImageWith({kChair, neighbour});
  BevTargets t = EncodeBevTargets({kChair, neighbour}, image, BevCoderOptions::Dense());
  const Eigen::Vector2d cell = image.frame.CellOf(kChair.Centre(), image.spec);
  t.values[At(image.spec,
              ch::kHeat[static_cast<int>(FurnitureClass::kChair)],
              static_cast<int>(cell.x()) + 3,
              static_cast<int>(cell.y()))] = 0.7f;
  BevDecodeOptions options;  // 0.2 m by default
  const std::vector<BevPeak> once = DecodeBevOutput(image, PerfectOutput(t, image.spec), options);
  ASSERT_EQ(once.size(), 2u);
  for (const BevPeak& peak : once) {
    const double to_first = std::hypot(peak.x - kChair.Centre().x(), peak.y - kChair.Centre().y());
    const double to_second =
        std::hypot(peak.x - neighbour.Centre().x(), peak.y - neighbour.Centre().y());
    EXPECT_LT(std::min(to_first, to_second), 0.01);
    EXPECT_EQ(peak.heat, 1.0);
  }
  options.same_class_m = 0;
  const std::vector<BevPeak> twice = DecodeBevOutput(image, PerfectOutput(t, image.spec), options);
  ASSERT_EQ(twice.size(), 3u);
  EXPECT_NEAR(twice[2].heat, 0.7, 1e-6);
  EXPECT_LT(std::hypot(twice[2].x - kChair.Centre().x(), twice[2].y - kChair.Centre().y()), 0.05);
  // Another class at the same place is not the same object.
  t.values[At(image.spec,
              ch::kHeat[static_cast<int>(FurnitureClass::kArmchair)],
              static_cast<int>(cell.x()) + 3,
              static_cast<int>(cell.y()))] = 0.7f;
  options.same_class_m = 0.2;
  EXPECT_EQ(DecodeBevOutput(image, PerfectOutput(t, image.spec), options).size(), 3u);
  options.same_class_m = -0.1;
  EXPECT_THROW(options.Check(), InputError);
}

TEST(BevBoxCoder, OptionChecksNameTheValue) {
  BevDecodeOptions decode;
  decode.vote_bandwidth_m = 0;
  try {
    decode.Check();
    FAIL() << "bandwidth 0 accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("vote bandwidth"), std::string::npos) << error.what();
  }
  BevCoderOptions coder;
  coder.heat_sigma_cells = 0.1;
  EXPECT_THROW(coder.Check(), InputError);
  // A truncated output is refused, not read past its end.
  const BevImage image = ImageWith({});
  BevOutput output{image.spec, std::vector<float>(100, 0.0f)};
  EXPECT_THROW(DecodeBevOutput(image, output, BevDecodeOptions{}), InputError);
}

}  // namespace
}  // namespace furn

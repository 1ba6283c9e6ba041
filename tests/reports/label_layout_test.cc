#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "reports/png_file.h"

namespace furn {
namespace {

// The rows of `image` holding any lit pixel, as a mask.
std::vector<bool> LitRows(const cv::Mat& image) {
  std::vector<bool> lit(image.rows, false);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols && !lit[r]; ++c) lit[r] = image.at<cv::Vec3b>(r, c)[1] > 0;
  return lit;
}

// Labels at one point: each moves a line away from the ones drawn before,
// alternately down and up, until no free line is within reach; the rest are
// left out and counted. A plain DrawLabel would pile them on one line.
TEST(LabelLayout, LabelsAtOnePointTakeLinesOfTheirOwn) {
  cv::Mat image(400, 300, CV_8UC3, cv::Scalar(0, 0, 0));
  LabelLayout labels(&image);
  const int can_place = 2 * LabelLayout::kMaxShift + 1;
  for (int k = 0; k < can_place; ++k)
    EXPECT_TRUE(
        labels.Draw("chair 0.9" + std::to_string(k), cv::Point(100, 200), cv::Scalar(0, 255, 0)))
        << "label " << k;
  EXPECT_FALSE(labels.Draw("table 0.5", cv::Point(100, 200), cv::Scalar(0, 255, 0)));
  EXPECT_EQ(labels.left_out(), 1);
  // Nine labels of one line each, stacked: the lit rows span about nine lines.
  const std::vector<bool> lit = LitRows(image);
  int first = -1, last = -1;
  for (int r = 0; r < image.rows; ++r)
    if (lit[r]) {
      if (first < 0) first = r;
      last = r;
    }
  ASSERT_GE(first, 0);
  EXPECT_GT(last - first, 8 * 12) << "labels stacked, not piled";

  cv::Mat piled(400, 300, CV_8UC3, cv::Scalar(0, 0, 0));
  for (int k = 0; k < 3; ++k)
    DrawLabel(&piled, "chair 0.9", cv::Point(100, 200), cv::Scalar(0, 255, 0));
  const std::vector<bool> one = LitRows(piled);
  EXPECT_LT(std::count(one.begin(), one.end(), true), 20) << "DrawLabel alone piles them";
}

// Labels far apart keep their places; one at the image's edge moves inside.
TEST(LabelLayout, FreeLabelsStayWhereTheyAreAsked) {
  cv::Mat image(200, 200, CV_8UC3, cv::Scalar(0, 0, 0));
  LabelLayout labels(&image);
  EXPECT_TRUE(labels.Draw("a", cv::Point(20, 40), cv::Scalar(0, 255, 0)));
  EXPECT_TRUE(labels.Draw("b", cv::Point(20, 120), cv::Scalar(0, 255, 0)));
  EXPECT_TRUE(labels.Draw("long label at the edge", cv::Point(190, 199), cv::Scalar(0, 255, 0)));
  EXPECT_EQ(labels.left_out(), 0);
  const std::vector<bool> lit = LitRows(image);
  EXPECT_TRUE(lit[36] || lit[35]) << "'a' on its line";
  EXPECT_TRUE(lit[116] || lit[115]) << "'b' on its line";
  EXPECT_TRUE(lit[192] || lit[190]) << "the edge label inside the image";
}

}  // namespace
}  // namespace furn

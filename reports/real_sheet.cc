#include "reports/real_sheet.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "reports/png_file.h"

namespace furn {

namespace {

// The top view's canvas: floor-frame metres to pixels below a title band.
struct TopView {
  Eigen::Vector2d low, high;
  double scale = 0;
  int top = 24;  // room for the title

  cv::Point At(double x, double y) const {
    return cv::Point(static_cast<int>((x - low.x()) * scale),
                     top + static_cast<int>((high.y() - y) * scale));
  }
};

// The extent: the points, the camera and the labels, clipped to 8 m around
// the camera, with a 0.3 m margin; 40 to 200 pixels per metre.
TopView TopViewOf(const std::vector<Eigen::Vector3f>& points,
                  const Eigen::Vector3d& eye,
                  const std::vector<GroundTruthFootprint>& labels) {
  TopView view;
  view.low = view.high = eye.head<2>();
  auto extend = [&](double x, double y) {
    if (std::abs(x - eye.x()) > 8 || std::abs(y - eye.y()) > 8) return;
    view.low = view.low.cwiseMin(Eigen::Vector2d(x, y));
    view.high = view.high.cwiseMax(Eigen::Vector2d(x, y));
  };
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) extend(p.x(), p.y());
  }
  for (const GroundTruthFootprint& label : labels) extend(label.x, label.y);
  view.low -= Eigen::Vector2d(0.3, 0.3);
  view.high += Eigen::Vector2d(0.3, 0.3);
  view.scale = std::clamp(
      900.0 / std::max(view.high.x() - view.low.x(), view.high.y() - view.low.y()), 40.0, 200.0);
  return view;
}

// Grid lines every 0.5 m, whole metres brighter and labelled.
void DrawGrid(const TopView& view, cv::Mat* image) {
  const Eigen::Vector2d low = view.low, high = view.high;
  auto shade = [](double at) {
    const int level = std::abs(at - std::round(at)) < 1e-6 ? 70 : 45;
    return cv::Scalar(level, level, level);
  };
  auto label = [&](double at, const cv::Point& where) {
    if (std::abs(at - std::round(at)) >= 1e-6) return;
    DrawLabel(image,
              std::to_string(static_cast<int>(std::round(at))),
              where,
              cv::Scalar(150, 150, 150),
              0.35);
  };
  for (double x = std::ceil(low.x() * 2) / 2; x <= high.x(); x += 0.5) {
    cv::line(*image, view.At(x, low.y()), view.At(x, high.y()), shade(x), 1);
    label(x, view.At(x, high.y()) + cv::Point(3, 12));
  }
  for (double y = std::ceil(low.y() * 2) / 2; y <= high.y(); y += 0.5) {
    cv::line(*image, view.At(low.x(), y), view.At(high.x(), y), shade(y), 1);
    label(y, view.At(low.x(), y) + cv::Point(3, -3));
  }
}

// Per point, its colour by height: floor dark grey, 0..2 m through TURBO
// (the colour map once, as a table of its 256 levels).
std::vector<cv::Vec3b> HeightColours(const std::vector<Eigen::Vector3f>& points) {
  cv::Mat levels(1, 256, CV_8U), palette;
  for (int k = 0; k < 256; ++k) levels.at<uint8_t>(0, k) = static_cast<uint8_t>(k);
  cv::applyColorMap(levels, palette, cv::COLORMAP_TURBO);
  auto height_colour = [&](float z) {
    if (z < 0.03f) return cv::Vec3b(70, 70, 70);
    return palette.at<cv::Vec3b>(0, static_cast<int>(std::clamp(z / 2.0f, 0.0f, 1.0f) * 255));
  };
  std::vector<cv::Vec3b> colours;
  colours.reserve(points.size());
  for (const Eigen::Vector3f& p : points)
    colours.push_back(height_colour(p.allFinite() ? p.z() : 0));
  return colours;
}

// A label's footprint from above: a box with a line to its front, or a
// circle where it has no yaw; a cross at its centre and its class's name.
void DrawTopLabel(const TopView& view, const GroundTruthFootprint& label, cv::Mat* image) {
  const cv::Scalar colour = ClassColour(label.furniture_class);
  const cv::Point centre = view.At(label.x, label.y);
  if (std::isnan(label.yaw)) {
    cv::circle(*image,
               centre,
               static_cast<int>(0.5 * std::max(label.width, label.depth) * view.scale),
               colour,
               2,
               cv::LINE_AA);
  } else {
    const double c = std::cos(label.yaw), s = std::sin(label.yaw);
    auto corner = [&](double u, double v) {
      return view.At(label.x + c * u - s * v, label.y + s * u + c * v);
    };
    const double w = label.width / 2, d = label.depth / 2;
    const std::vector<cv::Point> box{corner(-w, -d), corner(w, -d), corner(w, d), corner(-w, d)};
    cv::polylines(*image, box, true, colour, 2, cv::LINE_AA);
    cv::line(*image, centre, corner(0, -d), colour, 2, cv::LINE_AA);  // the front
  }
  cv::drawMarker(*image, centre, colour, cv::MARKER_CROSS, 8, 1);
  DrawLabel(image,
            label.furniture_class ? ClassName(*label.furniture_class) : "",
            centre + cv::Point(8, -8),
            colour,
            0.45);
}

// The top view: grid, points by height, the camera white, the labels.
cv::Mat TopViewImage(const std::vector<Eigen::Vector3f>& points,
                     const std::vector<cv::Vec3b>& colours,
                     const Eigen::Vector3d& eye,
                     const std::vector<GroundTruthFootprint>& labels,
                     const std::string& title) {
  const TopView view = TopViewOf(points, eye, labels);
  cv::Mat image(static_cast<int>((view.high.y() - view.low.y()) * view.scale) + 1 + view.top,
                static_cast<int>((view.high.x() - view.low.x()) * view.scale) + 1,
                CV_8UC3,
                cv::Scalar(24, 24, 24));
  DrawGrid(view, &image);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    const cv::Point pixel = view.At(p.x(), p.y());
    if (pixel.x < 0 || pixel.y < view.top || pixel.x >= image.cols || pixel.y >= image.rows)
      continue;
    image.at<cv::Vec3b>(pixel) = colours[i];
  }
  cv::circle(image, view.At(eye.x(), eye.y()), 6, cv::Scalar(255, 255, 255), cv::FILLED);
  for (const GroundTruthFootprint& label : labels) DrawTopLabel(view, label, &image);
  DrawLabel(&image,
            title + ": labels in the floor frame, 0.5 m grid, camera white, height 0-2 m coloured",
            cv::Point(6, 16),
            cv::Scalar(255, 255, 255),
            0.45);
  return image;
}

// A label as a box in the camera's image: its eight corners projected, the
// edges whose both ends lie in front of the camera, the class's name.
void DrawCameraLabel(const CameraIntrinsics& camera,
                     const Eigen::Isometry3d& camera_from_floor,
                     const GroundTruthFootprint& label,
                     cv::Mat* view) {
  const double yaw = std::isnan(label.yaw) ? 0 : label.yaw;
  const double c = std::cos(yaw), s = std::sin(yaw), w = label.width / 2, d = label.depth / 2;
  std::vector<std::optional<cv::Point>> corners;
  for (const double z : {0.0, label.height}) {
    for (const auto& [u, v] : {std::pair{-w, -d}, {w, -d}, {w, d}, {-w, d}}) {
      const Eigen::Vector3d p =
          camera_from_floor * Eigen::Vector3d(label.x + c * u - s * v, label.y + s * u + c * v, z);
      if (p.z() <= 0.05) {
        corners.push_back(std::nullopt);
        continue;
      }
      const Eigen::Vector2d pixel = camera.Project(p);
      corners.push_back(cv::Point(static_cast<int>(pixel.x()), static_cast<int>(pixel.y())));
    }
  }
  const cv::Scalar colour = ClassColour(label.furniture_class);
  auto edge = [&](int a, int b) {
    if (corners[a] && corners[b]) cv::line(*view, *corners[a], *corners[b], colour, 1, cv::LINE_AA);
  };
  for (int k = 0; k < 4; ++k) {
    edge(k, (k + 1) % 4);
    edge(4 + k, 4 + (k + 1) % 4);
    edge(k, 4 + k);
  }
  if (corners[4])
    DrawLabel(view,
              label.furniture_class ? ClassName(*label.furniture_class) : "",
              *corners[4] + cv::Point(0, -4),
              colour,
              0.45);
}

// The camera's view of the points (nearest wins) with the labels as boxes.
cv::Mat CameraViewImage(const std::vector<Eigen::Vector3f>& points,
                        const std::vector<cv::Vec3b>& colours,
                        const Eigen::Isometry3d& world_from_camera,
                        const CameraIntrinsics& camera,
                        const std::vector<GroundTruthFootprint>& labels) {
  cv::Mat view(camera.height, camera.width, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::Mat nearest(camera.height, camera.width, CV_32F, cv::Scalar(1e9f));
  const Eigen::Isometry3d camera_from_floor = world_from_camera.inverse();
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    const Eigen::Vector3d p = camera_from_floor * points[i].cast<double>();
    if (p.z() <= 0.05) continue;
    const Eigen::Vector2d pixel = camera.Project(p);
    const int u = static_cast<int>(pixel.x()), v = static_cast<int>(pixel.y());
    if (u < 0 || v < 0 || u >= view.cols || v >= view.rows || p.z() > nearest.at<float>(v, u))
      continue;
    nearest.at<float>(v, u) = static_cast<float>(p.z());
    view.at<cv::Vec3b>(v, u) = colours[i];
  }
  for (const GroundTruthFootprint& label : labels)
    DrawCameraLabel(camera, camera_from_floor, label, &view);
  return view;
}

}  // namespace

void WriteRealScanSheet(const std::vector<Eigen::Vector3f>& points,
                        const Eigen::Isometry3d& world_from_camera,
                        const CameraIntrinsics& camera,
                        const std::vector<GroundTruthFootprint>& labels,
                        const std::string& title,
                        const std::string& png_path) {
  const std::vector<cv::Vec3b> colours = HeightColours(points);
  const cv::Mat image =
      TopViewImage(points, colours, world_from_camera.translation(), labels, title);
  const cv::Mat view = CameraViewImage(points, colours, world_from_camera, camera, labels);
  const int rows = std::max(image.rows, view.rows);
  cv::Mat sheet(rows, image.cols + view.cols + 8, CV_8UC3, cv::Scalar(24, 24, 24));
  image.copyTo(sheet(cv::Rect(0, 0, image.cols, image.rows)));
  view.copyTo(sheet(cv::Rect(image.cols + 8, 0, view.cols, view.rows)));
  WritePngAtomically(sheet, png_path);
}

}  // namespace furn

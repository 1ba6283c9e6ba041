#include "reports/real_sheet.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "reports/png_file.h"

namespace furn {

void WriteRealScanSheet(const std::vector<Eigen::Vector3f>& points,
                        const Eigen::Isometry3d& world_from_camera,
                        const CameraIntrinsics& camera,
                        const std::vector<GroundTruthFootprint>& labels,
                        const std::string& title,
                        const std::string& png_path) {
  const Eigen::Vector3d eye = world_from_camera.translation();
  // The extent: the points above the floor, the camera and the labels,
  // clipped to 8 m around the camera.
  Eigen::Vector2d low = eye.head<2>(), high = eye.head<2>();
  auto extend = [&](double x, double y) {
    if (std::abs(x - eye.x()) > 8 || std::abs(y - eye.y()) > 8) return;
    low = low.cwiseMin(Eigen::Vector2d(x, y));
    high = high.cwiseMax(Eigen::Vector2d(x, y));
  };
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) extend(p.x(), p.y());
  }
  for (const GroundTruthFootprint& label : labels) extend(label.x, label.y);
  low -= Eigen::Vector2d(0.3, 0.3);
  high += Eigen::Vector2d(0.3, 0.3);
  const double scale =
      std::clamp(900.0 / std::max(high.x() - low.x(), high.y() - low.y()), 40.0, 200.0);
  const int top = 24;  // room for the title
  cv::Mat image(static_cast<int>((high.y() - low.y()) * scale) + 1 + top,
                static_cast<int>((high.x() - low.x()) * scale) + 1,
                CV_8UC3,
                cv::Scalar(24, 24, 24));
  auto at = [&](double x, double y) {
    return cv::Point(static_cast<int>((x - low.x()) * scale),
                     top + static_cast<int>((high.y() - y) * scale));
  };
  // Grid every 0.5 m, metres labelled.
  for (double x = std::ceil(low.x() * 2) / 2; x <= high.x(); x += 0.5) {
    const bool metre = std::abs(x - std::round(x)) < 1e-6;
    cv::line(image,
             at(x, low.y()),
             at(x, high.y()),
             cv::Scalar(metre ? 70 : 45, metre ? 70 : 45, metre ? 70 : 45),
             1);
    if (metre)
      DrawLabel(&image,
                std::to_string(static_cast<int>(std::round(x))),
                at(x, high.y()) + cv::Point(3, 12),
                cv::Scalar(150, 150, 150),
                0.35);
  }
  for (double y = std::ceil(low.y() * 2) / 2; y <= high.y(); y += 0.5) {
    const bool metre = std::abs(y - std::round(y)) < 1e-6;
    cv::line(image,
             at(low.x(), y),
             at(high.x(), y),
             cv::Scalar(metre ? 70 : 45, metre ? 70 : 45, metre ? 70 : 45),
             1);
    if (metre)
      DrawLabel(&image,
                std::to_string(static_cast<int>(std::round(y))),
                at(low.x(), y) + cv::Point(3, -3),
                cv::Scalar(150, 150, 150),
                0.35);
  }
  // Points by height: floor dark grey, 0..2 m through a colour map.
  // The colour map once, as a table of its 256 levels.
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
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    const cv::Point pixel = at(p.x(), p.y());
    if (pixel.x < 0 || pixel.y < top || pixel.x >= image.cols || pixel.y >= image.rows) continue;
    image.at<cv::Vec3b>(pixel) = colours[i];
  }
  cv::circle(image, at(eye.x(), eye.y()), 6, cv::Scalar(255, 255, 255), cv::FILLED);
  for (const GroundTruthFootprint& label : labels) {
    const cv::Scalar colour = ClassColour(label.furniture_class);
    if (std::isnan(label.yaw)) {
      cv::circle(image,
                 at(label.x, label.y),
                 static_cast<int>(0.5 * std::max(label.width, label.depth) * scale),
                 colour,
                 2,
                 cv::LINE_AA);
    } else {
      const double c = std::cos(label.yaw), s = std::sin(label.yaw);
      auto corner = [&](double u, double v) {
        return at(label.x + c * u - s * v, label.y + s * u + c * v);
      };
      const double w = label.width / 2, d = label.depth / 2;
      const std::vector<cv::Point> box{corner(-w, -d), corner(w, -d), corner(w, d), corner(-w, d)};
      cv::polylines(image, box, true, colour, 2, cv::LINE_AA);
      cv::line(image, at(label.x, label.y), corner(0, -d), colour, 2, cv::LINE_AA);  // the front
    }
    cv::drawMarker(image, at(label.x, label.y), colour, cv::MARKER_CROSS, 8, 1);
    DrawLabel(&image,
              label.furniture_class ? ClassName(*label.furniture_class) : "",
              at(label.x, label.y) + cv::Point(8, -8),
              colour,
              0.45);
  }
  DrawLabel(&image,
            title + ": labels in the floor frame, 0.5 m grid, camera white, height 0-2 m coloured",
            cv::Point(6, 16),
            cv::Scalar(255, 255, 255),
            0.45);

  // Beside it, the camera's view of the same points with the labels as boxes.
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
  for (const GroundTruthFootprint& label : labels) {
    const double yaw = std::isnan(label.yaw) ? 0 : label.yaw;
    const double c = std::cos(yaw), s = std::sin(yaw), w = label.width / 2, d = label.depth / 2;
    std::vector<std::optional<cv::Point>> corners;
    for (const double z : {0.0, label.height}) {
      for (const auto& [u, v] : {std::pair{-w, -d}, {w, -d}, {w, d}, {-w, d}}) {
        const Eigen::Vector3d p =
            camera_from_floor *
            Eigen::Vector3d(label.x + c * u - s * v, label.y + s * u + c * v, z);
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
      if (corners[a] && corners[b])
        cv::line(view, *corners[a], *corners[b], colour, 1, cv::LINE_AA);
    };
    for (int k = 0; k < 4; ++k) {
      edge(k, (k + 1) % 4);
      edge(4 + k, 4 + (k + 1) % 4);
      edge(k, 4 + k);
    }
    if (corners[4])
      DrawLabel(&view,
                label.furniture_class ? ClassName(*label.furniture_class) : "",
                *corners[4] + cv::Point(0, -4),
                colour,
                0.45);
  }
  const int rows = std::max(image.rows, view.rows);
  cv::Mat sheet(rows, image.cols + view.cols + 8, CV_8UC3, cv::Scalar(24, 24, 24));
  image.copyTo(sheet(cv::Rect(0, 0, image.cols, image.rows)));
  view.copyTo(sheet(cv::Rect(image.cols + 8, 0, view.cols, view.rows)));
  WritePngAtomically(sheet, png_path);
}

}  // namespace furn

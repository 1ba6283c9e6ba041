#include "reports/frame_preview.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/png_file.h"

namespace furn {
namespace {

constexpr int kTitleHeight = 26;

cv::Vec3b IdColour(uint16_t id) {
  if (id == 0) return cv::Vec3b(0, 0, 0);
  uint32_t h = id * 2654435761u;
  return cv::Vec3b(64 + (h & 0xBF), 64 + ((h >> 8) & 0xBF), 64 + ((h >> 16) & 0xBF));
}

std::pair<float, float> DepthRange(const DepthFrame& frame) {
  std::vector<float> valid;
  for (float z : frame.depth) {
    if (z > 0) valid.push_back(z);
  }
  if (valid.empty()) return {0.5f, 4.5f};
  std::sort(valid.begin(), valid.end());
  const float low = valid[valid.size() / 100], high = valid[valid.size() * 99 / 100];
  return {low, std::max(high, low + 0.1f)};
}

cv::Mat ColouriseDepth(const DepthFrame& frame, std::pair<float, float> range) {
  cv::Mat grey(frame.height, frame.width, CV_8UC1);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const float z = frame.DepthAt(u, v);
      const float t = std::clamp((z - range.first) / (range.second - range.first), 0.0f, 1.0f);
      grey.at<uchar>(v, u) = static_cast<uchar>(255 * (1 - t));
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      if (frame.DepthAt(u, v) <= 0) colour.at<cv::Vec3b>(v, u) = cv::Vec3b(0, 0, 0);
    }
  }
  return colour;
}

// Mean of the valid depths in a (2r+1)^2 window (0 where the centre is
// invalid).
std::vector<float> SmoothValidDepth(const DepthFrame& frame, int radius) {
  std::vector<float> smoothed(frame.depth.size(), 0.0f);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      if (frame.DepthAt(u, v) <= 0) continue;
      double sum = 0;
      int count = 0;
      for (int dv = -radius; dv <= radius; ++dv) {
        for (int du = -radius; du <= radius; ++du) {
          const int x = u + du, y = v + dv;
          if (x < 0 || y < 0 || x >= frame.width || y >= frame.height) continue;
          const float z = frame.DepthAt(x, y);
          if (z > 0 && std::abs(z - frame.DepthAt(u, v)) < 0.1f) {
            sum += z;
            ++count;
          }
        }
      }
      smoothed[frame.Index(u, v)] = static_cast<float>(sum / count);
    }
  }
  return smoothed;
}

// Lambert shading of the surface implied by the depth image, lightly smoothed
// (normals from central differences): sensor noise shows as texture, disparity
// quantisation as terraces, dropout as black.
cv::Mat ShadeDepth(const DepthFrame& frame) {
  const std::vector<float> smoothed = SmoothValidDepth(frame, 2);
  cv::Mat shaded(frame.height, frame.width, CV_8UC3, cv::Scalar(0, 0, 0));
  const Eigen::Vector3f light = Eigen::Vector3f(-0.3f, -0.5f, -1.0f).normalized();
  auto depth = [&](int u, int v) { return smoothed[frame.Index(u, v)]; };
  for (int v = 1; v + 1 < frame.height; ++v) {
    for (int u = 1; u + 1 < frame.width; ++u) {
      const float z = depth(u, v), zr = depth(u + 1, v), zl = depth(u - 1, v), zd = depth(u, v + 1),
                  zu = depth(u, v - 1);
      if (z <= 0) continue;
      const bool interior = zr > 0 && zl > 0 && zd > 0 && zu > 0;
      Eigen::Vector3f n(0, 0, -1);
      if (interior) {
        // Metres of depth per metre across: one pixel spans z / f metres (f ~
        // 580 px).
        const float scale = 580.0f / (2 * z);
        n = Eigen::Vector3f((zr - zl) * scale, (zd - zu) * scale, -1.0f).normalized();
      }
      const float intensity =
          (interior ? 1.0f : 0.6f) * (0.15f + 0.85f * std::max(0.0f, n.dot(light)));
      const uchar c = static_cast<uchar>(255 * std::clamp(intensity, 0.0f, 1.0f));
      shaded.at<cv::Vec3b>(v, u) = cv::Vec3b(c, c, c);
    }
  }
  return shaded;
}

cv::Mat ColouriseIds(const DepthFrame& frame) {
  cv::Mat colour(frame.height, frame.width, CV_8UC3);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) colour.at<cv::Vec3b>(v, u) = IdColour(frame.IdAt(u, v));
  }
  return colour;
}

}  // namespace

void WritePreviewPng(const std::vector<PreviewPanel>& panels,
                     int columns,
                     const std::string& path) {
  Require(!panels.empty() && columns >= 1, path + ": a preview needs at least one panel");
  const DepthFrame& first = *panels.front().frame;
  std::pair<float, float> range{0.5f, 4.5f};
  for (const PreviewPanel& panel : panels) {
    if (panel.kind == PreviewPanel::Kind::kDepth) {
      range = DepthRange(*panel.frame);
      break;
    }
  }
  const int rows = static_cast<int>((panels.size() + columns - 1) / columns);
  const int cell_height = first.height + kTitleHeight;
  cv::Mat sheet(rows * cell_height, columns * first.width, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t i = 0; i < panels.size(); ++i) {
    const PreviewPanel& panel = panels[i];
    Require(panel.frame->width == first.width && panel.frame->height == first.height,
            path + ": preview panels must have the same size");
    cv::Mat image = panel.kind == PreviewPanel::Kind::kDepth ? ColouriseDepth(*panel.frame, range)
                    : panel.kind == PreviewPanel::Kind::kIds ? ColouriseIds(*panel.frame)
                                                             : ShadeDepth(*panel.frame);
    const int x = static_cast<int>(i % columns) * first.width;
    const int y = static_cast<int>(i / columns) * cell_height;
    image.copyTo(sheet(cv::Rect(x, y + kTitleHeight, first.width, first.height)));
    std::string title = panel.title;
    if (panel.kind == PreviewPanel::Kind::kDepth) {
      char text[64];
      std::snprintf(text, sizeof(text), "  [%.2f m red .. %.2f m blue]", range.first, range.second);
      title += text;
    }
    cv::putText(sheet,
                title,
                cv::Point(x + 6, y + 18),
                cv::FONT_HERSHEY_SIMPLEX,
                0.55,
                cv::Scalar(20, 20, 20),
                1,
                cv::LINE_AA);
  }
  Require(FileExtension(path) == "png", path + ": images are written as .png");
  WritePngAtomically(sheet, path);
}

}  // namespace furn

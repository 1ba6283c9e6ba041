#include "renderers/frame_io.h"

#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/file_util.h"

namespace furn {
namespace {

constexpr int kTitleHeight = 26;

void WritePng(const cv::Mat& image, const std::string& path) {
  Require(FileExtension(path) == "png", path + ": images are written as .png");
  std::vector<uchar> bytes;
  Require(cv::imencode(".png", image, bytes), path + ": PNG encoding failed");
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

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

cv::Mat DepthImage(const DepthFrame& frame, double units_per_metre) {
  Require(units_per_metre > 0, "depth scale " + std::to_string(units_per_metre) + " must be > 0");
  cv::Mat image(frame.height, frame.width, CV_16UC1);
  // Depths are >= 0: adding 0.5 and truncating rounds (libm's round is slow).
  const float scale = static_cast<float>(units_per_metre);
  for (int v = 0; v < frame.height; ++v) {
    uint16_t* row = image.ptr<uint16_t>(v);
    const float* depth = frame.depth.data() + static_cast<size_t>(v) * frame.width;
    for (int u = 0; u < frame.width; ++u) {
      const float units = depth[u] * scale + 0.5f;
      row[u] = units >= 1.0f && units < 65535.5f ? static_cast<uint16_t>(units) : 0;
    }
  }
  return image;
}

cv::Mat IdImage(const DepthFrame& frame) {
  cv::Mat image(frame.height, frame.width, CV_16UC1);
  std::memcpy(image.data, frame.instance_ids.data(), frame.instance_ids.size() * sizeof(uint16_t));
  return image;
}

void AppendPngBytes(png_structp png, png_bytep data, png_size_t size) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + size);
}

void FlushNothing(png_structp) {}

// 16-bit grey PNG through libpng with no row filter and zlib level 1: twice
// as fast as OpenCV's encoder (which tries every filter) and smaller on
// Kinect depth. Any PNG decoder reads it.
std::vector<uint8_t> FastPng(const cv::Mat& image) {
  std::vector<uint8_t> out;
  out.reserve(image.total() / 2);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  Require(png != nullptr && info != nullptr, "PNG encoder: out of memory");
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw InputError("PNG encoding failed");
  }
  png_set_write_fn(png, &out, AppendPngBytes, FlushNothing);
  png_set_IHDR(png,
               info,
               image.cols,
               image.rows,
               16,
               PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_filter(png, 0, PNG_FILTER_NONE);
  png_set_compression_level(png, 1);
  png_write_info(png, info);
  png_set_swap(png);  // PNG stores 16-bit samples big-endian
  for (int row = 0; row < image.rows; ++row) {
    png_write_row(png, const_cast<png_bytep>(reinterpret_cast<const png_byte*>(image.ptr(row))));
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return out;
}

cv::Mat Decode16(const std::vector<uint8_t>& png, const std::string& what) {
  const cv::Mat image = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  Require(!image.empty(), what + ": not a readable PNG");
  Require(image.type() == CV_16UC1, what + ": expected a single-channel 16-bit PNG");
  return image;
}

}  // namespace

std::vector<uint8_t> EncodeDepthPng(const DepthFrame& frame, double units_per_metre) {
  return FastPng(DepthImage(frame, units_per_metre));
}

std::vector<uint8_t> EncodeIdPng(const DepthFrame& frame) { return FastPng(IdImage(frame)); }

DepthFrame DecodeDepthPng(const std::vector<uint8_t>& png,
                          const std::string& what,
                          double units_per_metre) {
  const cv::Mat image = Decode16(png, what);
  DepthFrame frame;
  frame.Resize(image.cols, image.rows);
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      frame.depth[frame.Index(u, v)] =
          static_cast<float>(image.at<uint16_t>(v, u) / units_per_metre);
    }
  }
  return frame;
}

void DecodeIdPng(const std::vector<uint8_t>& png, const std::string& what, DepthFrame* frame) {
  const cv::Mat image = Decode16(png, what);
  Require(image.cols == frame->width && image.rows == frame->height,
          what + ": id image size differs from depth");
  std::memcpy(
      frame->instance_ids.data(), image.data, frame->instance_ids.size() * sizeof(uint16_t));
}

void WriteDepthPng(const DepthFrame& frame, const std::string& path, double units_per_metre) {
  WritePng(DepthImage(frame, units_per_metre), path);
}

DepthFrame ReadDepthPng(const std::string& path, double units_per_metre) {
  Require(units_per_metre > 0, "depth scale " + std::to_string(units_per_metre) + " must be > 0");
  const std::string bytes = ReadFileBytes(path);
  return DecodeDepthPng(std::vector<uint8_t>(bytes.begin(), bytes.end()), path, units_per_metre);
}

void WriteIdPng(const DepthFrame& frame, const std::string& path) {
  WritePng(IdImage(frame), path);
}

void WriteOrganizedPcd(const DepthFrame& frame,
                       const CameraIntrinsics& camera,
                       const std::string& path) {
  Require(FileExtension(path) == "pcd", path + ": point clouds are written as .pcd");
  Require(frame.width == camera.width && frame.height == camera.height,
          path + ": frame size does not match the camera");
  pcl::PointCloud<pcl::PointXYZ> cloud(frame.width, frame.height);
  cloud.is_dense = false;
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const float z = frame.DepthAt(u, v);
      pcl::PointXYZ& point = cloud.at(u, v);
      if (z <= 0) {
        point.x = point.y = point.z = std::numeric_limits<float>::quiet_NaN();
        continue;
      }
      const Eigen::Vector3f p = z * camera.RayThroughPixel(u, v);
      point.x = p.x();
      point.y = p.y();
      point.z = p.z();
    }
  }
  AtomicFile file(path);
  Require(pcl::io::savePCDFileBinary(file.TempPath(), cloud) == 0, path + ": cannot write PCD");
  file.Commit();
}

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
  WritePng(sheet, path);
}

}  // namespace furn

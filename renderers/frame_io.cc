#include "renderers/frame_io.h"

#include <libdeflate.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <fcntl.h>
#include <png.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

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

void AppendBigEndian32(uint32_t value, std::vector<uint8_t>* out) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(value >> shift));
}

// Appends one PNG chunk: length, type, data, CRC of type and data.
void AppendChunk(const char type[4], const uint8_t* data, size_t size, std::vector<uint8_t>* out) {
  AppendBigEndian32(static_cast<uint32_t>(size), out);
  const size_t type_at = out->size();
  out->insert(out->end(), type, type + 4);
  out->insert(out->end(), data, data + size);
  AppendBigEndian32(libdeflate_crc32(0, out->data() + type_at, size + 4), out);
}

// 16-bit grey PNG, rows unfiltered, compressed by libdeflate at level 1: about
// three times faster than libpng with zlib at level 1, and smaller on Kinect
// depth. The container is written here (signature, IHDR, one IDAT, IEND); any
// PNG decoder reads it.
std::vector<uint8_t> FastPng(const cv::Mat& image) {
  const size_t row_bytes = 1 + 2 * static_cast<size_t>(image.cols);
  std::vector<uint8_t> raw(row_bytes * image.rows);
  for (int row = 0; row < image.rows; ++row) {
    uint8_t* out = &raw[row * row_bytes];
    *out++ = 0;  // filter type None
    const uint16_t* in = image.ptr<uint16_t>(row);
    for (int col = 0; col < image.cols; ++col) {  // PNG samples are big-endian
      *out++ = static_cast<uint8_t>(in[col] >> 8);
      *out++ = static_cast<uint8_t>(in[col]);
    }
  }
  thread_local std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(
      libdeflate_alloc_compressor(1), libdeflate_free_compressor);
  Require(compressor != nullptr, "PNG encoder: out of memory");
  std::vector<uint8_t> idat(libdeflate_zlib_compress_bound(compressor.get(), raw.size()));
  idat.resize(
      libdeflate_zlib_compress(compressor.get(), raw.data(), raw.size(), idat.data(), idat.size()));
  Require(!idat.empty(), "PNG encoding failed");

  static constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<uint8_t> header;
  AppendBigEndian32(static_cast<uint32_t>(image.cols), &header);
  AppendBigEndian32(static_cast<uint32_t>(image.rows), &header);
  header.insert(header.end(), {16, 0, 0, 0, 0});  // 16-bit grey, deflate, adaptive, no interlace
  std::vector<uint8_t> png(std::begin(kSignature), std::end(kSignature));
  png.reserve(idat.size() + 64);
  AppendChunk("IHDR", header.data(), header.size(), &png);
  AppendChunk("IDAT", idat.data(), idat.size(), &png);
  AppendChunk("IEND", nullptr, 0, &png);
  return png;
}

// libpng with our own error and warning handlers: a damaged file is one
// line of ours (libpng's reason after a colon), nothing printed by libpng.
struct PngReader {
  const std::vector<uint8_t>* bytes;
  size_t at = 0;
  std::string error;
};

void PngError(png_structp png, png_const_charp message) {
  static_cast<PngReader*>(png_get_error_ptr(png))->error = message;
  png_longjmp(png, 1);
}

void PngWarning(png_structp, png_const_charp) {}

void PngRead(png_structp png, png_bytep out, png_size_t count) {
  PngReader* reader = static_cast<PngReader*>(png_get_io_ptr(png));
  if (reader->bytes->size() - reader->at < count) png_error(png, "the file ends early");
  std::memcpy(out, reader->bytes->data() + reader->at, count);
  reader->at += count;
}

cv::Mat Decode16(const std::vector<uint8_t>& bytes, const std::string& what) {
  Require(bytes.size() >= 8 && png_sig_cmp(bytes.data(), 0, 8) == 0,
          what + ": not a readable PNG (no PNG signature)");
  PngReader reader{&bytes, 0, {}};
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &reader, PngError, PngWarning);
  Require(png != nullptr, what + ": cannot start the PNG reader");
  png_infop info = png_create_info_struct(png);
  // What the read fills lives behind a pointer set before setjmp: locals
  // changed between setjmp and a longjmp back have indeterminate values.
  struct Output {
    cv::Mat image;
    std::vector<png_bytep> rows;
    bool grey16 = false;
  };
  const std::unique_ptr<Output> out = std::make_unique<Output>();
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw InputError(what + ": not a readable PNG: " + reader.error);
  }
  if (info == nullptr) png_error(png, "cannot start the PNG reader");
  png_set_read_fn(png, &reader, PngRead);
  png_set_user_limits(png, 16384, 16384);
  png_read_info(png, info);
  out->grey16 = png_get_color_type(png, info) == PNG_COLOR_TYPE_GRAY &&
                png_get_bit_depth(png, info) == 16 &&
                png_get_interlace_type(png, info) == PNG_INTERLACE_NONE;
  if (out->grey16) {
    png_set_swap(png);  // PNG is big-endian
    out->image.create(static_cast<int>(png_get_image_height(png, info)),
                      static_cast<int>(png_get_image_width(png, info)),
                      CV_16UC1);
    out->rows.resize(out->image.rows);
    for (int v = 0; v < out->image.rows; ++v) out->rows[v] = out->image.ptr<png_byte>(v);
    png_read_image(png, out->rows.data());
  }
  png_destroy_read_struct(&png, &info, nullptr);
  const bool grey16 = out->grey16;
  cv::Mat image = out->image;
  Require(grey16, what + ": expected a single-channel 16-bit PNG (not interlaced)");
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

namespace {

// Sends the process's stderr to /dev/null while it lives: OpenCV's TIFF and
// EXR readers (and libtiff under them) print their own complaints about a
// damaged file, which would precede our one line.
class QuietStderr {
 public:
  QuietStderr() {
    std::fflush(stderr);
    saved_ = dup(STDERR_FILENO);
    const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (saved_ >= 0 && null >= 0) dup2(null, STDERR_FILENO);
    if (null >= 0) close(null);
  }
  ~QuietStderr() {
    std::fflush(stderr);
    std::cerr.flush();
    if (saved_ >= 0) {
      dup2(saved_, STDERR_FILENO);
      close(saved_);
    }
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_ = -1;
};

}  // namespace

DepthFrame ReadDepthImage(const std::string& path, std::optional<double> units_per_metre) {
  const std::string extension = FileExtension(path);
  if (extension == "png") return ReadDepthPng(path, units_per_metre.value_or(1000));
  Require(extension == "tif" || extension == "tiff" || extension == "exr",
          path +
              ": depth images are read from .png (16-bit), .tif/.tiff (16-bit or float) "
              "or .exr (float) files");
  if (units_per_metre) {
    Require(*units_per_metre > 0 && std::isfinite(*units_per_metre),
            "depth scale " + std::to_string(*units_per_metre) + " must be a finite number > 0");
  }
  const std::string bytes = ReadFileBytes(path);  // a clear error for a missing file
  // OpenCV reads OpenEXR only when this is set before its first use.
  setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);
  cv::Mat image;
  try {
    const QuietStderr quiet;
    image = cv::imdecode(
        cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data())),
        cv::IMREAD_ANYDEPTH | cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    image = cv::Mat();
  }
  Require(!image.empty(), path + ": not a readable " + extension + " image");
  Require(
      image.channels() == 1,
      path + ": a depth image has one channel, this one has " + std::to_string(image.channels()));
  const bool is_float = image.depth() == CV_32F || image.depth() == CV_64F;
  Require(is_float || image.depth() == CV_16U,
          path + ": depth images are 16-bit unsigned or 32-bit float");
  const double scale = units_per_metre.value_or(is_float ? 1.0 : 1000.0);
  cv::Mat metres;
  image.convertTo(metres, CV_32F, 1.0 / scale);
  DepthFrame frame;
  frame.Resize(metres.cols, metres.rows);
  for (int v = 0; v < metres.rows; ++v) {
    const float* row = metres.ptr<float>(v);
    for (int u = 0; u < metres.cols; ++u) {
      frame.depth[static_cast<size_t>(v) * metres.cols + u] =
          std::isfinite(row[u]) && row[u] > 0 ? row[u] : 0.0f;
    }
  }
  return frame;
}

void WriteIdPng(const DepthFrame& frame, const std::string& path) {
  WritePng(IdImage(frame), path);
}

void WriteMaskPng(const std::vector<uint8_t>& mask,
                  int width,
                  int height,
                  const std::string& path) {
  Require(width > 0 && height > 0 && mask.size() == static_cast<size_t>(width) * height,
          path + ": a mask of " + std::to_string(mask.size()) + " pixels is not " +
              std::to_string(width) + "x" + std::to_string(height));
  cv::Mat image(height, width, CV_8UC1);
  std::memcpy(image.data, mask.data(), mask.size());
  WritePng(image, path);
}

std::vector<Eigen::Vector3f> BackProject(const DepthFrame& frame, const CameraIntrinsics& camera) {
  Require(frame.width == camera.width && frame.height == camera.height,
          "depth image is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
              " but the intrinsics are for " + std::to_string(camera.width) + "x" +
              std::to_string(camera.height));
  std::vector<Eigen::Vector3f> points;
  points.reserve(static_cast<size_t>(frame.width) * frame.height);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const float z = frame.DepthAt(u, v);
      points.push_back(z > 0 ? Eigen::Vector3f(z * camera.RayThroughPixel(u, v))
                             : Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
    }
  }
  return points;
}

namespace {

// The whitespace-separated words of a header line.
std::vector<std::string> Words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// A whole non-negative number of at most `limit`, or nullopt.
std::optional<uint64_t> Count(const std::string& word, uint64_t limit) {
  if (word.empty() || word.size() > 19 ||  // 19 digits always fit 64 bits
      !std::all_of(word.begin(), word.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  const unsigned long long value = std::stoull(word);
  if (value > limit) return std::nullopt;
  return value;
}

}  // namespace

void CheckPcdHeader(const std::string& bytes, const std::string& path) {
  std::map<std::string, std::vector<std::string>> header;
  size_t at = 0;
  std::string data_kind;
  while (at < bytes.size() && data_kind.empty()) {
    const size_t end = bytes.find('\n', at);
    Require(end != std::string::npos && end - at < 65536,
            path + ": not a PCD file (its header ends without a DATA line)");
    const std::vector<std::string> words = Words(bytes.substr(at, end - at));
    at = end + 1;
    if (words.empty() || words[0][0] == '#') continue;
    static const std::set<std::string> kKeywords{
        "VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS"};
    if (words[0] == "DATA") {
      Require(words.size() == 2, path + ": PCD DATA must be ascii, binary or binary_compressed");
      data_kind = words[1];
    } else {
      // PCL's reader misplaces the body after a line it does not know.
      Require(kKeywords.count(words[0]) > 0,
              path + ": not a PCD file (header line '" + words[0].substr(0, 40) +
                  "' is neither a comment nor a PCD keyword)");
      // PCL acts on every line as it comes (a POINTS line resizes the body):
      // a repeated keyword would be checked here only in its last form.
      Require(header.count(words[0]) == 0,
              path + ": PCD header line " + words[0] + " appears twice");
      header[words[0]] = std::vector<std::string>(words.begin() + 1, words.end());
    }
  }
  Require(!data_kind.empty(), path + ": not a PCD file (its header ends without a DATA line)");
  for (const char* key : {"FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT", "POINTS"}) {
    Require(header.count(key), path + ": not a PCD file (its header lacks " + key + ")");
  }
  Require(data_kind == "ascii" || data_kind == "binary" || data_kind == "binary_compressed",
          path + ": PCD DATA '" + data_kind + "' must be ascii, binary or binary_compressed");
  const size_t fields = header["FIELDS"].size();
  Require(fields >= 1 && fields <= 1024, path + ": PCD FIELDS must name 1 to 1024 fields");
  std::vector<std::string> counts =
      header.count("COUNT") ? header["COUNT"] : std::vector<std::string>(fields, "1");
  Require(
      header["SIZE"].size() == fields && header["TYPE"].size() == fields && counts.size() == fields,
      path + ": PCD SIZE, TYPE and COUNT must have one entry per field (" + std::to_string(fields) +
          ")");
  uint64_t point_step = 0;
  for (size_t f = 0; f < fields; ++f) {
    const std::optional<uint64_t> size = Count(header["SIZE"][f], 8);
    const std::string& type = header["TYPE"][f];
    Require(size && (*size == 1 || *size == 2 || *size == 4 || *size == 8),
            path + ": PCD SIZE of field " + header["FIELDS"][f] + " must be 1, 2, 4 or 8");
    Require(type == "I" || type == "U" || (type == "F" && *size >= 4),
            path + ": PCD TYPE of field " + header["FIELDS"][f] +
                " must be I, U or F (F of size 4 or 8)");
    const std::optional<uint64_t> count = Count(counts[f], 4096);
    Require(count && *count >= 1,
            path + ": PCD COUNT of field " + header["FIELDS"][f] + " '" + counts[f] +
                "' must be in 1..4096");
    point_step += *size * *count;
  }
  const std::optional<uint64_t> width =
      Count(header["WIDTH"].empty() ? "" : header["WIDTH"][0], 1u << 30);
  const std::optional<uint64_t> height =
      Count(header["HEIGHT"].empty() ? "" : header["HEIGHT"][0], 1u << 30);
  const std::optional<uint64_t> points =
      Count(header["POINTS"].empty() ? "" : header["POINTS"][0], 1u << 30);
  Require(width && height && points,
          path + ": PCD WIDTH, HEIGHT and POINTS must be whole numbers up to 2^30");
  Require(*width * *height == *points,
          path + ": PCD WIDTH x HEIGHT (" + std::to_string(*width) + " x " +
              std::to_string(*height) + ") must equal POINTS (" + std::to_string(*points) + ")");
  // The body must hold what the header declares: nothing is allocated for
  // points the file does not have.
  const uint64_t body = bytes.size() - at;
  const uint64_t needed = *points * point_step;
  if (data_kind == "binary") {
    Require(needed <= body,
            path + ": PCD declares " + std::to_string(*points) + " points of " +
                std::to_string(point_step) + " bytes, but its body has " + std::to_string(body) +
                " bytes");
  } else if (data_kind == "binary_compressed") {
    Require(body >= 8, path + ": PCD binary_compressed body lacks its two sizes");
    uint32_t compressed = 0, uncompressed = 0;
    std::memcpy(&compressed, bytes.data() + at, 4);
    std::memcpy(&uncompressed, bytes.data() + at + 4, 4);
    Require(compressed <= body - 8,
            path + ": PCD compressed size " + std::to_string(compressed) +
                " exceeds the file's body (" + std::to_string(body - 8) + " bytes)");
    Require(uncompressed == needed && (needed == 0 || compressed > 0),
            path + ": PCD uncompressed size " + std::to_string(uncompressed) +
                " must be POINTS x point size (" + std::to_string(needed) + ")");
    // LZF expands a byte of input into at most a few hundred bytes.
    Require(uncompressed <= 300ull * compressed + 1024,
            path + ": PCD compression ratio " + std::to_string(uncompressed) + " : " +
                std::to_string(compressed) + " is beyond LZF's");
  } else {
    const uint64_t lines = static_cast<uint64_t>(
        std::count(bytes.begin() + static_cast<std::ptrdiff_t>(at), bytes.end(), '\n') + 1);
    Require(*points <= lines,
            path + ": PCD declares " + std::to_string(*points) +
                " points, but its ascii body has " + std::to_string(lines) + " lines");
  }
}

void CheckPlyHeader(const std::string& bytes, const std::string& path) {
  Require(bytes.rfind("ply", 0) == 0, path + ": not a PLY file (no 'ply' magic line)");
  const size_t end_header = bytes.find("end_header");
  Require(end_header != std::string::npos && end_header < (1u << 20),
          path + ": not a PLY file (no end_header)");
  std::istringstream in(bytes.substr(0, end_header));
  std::string line, format, element;
  struct Element {
    std::string name;
    uint64_t count = 0;
    uint64_t min_bytes = 0;  // of one record in a binary body
  };
  std::vector<Element> elements;
  auto scalar_size = [](const std::string& type) -> int {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
    if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" ||
        type == "float32")
      return 4;
    if (type == "double" || type == "float64") return 8;
    return 0;
  };
  bool has_xyz[3] = {false, false, false};
  while (std::getline(in, line)) {
    const std::vector<std::string> words = Words(line);
    if (words.empty()) continue;
    static const std::set<std::string> kKeywords{
        "ply", "format", "comment", "obj_info", "element", "property", "end_header"};
    Require(kKeywords.count(words[0]) > 0,
            path + ": not a PLY file (header line '" + words[0].substr(0, 40) +
                "' is not a PLY keyword)");
    if (words[0] == "format" && words.size() >= 2) format = words[1];
    if (words[0] == "element") {
      const std::optional<uint64_t> count =
          words.size() == 3 ? Count(words[2], 1u << 30) : std::nullopt;
      Require(count.has_value(),
              path + ": PLY '" + line + "' must be 'element <name> <count up to 2^30>'");
      elements.push_back({words[1], *count, 0});
    }
    if (words[0] == "property") {
      Require(!elements.empty(), path + ": PLY property before any element");
      Element& e = elements.back();
      if (words.size() >= 2 && words[1] == "list") {
        Require(words.size() == 5 && scalar_size(words[2]) > 0 && scalar_size(words[3]) > 0,
                path + ": PLY '" + line + "' must be 'property list <type> <type> <name>'");
        // PCL's reader asserts on any list property of the vertex element.
        Require(e.name != "vertex",
                path + ": PLY vertex property " + words[4] + " must be a scalar, not a list");
        e.min_bytes += static_cast<uint64_t>(scalar_size(words[2]));
      } else {
        Require(words.size() == 3 && scalar_size(words[1]) > 0,
                path + ": PLY '" + line + "' must be 'property <type> <name>'");
        e.min_bytes += static_cast<uint64_t>(scalar_size(words[1]));
        for (int k = 0; k < 3; ++k) {
          if (e.name == "vertex" && words[2] == std::string(1, "xyz"[k])) has_xyz[k] = true;
        }
      }
    }
  }
  Require(format == "ascii" || format == "binary_little_endian" || format == "binary_big_endian",
          path + ": PLY format '" + format + "' must be ascii or binary_little/big_endian");
  Require(has_xyz[0] && has_xyz[1] && has_xyz[2],
          path + ": the cloud has no x, y, z fields (PLY vertex properties)");
  const uint64_t body = bytes.size() - std::min(bytes.size(), end_header + 11);
  uint64_t needed = 0;
  for (const Element& e : elements) {
    needed +=
        format == "ascii" ? e.count * 2 : e.count * e.min_bytes;  // ascii: a digit and a space
  }
  Require(needed <= body,
          path + ": PLY elements declare at least " + std::to_string(needed) +
              " bytes, but its body has " + std::to_string(body));
}

ScanCloud ReadPointCloudFile(const std::string& path) {
  const std::string extension = FileExtension(path);
  Require(extension == "pcd" || extension == "ply",
          path + ": point clouds are read from .pcd or .ply files");
  const std::string bytes = ReadFileBytes(path);  // a clear error for a missing file
  // PCL 1.13's PCD reader crashes on some malformed headers, so the header
  // is checked here first: PLY's magic line, or every PCD header field.
  if (extension == "ply") {
    CheckPlyHeader(bytes, path);
  } else {
    CheckPcdHeader(bytes, path);
  }
  pcl::PCLPointCloud2 blob;
  // PCL prints its own reasons; ours below is the one line the user sees.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
  const int status = extension == "pcd" ? pcl::io::loadPCDFile(path, blob, origin, orientation)
                                        : pcl::io::loadPLYFile(path, blob);
  Require(status >= 0, path + ": not a readable " + extension + " point cloud");
  // x, y, z of any numeric type (float, double, integers), read as PCL laid
  // them out: fields at their offsets within each point_step-long point.
  const pcl::PCLPointField* fields[3] = {nullptr, nullptr, nullptr};
  for (const pcl::PCLPointField& f : blob.fields) {
    for (int k = 0; k < 3; ++k) {
      if (f.name == std::string(1, "xyz"[k])) fields[k] = &f;
    }
  }
  Require(fields[0] != nullptr && fields[1] != nullptr && fields[2] != nullptr,
          path + ": the cloud has no x, y, z fields");
  const size_t points = static_cast<size_t>(blob.width) * blob.height;
  Require(blob.data.size() >= points * blob.point_step,
          path + ": the cloud's data is shorter than its header declares");
  auto value_at = [&](const uint8_t* point, const pcl::PCLPointField& f) -> double {
    const uint8_t* at = point + f.offset;
    switch (f.datatype) {
      case pcl::PCLPointField::INT8:
        return static_cast<double>(*reinterpret_cast<const int8_t*>(at));
      case pcl::PCLPointField::UINT8:
        return static_cast<double>(*at);
      case pcl::PCLPointField::INT16: {
        int16_t v;
        std::memcpy(&v, at, sizeof(v));
        return v;
      }
      case pcl::PCLPointField::UINT16: {
        uint16_t v;
        std::memcpy(&v, at, sizeof(v));
        return v;
      }
      case pcl::PCLPointField::INT32: {
        int32_t v;
        std::memcpy(&v, at, sizeof(v));
        return v;
      }
      case pcl::PCLPointField::UINT32: {
        uint32_t v;
        std::memcpy(&v, at, sizeof(v));
        return v;
      }
      case pcl::PCLPointField::FLOAT32: {
        float v;
        std::memcpy(&v, at, sizeof(v));
        return v;
      }
      case pcl::PCLPointField::FLOAT64: {
        double v;
        std::memcpy(&v, at, sizeof(v));
        return v;
      }
      default:
        return std::numeric_limits<double>::quiet_NaN();
    }
  };
  for (const pcl::PCLPointField* f : fields) {
    Require(f->datatype >= pcl::PCLPointField::INT8 && f->datatype <= pcl::PCLPointField::FLOAT64 &&
                f->offset < blob.point_step,
            path + ": field " + f->name + " has a type or offset this reader does not know");
  }
  ScanCloud scan;
  scan.points.reserve(points);
  for (size_t i = 0; i < points; ++i) {
    const uint8_t* point = blob.data.data() + i * blob.point_step;
    scan.points.emplace_back(static_cast<float>(value_at(point, *fields[0])),
                             static_cast<float>(value_at(point, *fields[1])),
                             static_cast<float>(value_at(point, *fields[2])));
  }
  if (blob.height > 1) {
    scan.width = static_cast<int>(blob.width);
    scan.height = static_cast<int>(blob.height);
  }
  // PCL fills the default viewpoint (origin, identity) when the header has
  // none; any other is the sensor's pose in the cloud's frame.
  if (!origin.head<3>().isZero() ||
      !orientation.coeffs().isApprox(Eigen::Quaternionf::Identity().coeffs())) {
    Require(origin.head<3>().allFinite() && orientation.coeffs().allFinite() &&
                std::abs(orientation.norm() - 1) < 1e-3,
            path + ": VIEWPOINT must be x y z qw qx qy qz with a unit quaternion");
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = orientation.cast<double>().normalized().toRotationMatrix();
    pose.translation() = origin.head<3>().cast<double>();
    scan.viewpoint = pose;
  }
  return scan;
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

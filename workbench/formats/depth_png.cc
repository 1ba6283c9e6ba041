#include "workbench/formats/depth_png.h"

#include <fcntl.h>
#include <libdeflate.h>
#include <png.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

void WritePng(const cv::Mat& image, const std::string& path) {
  Require(FileExtension(path) == "png", path + ": images are written as .png");
  std::vector<uchar> bytes;
  Require(cv::imencode(".png", image, bytes), path + ": PNG encoding failed");
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

// A depth in units (>= 0: adding 0.5 and truncating rounds; libm's round is
// slow); 0 where there is none or it does not fit 16 bits.
uint16_t DepthUnits(float depth, float scale) {
  const float units = depth * scale + 0.5f;
  return units >= 1.0f && units < 65535.5f ? static_cast<uint16_t>(units) : 0;
}

float DepthScale(double units_per_metre) {
  Require(units_per_metre > 0, "depth scale " + std::to_string(units_per_metre) + " must be > 0");
  return static_cast<float>(units_per_metre);
}

cv::Mat DepthImage(const DepthFrame& frame, double units_per_metre) {
  const float scale = DepthScale(units_per_metre);
  cv::Mat image(frame.height, frame.width, CV_16UC1);
  for (int v = 0; v < frame.height; ++v) {
    uint16_t* row = image.ptr<uint16_t>(v);
    const float* depth = frame.depth.data() + static_cast<size_t>(v) * frame.width;
    for (int u = 0; u < frame.width; ++u) row[u] = DepthUnits(depth[u], scale);
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

// 16-bit grey PNG of rows x cols samples (sample(v, u) each), rows
// unfiltered, compressed by libdeflate at level 1: about three times faster
// than libpng with zlib at level 1, and smaller on Kinect depth. The
// samples are written big-endian straight into the rows deflate reads (one
// pass; the buffers are the thread's own, reused). The container is written
// here (signature, IHDR, one IDAT, IEND); any PNG decoder reads it.
template <class Sample>
std::vector<uint8_t> FastPng(int cols, int rows, Sample&& sample) {
  const size_t row_bytes = 1 + 2 * static_cast<size_t>(cols);
  thread_local std::vector<uint8_t> raw, idat;
  raw.resize(row_bytes * rows);  // every byte written below
  for (int v = 0; v < rows; ++v) {
    uint8_t* out = &raw[v * row_bytes];
    *out++ = 0;                       // filter type None
    for (int u = 0; u < cols; ++u) {  // PNG samples are big-endian
      const uint16_t value = sample(v, u);
      *out++ = static_cast<uint8_t>(value >> 8);
      *out++ = static_cast<uint8_t>(value);
    }
  }
  thread_local std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(
      libdeflate_alloc_compressor(1), libdeflate_free_compressor);
  Require(compressor != nullptr, "PNG encoder: out of memory");
  idat.resize(libdeflate_zlib_compress_bound(compressor.get(), raw.size()));
  const size_t compressed =
      libdeflate_zlib_compress(compressor.get(), raw.data(), raw.size(), idat.data(), idat.size());
  Require(compressed > 0, "PNG encoding failed");

  static constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<uint8_t> header;
  AppendBigEndian32(static_cast<uint32_t>(cols), &header);
  AppendBigEndian32(static_cast<uint32_t>(rows), &header);
  header.insert(header.end(), {16, 0, 0, 0, 0});  // 16-bit grey, deflate, adaptive, no interlace
  std::vector<uint8_t> png(std::begin(kSignature), std::end(kSignature));
  png.reserve(compressed + 64);
  AppendChunk("IHDR", header.data(), header.size(), &png);
  AppendChunk("IDAT", idat.data(), compressed, &png);
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
  if (uint64_t{png_get_image_width(png, info)} * png_get_image_height(png, info) > kMaxDepthPixels)
    png_error(png, "more than 4096 x 4096 pixels (what one frame's detection may cost)");
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
  const float scale = DepthScale(units_per_metre);
  const float* depth = frame.depth.data();
  const int width = frame.width;
  return FastPng(width, frame.height, [&](int v, int u) {
    return DepthUnits(depth[static_cast<size_t>(v) * width + u], scale);
  });
}

std::vector<uint8_t> EncodeIdPng(const DepthFrame& frame) {
  const uint16_t* ids = frame.instance_ids.data();
  const int width = frame.width;
  return FastPng(
      width, frame.height, [&](int v, int u) { return ids[static_cast<size_t>(v) * width + u]; });
}

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

}  // namespace furn

#include "reports/png_file.h"

#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "core/error.h"
#include "core/file_util.h"

namespace furn {

void WritePngAtomically(const cv::Mat& image, const std::string& png_path) {
  std::vector<uchar> bytes;
  Require(cv::imencode(".png", image, bytes), png_path + ": PNG encoding failed");
  WriteFileAtomically(png_path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace furn

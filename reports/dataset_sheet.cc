#include "reports/dataset_sheet.h"

#include <algorithm>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/png_file.h"

namespace furn {
namespace {

cv::Mat Tile(const SheetFrame& item, const DatasetSheetOptions& options) {
  const FrameRecord& frame = *item.frame;
  const cv::Mat depth = cv::imdecode(frame.depth_noisy_png, cv::IMREAD_UNCHANGED);
  Require(!depth.empty() && depth.type() == CV_16UC1,
          "frame " + std::to_string(frame.id) + ": noisy depth is not a 16-bit PNG");
  // 0.5 m red .. 5 m blue (the Kinect's range), black for no return.
  cv::Mat grey;
  depth.convertTo(grey, CV_8UC1, -255.0 / 4500.0, 255.0 + 255.0 * 500.0 / 4500.0);
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), depth == 0);
  cv::Mat tile;
  cv::resize(colour, tile, cv::Size(), options.scale, options.scale, cv::INTER_AREA);
  std::map<int, const ObjectRecord*> objects;
  for (const ObjectRecord& object : item.room->objects) objects[object.instance_id] = &object;
  for (const FrameObjectRecord& seen : frame.objects) {
    const auto it = objects.find(seen.instance_id);
    if (it == objects.end() || !it->second->furniture_class || seen.visible_pixels == 0) continue;
    const bool clear = seen.visibility >= options.min_visibility;
    const cv::Scalar colour_of_box =
        clear ? ClassColour(it->second->furniture_class) : cv::Scalar(150, 150, 150);
    const cv::Rect box(cv::Point(static_cast<int>(seen.visible_box[0] * options.scale),
                                 static_cast<int>(seen.visible_box[1] * options.scale)),
                       cv::Point(static_cast<int>((seen.visible_box[2] + 1) * options.scale),
                                 static_cast<int>((seen.visible_box[3] + 1) * options.scale)));
    cv::rectangle(tile, box, colour_of_box, clear ? 2 : 1);
    char label[64];
    std::snprintf(
        label, sizeof(label), "%s %.2f", ClassName(*it->second->furniture_class), seen.visibility);
    const cv::Point at(box.x + 2, std::max(12, box.y - 3));
    DrawLabel(&tile, label, at, colour_of_box);
  }
  char caption[96];
  std::snprintf(caption,
                sizeof(caption),
                "frame %lld  room %lld (%s)",
                static_cast<long long>(frame.id),
                static_cast<long long>(item.room->id),
                EnumName(item.room->split));
  DrawLabel(&tile, caption, cv::Point(4, tile.rows - 6), cv::Scalar(255, 255, 255));
  return tile;
}

}  // namespace

void WriteDatasetSheet(const std::vector<SheetFrame>& frames,
                       const DatasetSheetOptions& options,
                       const std::string& png_path) {
  Require(options.Check(), "sheet options: columns >= 1, scale in [0.1, 1], min_visibility >= 0");
  Require(!frames.empty(), png_path + ": the dataset has no frames to show");
  Require(FileExtension(png_path) == "png", png_path + ": the sheet is written as .png");
  std::vector<cv::Mat> tiles;
  for (const SheetFrame& frame : frames) tiles.push_back(Tile(frame, options));
  const int columns = std::min<int>(options.columns, static_cast<int>(tiles.size()));
  const int rows = static_cast<int>((tiles.size() + columns - 1) / columns);
  const int w = tiles[0].cols, h = tiles[0].rows;
  cv::Mat sheet(rows * h, columns * w, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t i = 0; i < tiles.size(); ++i) {
    tiles[i].copyTo(sheet(
        cv::Rect(static_cast<int>(i % columns) * w, static_cast<int>(i / columns) * h, w, h)));
  }
  WritePngAtomically(sheet, png_path);
}

}  // namespace furn

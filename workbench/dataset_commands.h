// The work behind `workbench dataset ...`, as functions tests call directly.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

namespace furn {

struct DatasetInfo {
  std::string path;
  int64_t file_bytes = 0;
  std::string generation_options;
  std::map<std::string, int> rooms_per_split;
  int64_t frames = 0;
  std::map<std::string, int64_t> objects_per_class;  // placed targets, per class
  int64_t clutter_objects = 0;
  std::map<std::string, int64_t> views_per_class;     // target objects in frustum over all frames
  std::array<int64_t, 10> visibility_histogram = {};  // of those views, by tenths
  std::map<std::string, int64_t> models_per_class;
};

// Throws DbError / InputError for a missing or foreign file.
DatasetInfo ReadDatasetInfo(const std::string& db_path);
std::string DatasetInfoText(const DatasetInfo& info);
std::string DatasetInfoJson(const DatasetInfo& info);

// Up to `max_frames` frames spread evenly over the dataset, as a contact sheet.
void WriteDatasetPreview(const std::string& db_path, int max_frames, const std::string& png_path);

}  // namespace furn

// The work behind `workbench dataset ...`, as functions tests call directly.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "scenes/catalog.h"

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

namespace furn {

// Joins datasets made with the same generation options (e.g. the shards of
// one run) into a new file. Throws InputError when `out` exists, the options
// differ, two inputs hold the same room with different content, or (unless
// allow_partial) the inputs lack rooms their generation made.
struct MergeSummary {
  int rooms = 0;
  int duplicate_rooms = 0;  // present in several inputs, identical
};
// The inputs of a merge, checked: each a dataset, all of one generation,
// and (unless allow_partial) together every room of it (else an InputError
// ending in `remedy`). Returns their generation options.
std::string CheckMergeable(const std::vector<std::string>& inputs,
                           const std::string& remedy,
                           bool allow_partial = false);

MergeSummary MergeDatasets(const std::vector<std::string>& inputs,
                           const std::string& out,
                           bool allow_partial = false);

// Writes every frame to `out_dir` as
//   bop: a BOP dataset, models included (workbench/bop_export.h); the meshes
//        come from the catalog the dataset was generated from, found with
//        `catalog_options`
//   png: frames/<frame>_depth.png, _depth_ideal.png, _ids.png; frames.json
//        (camera, pose as 4 rows, ground truth per frame)
//   pcd: <frame>.pcd (organized, noisy, world frame with VIEWPOINT = the
//        camera's pose, a label field = instance id) and <frame>.json
//        (camera, pose, ground truth)
// Returns the number of frames written.
int ExportDataset(const std::string& db_path,
                  const std::string& format,
                  const std::string& out_dir,
                  const CatalogOpenOptions& catalog_options = {});

}  // namespace furn

// A generated dataset as a BOP dataset (https://bop.felk.cvut.cz/datasets/,
// the layout the BOP toolkit's loaders read):
//
//   camera.json                       the sensor: fx, fy, cx, cy, width, height, depth_scale
//   models/models_info.json           per obj_id: diameter, min_x/y/z, size_x/y/z (mm),
//                                     symmetries_discrete (turns about z as 4x4 row-major,
//                                     mm) or symmetries_continuous (axis z), found on the mesh
//   test_targets_bop19.json           per test image and obj_id: the furniture instances
//                                     at least 10 % visible (im_id, inst_count, obj_id, scene_id)
//   models/obj_000001.ply ...         each CAD model in mm, centred on its bounding box
//   <split>/<room:06d>/
//     depth/<im:06d>.png              noisy depth, 16-bit mm (depth_scale 1)
//     mask/<im:06d>_<gt:06d>.png      amodal mask of the gt-th object (rendered alone)
//     mask_visib/<im:06d>_<gt:06d>.png  its visible part (255 where seen)
//     scene_camera.json               cam_K, depth_scale, cam_R_w2c, cam_t_w2c (mm)
//     scene_gt.json                   obj_id, cam_R_m2c, cam_t_m2c (mm) per object
//     scene_gt_info.json              bbox_obj, bbox_visib, px_count_all, px_count_valid,
//                                     px_count_visib, visib_fract
//
// Beside them, not part of BOP: depth_ideal/ (the depth without sensor
// noise), mask_ids/ (the instance id image), scene_gt_furnidet.json (each
// gt's instance id, model id and class) and models/models_furnidet.json
// (obj_id -> model id and class).
//
// Our models have their origin at the centre of their floor footprint; BOP's
// are centred on their bounding box, so models and poses are both moved: a
// model point p (mm, BOP frame) is at cam_R_m2c * p + cam_t_m2c in the camera.
#pragma once

#include <string>

#include "scenes/catalog.h"

namespace furn {

struct BopExportOptions {
  // The catalog the dataset was generated from (its generation options name
  // it, with any clutter catalogs) supplies the meshes; each must have the
  // content hash the dataset recorded.
  CatalogOpenOptions catalog;
};

// Writes the dataset at `db_path` into `out_dir` (which must exist); returns
// the number of frames. Throws InputError for a dataset that was not
// generated from a catalog (a real set) or whose catalog no longer holds a
// model as it was.
int ExportBop(const std::string& db_path,
              const std::string& out_dir,
              const BopExportOptions& options);

}  // namespace furn

// `dataset export --format rosbag`: the frames of a split as a ROS 1 bag
// (a .bag path; formats/rosbag_io.h's FrameBagWriter) or a ROS 2 bag folder
// of SQLite or MCAP storage (formats/ros2_bag.h), written atomically.
//
//   const int frames = ExportRosbag("synth.db", "synth_test.bag", "test");
//   ExportRosbag("synth.db", "synth_jazzy", "all", Ros2Storage::kMcap);
#pragma once

#include <string>

#include "workbench/formats/ros2_storage.h"

namespace furn {

// `split`: train, val, test or all; `storage` applies to ROS 2 folders.
// Returns the frames written; InputError for a split without frames (no
// file is written).
int ExportRosbag(const std::string& db_path,
                 const std::string& out_bag,
                 const std::string& split,
                 Ros2Storage storage = Ros2Storage::kSqlite3);

}  // namespace furn

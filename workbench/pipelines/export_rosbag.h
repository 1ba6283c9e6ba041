// `dataset export --format rosbag`: the frames of a split as a ROS 1 bag
// (formats/rosbag_io.h's FrameBagWriter), written atomically.
//
//   const int frames = ExportRosbag("synth.db", "synth_test.bag", "test");
#pragma once

#include <string>

namespace furn {

// `split`: train, val, test or all. Returns the frames written; InputError
// for a split without frames (no file is written).
int ExportRosbag(const std::string& db_path, const std::string& out_bag, const std::string& split);

}  // namespace furn

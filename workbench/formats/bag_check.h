// Our checks of a ROS 1 bag before the bag library reads it (issue 29): the
// library trusts every length and offset in the file, so a damaged bag
// crashed it (an index entry past its chunk) or made it allocate gigabytes
// (a message field claiming 2^32 bytes). These readers are bounded: every
// length is checked against the bytes that hold it, nothing is allocated for
// what the file does not have, and a failure is one InputError naming the
// file (or the message) and the rule. No ROS headers: they are tested and
// fuzzed in every build.
//
//   CheckBagFile("scan.bag");                    // records, chunks, indexes
//   CheckMessageFields("sensor_msgs/Image", bytes, "scan.bag /camera at 1.0");
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace furn {

// The bag's record structure (format 2.0): the magic line, every record's
// header and data lengths within the file, header fields within their
// header, known op codes, the bag header's index position, each chunk's
// compression (none, lz4, bz2) and uncompressed size, index entries that
// point into their chunk, chunk infos that name a chunk, and (uncompressed
// chunks) the records inside a chunk within it. Returns the first chunk's
// compression ("none", "lz4" or "bz2"; "none" without chunks): what a copy
// of the bag is written with.
std::string CheckBagFile(const std::string& path);

// The serialized fields of a message of `type` (sensor_msgs/Image,
// sensor_msgs/PointCloud2, sensor_msgs/CameraInfo, tf2_msgs/TFMessage):
// every string and array length within the bytes left; other types are not
// checked. `where` names the message in errors.
void CheckMessageFields(const std::string& type,
                        const std::vector<uint8_t>& bytes,
                        const std::string& where);

}  // namespace furn

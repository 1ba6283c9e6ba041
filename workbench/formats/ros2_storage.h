// The storage files of a ROS 2 bag behind one reader and one writer: rosbag2's
// SQLite file (.db3, Humble's default) and MCAP (.mcap, the default of
// `ros2 bag record` since Iron, Jazzy included). The bag's logic (folders,
// metadata.yaml, scans, copies) in ros2_bag.cc is written once over these.
//
//   std::unique_ptr<Ros2StorageReader> file = OpenRos2Storage("run_0.mcap");
//   file->ForEach(file->Ids({"/camera/depth/image_raw"}), [&](const Ros2Message& m) { ... });
//
//   std::unique_ptr<Ros2StorageWriter> out = CreateRos2Storage("out_0.mcap", Ros2Storage::kMcap);
//   out->Write(topic, time_ns, cdr);
//   out->Finish();
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "workbench/formats/mcap.h"

namespace furn {

enum class Ros2Storage { kSqlite3, kMcap };
// metadata.yaml's storage_identifier: "sqlite3", "mcap".
const char* Ros2StorageName(Ros2Storage storage);
// The storage file's extension without the dot: "db3", "mcap".
const char* Ros2StorageExtension(Ros2Storage storage);
// InputError naming `flag` for any other name than sqlite3 or mcap.
Ros2Storage Ros2StorageFromName(const std::string& name, const std::string& flag);

// A topic as a bag declares it.
struct Ros2Topic {
  std::string name, type;
  std::string serialization = "cdr";
  std::string offered_qos_profiles;  // rosbag2's QoS YAML; empty when unknown
  // MCAP: the schema's encoding ("ros2msg") and text; empty from SQLite.
  std::string schema_encoding, schema;
};

// One message of a ROS 2 bag as stored: topic, type, receive time, CDR bytes.
struct Ros2Message {
  std::string topic, type;
  int64_t time_ns = 0;
  std::vector<uint8_t> data;
  // The topic's declaration (QoS, schema); valid during the callback.
  const Ros2Topic* declaration = nullptr;
};

// The messages of one storage file. Bounded as every loader here: a message
// above 256 MiB is refused before it is read; errors are InputError naming
// the file.
class Ros2StorageReader {
 public:
  virtual ~Ros2StorageReader() = default;
  const std::map<int64_t, Ros2Topic>& topics() const { return topics_; }
  // Topic ids of the names (and, when not empty, of the type).
  std::set<int64_t> Ids(const std::set<std::string>& names, const std::string& type = "") const;
  virtual int64_t Count(const std::set<int64_t>& ids) = 0;
  // The messages of the topics in receive-time order (ties in storage
  // order); the first `limit` when > 0.
  virtual void ForEach(const std::set<int64_t>& ids,
                       const std::function<void(const Ros2Message&)>& each,
                       int64_t limit = 0) = 0;
  // What a copy of this file is written as.
  virtual Ros2Storage storage() const = 0;
  virtual McapCompression compression() const { return McapCompression::kNone; }

 protected:
  std::map<int64_t, Ros2Topic> topics_;
};

// Opens a .db3 or .mcap file (by its extension; the content is checked).
std::unique_ptr<Ros2StorageReader> OpenRos2Storage(const std::string& file);

// Writes one storage file; the first message of a topic declares it.
class Ros2StorageWriter {
 public:
  virtual ~Ros2StorageWriter() = default;
  virtual void Write(const Ros2Topic& topic, int64_t time_ns, const std::vector<uint8_t>& cdr) = 0;
  virtual void Finish() = 0;
};

// Creates `file` (which must not exist); MCAP chunks use `compression`.
std::unique_ptr<Ros2StorageWriter> CreateRos2Storage(
    const std::string& file,
    Ros2Storage storage,
    McapCompression compression = McapCompression::kZstd);

}  // namespace furn

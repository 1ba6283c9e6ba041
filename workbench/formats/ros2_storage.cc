#include "workbench/formats/ros2_storage.h"

#include <climits>
#include <tuple>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/sqlite.h"
#include "workbench/formats/ros2_messages.h"
#include "workbench/formats/ros_common.h"

namespace furn {
namespace {

constexpr int64_t kMaxMessageBytes = int64_t{1} << 28;  // 256 MiB: 100 raw 1080p depth frames
constexpr int kMaxTopics = 10000;

std::string SecondsText(int64_t time_ns) { return TimeText(time_ns * 1e-9); }

// Runs `body`, turning SQLite's errors into InputError naming the file.
template <typename Body>
auto Guarded(const std::string& path, Body body) {
  try {
    return body();
  } catch (const DbError& e) {
    throw InputError(path + ": " + e.what());
  }
}

void RequireCdr(const std::string& where, const Ros2Topic& topic) {
  Require(topic.serialization == "cdr",
          where + " " + topic.name + ": serialization '" + topic.serialization.substr(0, 32) +
              "' is not cdr");
}

// ---------------------------------------------------------------- SQLite

// One .db3 of a bag, opened read-only; its tables checked before use.
class SqliteReader : public Ros2StorageReader {
 public:
  explicit SqliteReader(const std::string& path) : path_(path), db_(Open(path)) {
    Guarded(path, [&] {
      // A hostile file may define its tables as views or its columns as
      // expressions that make gigabytes out of a few bytes.
      db_.TreatAsUntrusted(kMaxMessageBytes);
      const bool has_qos =
          CheckPlainTable("topics", {"id", "name", "type", "serialization_format"});
      CheckPlainTable("messages", {"id", "topic_id", "timestamp", "data"});
      Statement topics(&db_,
                       std::string("SELECT id, name, type, serialization_format, ") +
                           (has_qos ? "offered_qos_profiles" : "''") + " FROM topics");
      while (topics.Step()) {
        Require(static_cast<int>(topics_.size()) < kMaxTopics,
                path + ": more than " + std::to_string(kMaxTopics) + " topics");
        Ros2Topic topic{topics.ColumnText(1),
                        topics.ColumnText(2),
                        topics.ColumnText(3),
                        topics.ColumnText(4).substr(0, 1 << 16),
                        "",
                        ""};
        Require(topic.name.size() <= 256 && topic.type.size() <= 256,
                path + ": a topic name or type longer than 256 bytes");
        topics_[topics.ColumnInt(0)] = std::move(topic);
      }
      return 0;
    });
  }

  int64_t Count(const std::set<int64_t>& ids) override {
    if (ids.empty()) return 0;
    return Guarded(path_, [&] {
      Statement count(&db_, "SELECT COUNT(*) FROM messages WHERE topic_id IN (" + List(ids) + ")");
      return count.Step() ? count.ColumnInt(0) : int64_t{0};
    });
  }

  void ForEach(const std::set<int64_t>& ids,
               const std::function<void(const Ros2Message&)>& each,
               int64_t limit) override {
    if (ids.empty()) return;
    Guarded(path_, [&] {
      // length() of a BLOB is its bytes, read from the record without its
      // content; of TEXT it counts characters to the first NUL, so a message
      // stored as TEXT is refused rather than measured.
      Statement rows(&db_,
                     "SELECT topic_id, timestamp, typeof(data), length(data), CASE WHEN "
                     "typeof(data) = 'blob' AND length(data) <= " +
                         std::to_string(kMaxMessageBytes) +
                         " THEN data END FROM messages WHERE topic_id IN (" + List(ids) +
                         ") ORDER BY timestamp, id" +
                         (limit > 0 ? " LIMIT " + std::to_string(limit) : std::string()));
      Ros2Message message;
      while (Step(&rows)) {
        const Ros2Topic& topic = topics_.at(rows.ColumnInt(0));
        message.topic = topic.name;
        message.type = topic.type;
        message.declaration = &topic;
        message.time_ns = rows.ColumnInt(1);
        const std::string where = path_ + " " + topic.name + " at " + SecondsText(message.time_ns);
        Require(rows.ColumnText(2) == "blob",
                where + ": the message is stored as " + rows.ColumnText(2).substr(0, 16) +
                    "; rosbag2 stores messages as BLOB");
        Require(rows.ColumnInt(3) <= kMaxMessageBytes,
                where + ": a message of " + std::to_string(rows.ColumnInt(3)) +
                    " bytes, more than " + std::to_string(kMaxMessageBytes));
        RequireCdr(path_, topic);
        message.data = rows.ColumnBlob(4);
        each(message);
      }
      return 0;
    });
  }

  Ros2Storage storage() const override { return Ros2Storage::kSqlite3; }

 private:
  static Database Open(const std::string& path) {
    try {
      return Database(path, Database::Mode::kReadOnly);
    } catch (const DbError& e) {
      throw InputError(std::string(e.what()));
    }
  }
  // The next row; a value past the length cap (SQLite's "too big", whatever
  // the column computes or stores) is refused as the cap it breaks.
  bool Step(Statement* rows) {
    try {
      return rows->Step();
    } catch (const DbError& e) {
      if (std::string(e.what()).find("too big") == std::string::npos) throw;
      throw InputError(path_ + ": a message of more than " + std::to_string(kMaxMessageBytes) +
                       " bytes (SQLite: string or blob too big)");
    }
  }
  // A table as rosbag2 makes it: a plain table (not a view, not a virtual
  // table) with the `needed` columns, all stored (no generated or hidden
  // one). Returns whether it has an offered_qos_profiles column.
  bool CheckPlainTable(const std::string& table, const std::set<std::string>& needed) {
    Statement kind(&db_, "SELECT type, sql FROM sqlite_master WHERE name = ?");
    kind.Bind(1, table);
    Require(kind.Step() && kind.ColumnText(0) == "table",
            path_ + ": no '" + table + "' table: not a rosbag2 SQLite file");
    Require(kind.ColumnText(1).rfind("CREATE TABLE", 0) == 0,
            path_ + ": table '" + table + "' is not a plain table (rosbag2 writes CREATE TABLE)");
    Statement columns(&db_, "SELECT name, hidden FROM pragma_table_xinfo(?)");
    columns.Bind(1, table);
    std::set<std::string> missing = needed;
    bool has_qos = false;
    while (columns.Step()) {
      Require(columns.ColumnInt(1) == 0,
              path_ + ": column '" + columns.ColumnText(0).substr(0, 64) + "' of table '" + table +
                  "' is generated or hidden; a rosbag2 file stores its columns");
      missing.erase(columns.ColumnText(0));
      has_qos = has_qos || columns.ColumnText(0) == "offered_qos_profiles";
    }
    Require(missing.empty(),
            path_ + ": table '" + table + "' has no column '" +
                (missing.empty() ? std::string() : *missing.begin()) +
                "': not a rosbag2 SQLite file");
    return has_qos;
  }
  static std::string List(const std::set<int64_t>& ids) {
    std::string list;
    for (int64_t id : ids) list += (list.empty() ? "" : ",") + std::to_string(id);
    return list;
  }
  std::string path_;
  Database db_;
};

// rosbag2's SQLite layout of Humble (schema 3).
class SqliteWriter : public Ros2StorageWriter {
 public:
  explicit SqliteWriter(const std::string& path) : path_(path) {
    Guarded(path, [&] {
      db_ = std::make_unique<Database>(path);
      db_->Execute(
          "PRAGMA journal_mode = DELETE;"
          "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);"
          "INSERT INTO schema VALUES (3, 'humble');"
          "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
          "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
          "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
          "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
          "CREATE INDEX timestamp_idx ON messages (timestamp ASC);"
          "BEGIN");
      insert_ = std::make_unique<Statement>(
          db_.get(), "INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)");
      return 0;
    });
  }

  void Write(const Ros2Topic& topic, int64_t time_ns, const std::vector<uint8_t>& cdr) override {
    Guarded(path_, [&] {
      auto found = ids_.find(topic.name);
      if (found == ids_.end()) {
        Statement add(db_.get(),
                      "INSERT INTO topics(name, type, serialization_format, offered_qos_profiles) "
                      "VALUES (?, ?, ?, ?)");
        add.Bind(1, topic.name)
            .Bind(2, topic.type)
            .Bind(3, topic.serialization)
            .Bind(4, topic.offered_qos_profiles)
            .Run();
        found = ids_.emplace(topic.name, db_->LastInsertRowId()).first;
      }
      insert_->Bind(1, found->second).Bind(2, time_ns).BindBlob(3, cdr).Run();
      insert_->Reset();
      return 0;
    });
  }

  void Finish() override {
    Guarded(path_, [&] {
      db_->Execute("COMMIT");
      insert_.reset();
      db_.reset();
      return 0;
    });
  }

 private:
  std::string path_;
  std::unique_ptr<Database> db_;
  std::unique_ptr<Statement> insert_;
  std::map<std::string, int64_t> ids_;
};

// ---------------------------------------------------------------- MCAP

// An MCAP file of ROS 2 messages: channels are topics, a channel's schema
// name its type, its metadata's offered_qos_profiles its QoS (as rosbag2's
// MCAP storage plugin writes them).
class McapStorageReader : public Ros2StorageReader {
 public:
  explicit McapStorageReader(const std::string& path) : file_(path) {
    Require(file_.channels().size() <= static_cast<size_t>(kMaxTopics),
            path + ": more than " + std::to_string(kMaxTopics) + " topics");
    for (const auto& [id, channel] : file_.channels()) {
      Ros2Topic topic;
      topic.name = channel.topic;
      topic.serialization = channel.message_encoding;
      const auto qos = channel.metadata.find("offered_qos_profiles");
      if (qos != channel.metadata.end()) topic.offered_qos_profiles = qos->second;
      const auto schema = file_.schemas().find(channel.schema_id);
      if (schema != file_.schemas().end()) {
        topic.type = schema->second.name;
        topic.schema_encoding = schema->second.encoding;
        topic.schema = schema->second.data;
      }
      Require(topic.name.size() <= 256 && topic.type.size() <= 256,
              path + ": a topic name or type longer than 256 bytes");
      topics_[id] = std::move(topic);
    }
  }

  int64_t Count(const std::set<int64_t>& ids) override { return file_.Count(Channels(ids)); }

  void ForEach(const std::set<int64_t>& ids,
               const std::function<void(const Ros2Message&)>& each,
               int64_t limit) override {
    if (ids.empty()) return;
    Ros2Message message;
    file_.ForEach(
        Channels(ids),
        [&](const McapMessage& m) {
          const Ros2Topic& topic = topics_.at(m.channel_id);
          Require(m.log_time <= static_cast<uint64_t>(INT64_MAX),
                  file_.path() + " " + topic.name + ": log_time " + std::to_string(m.log_time) +
                      " ns is beyond 2^63");
          RequireCdr(file_.path(), topic);
          Require(!topic.type.empty(),
                  file_.path() + " " + topic.name +
                      ": its channel has no schema, so its message type is unknown");
          message.topic = topic.name;
          message.type = topic.type;
          message.declaration = &topic;
          message.time_ns = static_cast<int64_t>(m.log_time);
          message.data = m.data;
          each(message);
        },
        limit);
  }

  Ros2Storage storage() const override { return Ros2Storage::kMcap; }
  McapCompression compression() const override { return file_.compression(); }

 private:
  static std::set<uint16_t> Channels(const std::set<int64_t>& ids) {
    std::set<uint16_t> channels;
    for (int64_t id : ids) channels.insert(static_cast<uint16_t>(id));
    return channels;
  }
  McapReader file_;
};

// A topic's schema: the one it was read with, else the definition of its
// type known here (ros2_messages.h), else an empty one (the messages still
// copy; a viewer cannot decode them).
std::pair<std::string, std::string> SchemaOf(const Ros2Topic& topic) {
  if (!topic.schema.empty()) return {topic.schema_encoding, topic.schema};
  return {"ros2msg", Ros2MessageDefinition(topic.type)};
}

class McapStorageWriter : public Ros2StorageWriter {
 public:
  McapStorageWriter(const std::string& path, McapCompression compression)
      : file_(path, Options(compression)) {}

  void Write(const Ros2Topic& topic, int64_t time_ns, const std::vector<uint8_t>& cdr) override {
    Require(time_ns >= 0, "a receive time before 1970 cannot be written to MCAP");
    auto found = channels_.find(topic.name);
    if (found == channels_.end()) {
      const auto [encoding, text] = SchemaOf(topic);
      auto schema = schemas_.find({topic.type, encoding, text});
      if (schema == schemas_.end())
        schema = schemas_
                     .emplace(std::make_tuple(topic.type, encoding, text),
                              file_.AddSchema(topic.type, encoding, text))
                     .first;
      std::map<std::string, std::string> metadata;
      metadata["offered_qos_profiles"] = topic.offered_qos_profiles;
      found =
          channels_
              .emplace(topic.name,
                       file_.AddChannel(schema->second, topic.name, topic.serialization, metadata))
              .first;
    }
    file_.Write(found->second, static_cast<uint64_t>(time_ns), cdr);
  }

  void Finish() override { file_.Finish(); }

 private:
  static McapWriterOptions Options(McapCompression compression) {
    McapWriterOptions options;
    options.compression = compression;
    return options;
  }
  McapWriter file_;
  std::map<std::string, uint16_t> channels_;
  std::map<std::tuple<std::string, std::string, std::string>, uint16_t> schemas_;
};

}  // namespace

const char* Ros2StorageName(Ros2Storage storage) {
  return storage == Ros2Storage::kMcap ? "mcap" : "sqlite3";
}

const char* Ros2StorageExtension(Ros2Storage storage) {
  return storage == Ros2Storage::kMcap ? "mcap" : "db3";
}

Ros2Storage Ros2StorageFromName(const std::string& name, const std::string& flag) {
  if (name == "sqlite3") return Ros2Storage::kSqlite3;
  if (name == "mcap") return Ros2Storage::kMcap;
  throw InputError(flag + " '" + name.substr(0, 32) +
                   "': a ROS 2 bag's storage is sqlite3 or mcap");
}

std::set<int64_t> Ros2StorageReader::Ids(const std::set<std::string>& names,
                                         const std::string& type) const {
  std::set<int64_t> ids;
  for (const auto& [id, topic] : topics_) {
    if (names.count(topic.name) && (type.empty() || topic.type == type)) ids.insert(id);
  }
  return ids;
}

std::unique_ptr<Ros2StorageReader> OpenRos2Storage(const std::string& file) {
  if (FileExtension(file) == "mcap") return std::make_unique<McapStorageReader>(file);
  return std::make_unique<SqliteReader>(file);
}

std::unique_ptr<Ros2StorageWriter> CreateRos2Storage(const std::string& file,
                                                     Ros2Storage storage,
                                                     McapCompression compression) {
  if (storage == Ros2Storage::kMcap) return std::make_unique<McapStorageWriter>(file, compression);
  return std::make_unique<SqliteWriter>(file);
}

}  // namespace furn

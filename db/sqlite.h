// Thin RAII wrapper over SQLite: every failing call throws DbError carrying
// SQLite's own message and the database path; statements and transactions
// are objects that clean up after themselves.
//
//   Database db("synth.db");                       // WAL, foreign keys on
//   Transaction transaction(&db);
//   Statement insert(&db, "INSERT INTO scenes(id, seed) VALUES (?, ?)");
//   insert.Bind(1, int64_t{7}).Bind(2, int64_t{42}).Run();
//   transaction.Commit();                          // rolled back if never
//   reached
//
//   Statement query(&db, "SELECT id FROM scenes");
//   while (query.Step()) int64_t id = query.ColumnInt(0);
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

struct sqlite3;
struct sqlite3_stmt;

namespace furn {

class DbError : public std::runtime_error {
 public:
  explicit DbError(const std::string& message) : std::runtime_error(message) {}
};

// How a database file opens (one definition for Database and DatasetDb):
// kReadWrite creates the file when missing; kReadWriteExisting and kReadOnly
// need it to exist.
enum class OpenMode { kReadWrite, kReadWriteExisting, kReadOnly };

class Database {
 public:
  using Mode = OpenMode;
  // kReadWrite creates the file when missing; kReadWriteExisting fails on a
  // missing file instead. Both turn on WAL; every mode turns on foreign keys.
  explicit Database(const std::string& path, Mode mode = Mode::kReadWrite);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Runs one or more statements without results.
  void Execute(const std::string& sql);
  // For a file someone else wrote (a bag): defensive mode (no writes to the
  // schema, no shadow tables), an untrusted schema (no functions with side
  // effects in views, triggers or generated columns) and no string or BLOB
  // longer than `max_value_bytes`, whatever a column computes.
  void TreatAsUntrusted(int64_t max_value_bytes);
  int64_t LastInsertRowId() const;
  const std::string& path() const { return path_; }
  sqlite3* handle() { return db_; }

  // Throws DbError "<path>: <what>: <sqlite message>" when code is an error.
  void Check(int code, const std::string& what) const;

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

class Statement {
 public:
  Statement(Database* db, const std::string& sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Parameters are 1-based, as in SQLite.
  Statement& Bind(int index, int64_t value);
  Statement& Bind(int index, double value);
  Statement& Bind(int index, const std::string& text);
  Statement& BindBlob(int index, const std::vector<uint8_t>& bytes);
  Statement& BindNull(int index);

  // True while a row is available; false when done.
  bool Step();
  // Step() to completion, then Reset() for the next use.
  void Run();
  void Reset();

  int ColumnCount() const;
  int64_t ColumnInt(int column) const;
  double ColumnDouble(int column) const;
  std::string ColumnText(int column) const;
  std::vector<uint8_t> ColumnBlob(int column) const;
  bool ColumnIsNull(int column) const;

 private:
  Database* db_;
  sqlite3_stmt* statement_ = nullptr;
  std::string sql_;
};

// BEGIN IMMEDIATE on construction; ROLLBACK on destruction unless Commit().
class Transaction {
 public:
  explicit Transaction(Database* db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void Commit();

 private:
  Database* db_;
  bool done_ = false;
};

}  // namespace furn

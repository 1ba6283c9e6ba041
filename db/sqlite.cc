#include "db/sqlite.h"

#include <algorithm>

#include <sqlite3.h>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

// What a user can act on, for the result codes that are about the file and
// not the query: read-only media, a full disk, another writer, damage.
// Empty for the others.
std::string PlainCause(int code) {
  // A read-only open that meets a hot journal or WAL (a writer died mid-
  // transaction) cannot roll it back: that is not a read-only file.
  if (code == SQLITE_READONLY_ROLLBACK || code == SQLITE_READONLY_RECOVERY ||
      code == SQLITE_READONLY_CANTINIT)
    return "a writer stopped mid-transaction (a hot journal beside it); open it once with write "
           "access to roll that back, or copy the file without its -journal / -wal";
  switch (code & 0xff) {
    case SQLITE_READONLY:
      return "cannot write: the file or its folder is read-only";
    case SQLITE_FULL:
      return "cannot write: the disk is full";
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return "another process holds the database (two runs writing one file?)";
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return "the file is damaged or not a database";
    case SQLITE_IOERR:
      return "an input/output error on the file";
    case SQLITE_CANTOPEN:
      return "cannot open the file (missing folder, permissions or read-only media)";
    default:
      return "";
  }
}

}  // namespace

Database::Database(const std::string& path, Mode mode) : path_(path) {
  const int flags = mode == Mode::kReadOnly            ? SQLITE_OPEN_READONLY
                    : mode == Mode::kReadWriteExisting ? SQLITE_OPEN_READWRITE
                                                       : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  try {
    RequireRegularFile(path);  // SQLite would wait on a FIFO's open()
  } catch (const InputError& error) {
    throw DbError(error.what());
  }
  const int code = sqlite3_open_v2(path.c_str(), &db_, flags, nullptr);
  if (code != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(code);
    sqlite3_close(db_);
    db_ = nullptr;
    const std::string cause = PlainCause(code);
    throw DbError(path + ": " + (cause.empty() ? "cannot open database" : cause) +
                  " (SQLite: " + message + ")");
  }
  sqlite3_extended_result_codes(db_, 1);
  sqlite3_busy_timeout(db_, 10000);
  Execute("PRAGMA foreign_keys = ON");
  if (mode != Mode::kReadOnly) Execute("PRAGMA journal_mode = WAL");
}

Database::~Database() { sqlite3_close_v2(db_); }

void Database::TreatAsUntrusted(int64_t max_value_bytes) {
  Check(sqlite3_db_config(db_, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr), "defensive mode");
  Check(sqlite3_db_config(db_, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr), "untrusted schema");
  const int64_t limit = std::clamp<int64_t>(max_value_bytes, 1, 0x7ffffffe);
  sqlite3_limit(db_, SQLITE_LIMIT_LENGTH, static_cast<int>(limit));
}

void Database::Check(int code, const std::string& what) const {
  if (code == SQLITE_OK || code == SQLITE_ROW || code == SQLITE_DONE) return;
  const std::string cause = PlainCause(code);
  if (!cause.empty())
    throw DbError(path_ + ": " + cause + " (SQLite: " + sqlite3_errmsg(db_) + ")");
  throw DbError(path_ + ": " + what + ": " + sqlite3_errmsg(db_));
}

void Database::Execute(const std::string& sql) {
  char* error = nullptr;
  const int code = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
  if (code != SQLITE_OK) {
    const std::string message = error ? error : sqlite3_errstr(code);
    sqlite3_free(error);
    const std::string cause = PlainCause(code);
    if (!cause.empty()) throw DbError(path_ + ": " + cause + " (SQLite: " + message + ")");
    throw DbError(path_ + ": " + message + " (in: " + sql.substr(0, 80) + ")");
  }
}

int64_t Database::LastInsertRowId() const { return sqlite3_last_insert_rowid(db_); }

Statement::Statement(Database* db, const std::string& sql) : db_(db), sql_(sql) {
  db_->Check(sqlite3_prepare_v2(db_->handle(), sql.c_str(), -1, &statement_, nullptr),
             "cannot prepare '" + sql.substr(0, 80) + "'");
}

Statement::~Statement() { sqlite3_finalize(statement_); }

Statement& Statement::Bind(int index, int64_t value) {
  db_->Check(sqlite3_bind_int64(statement_, index, value), "bind");
  return *this;
}

Statement& Statement::Bind(int index, double value) {
  db_->Check(sqlite3_bind_double(statement_, index, value), "bind");
  return *this;
}

Statement& Statement::Bind(int index, const std::string& text) {
  db_->Check(sqlite3_bind_text(
                 statement_, index, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT),
             "bind");
  return *this;
}

Statement& Statement::BindBlob(int index, const std::vector<uint8_t>& bytes) {
  db_->Check(sqlite3_bind_blob(
                 statement_, index, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT),
             "bind");
  return *this;
}

Statement& Statement::BindNull(int index) {
  db_->Check(sqlite3_bind_null(statement_, index), "bind");
  return *this;
}

bool Statement::Step() {
  const int code = sqlite3_step(statement_);
  db_->Check(code, "'" + sql_.substr(0, 80) + "'");
  return code == SQLITE_ROW;
}

void Statement::Run() {
  while (Step()) {
  }
  Reset();
}

void Statement::Reset() {
  sqlite3_reset(statement_);
  sqlite3_clear_bindings(statement_);
}

int Statement::ColumnCount() const { return sqlite3_column_count(statement_); }

int64_t Statement::ColumnInt(int column) const { return sqlite3_column_int64(statement_, column); }

double Statement::ColumnDouble(int column) const {
  return sqlite3_column_double(statement_, column);
}

std::string Statement::ColumnText(int column) const {
  const auto* text = sqlite3_column_text(statement_, column);
  return text ? std::string(reinterpret_cast<const char*>(text),
                            sqlite3_column_bytes(statement_, column))
              : std::string();
}

std::vector<uint8_t> Statement::ColumnBlob(int column) const {
  const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(statement_, column));
  return data ? std::vector<uint8_t>(data, data + sqlite3_column_bytes(statement_, column))
              : std::vector<uint8_t>();
}

bool Statement::ColumnIsNull(int column) const {
  return sqlite3_column_type(statement_, column) == SQLITE_NULL;
}

Transaction::Transaction(Database* db) : db_(db) { db_->Execute("BEGIN IMMEDIATE"); }

Transaction::~Transaction() {
  if (!done_) {
    try {
      db_->Execute("ROLLBACK");
    } catch (const DbError&) {
      // Nothing more can be done in a destructor; the transaction is void.
    }
  }
}

void Transaction::Commit() {
  db_->Execute("COMMIT");
  done_ = true;
}

}  // namespace furn

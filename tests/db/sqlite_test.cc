#include "db/sqlite.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>

#include "tests/test_util.h"

namespace furn {
namespace {

TEST(Sqlite, InsertsAndReadsEveryType) {
  Database db(testing::ScratchDir() + "/t.db");
  db.Execute("CREATE TABLE t(i INTEGER, d REAL, s TEXT, b BLOB, n TEXT)");
  Statement insert(&db, "INSERT INTO t VALUES (?, ?, ?, ?, ?)");
  insert.Bind(1, int64_t{42})
      .Bind(2, 2.5)
      .Bind(3, std::string("chair"))
      .BindBlob(4, {1, 0, 255})
      .BindNull(5);
  insert.Run();
  Statement query(&db, "SELECT i, d, s, b, n FROM t");
  ASSERT_TRUE(query.Step());
  EXPECT_EQ(query.ColumnInt(0), 42);
  EXPECT_DOUBLE_EQ(query.ColumnDouble(1), 2.5);
  EXPECT_EQ(query.ColumnText(2), "chair");
  EXPECT_EQ(query.ColumnBlob(3), (std::vector<uint8_t>{1, 0, 255}));
  EXPECT_TRUE(query.ColumnIsNull(4));
  EXPECT_FALSE(query.Step());
}

TEST(Sqlite, TransactionRollsBackUnlessCommitted) {
  Database db(testing::ScratchDir() + "/t.db");
  db.Execute("CREATE TABLE t(i INTEGER)");
  {
    Transaction transaction(&db);
    db.Execute("INSERT INTO t VALUES (1)");
  }  // destroyed without Commit()
  {
    Transaction transaction(&db);
    db.Execute("INSERT INTO t VALUES (2)");
    transaction.Commit();
  }
  Statement count(&db, "SELECT group_concat(i) FROM t");
  ASSERT_TRUE(count.Step());
  EXPECT_EQ(count.ColumnText(0), "2");
}

TEST(Sqlite, ErrorsCarrySqliteMessageAndPath) {
  const std::string path = testing::ScratchDir() + "/t.db";
  Database db(path);
  try {
    Statement bad(&db, "SELECT * FROM no_such_table");
    FAIL();
  } catch (const DbError& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("no such table: no_such_table"), std::string::npos);
  }
  db.Execute(
      "CREATE TABLE p(id INTEGER PRIMARY KEY); CREATE TABLE c(p INTEGER "
      "REFERENCES p(id))");
  EXPECT_THROW(db.Execute("INSERT INTO c VALUES (7)"),
               DbError);  // foreign keys are on
}

TEST(Sqlite, ReadOnlyOpenOfMissingFileFails) {
  const std::string path = testing::ScratchDir() + "/missing.db";
  EXPECT_THROW(Database(path, Database::Mode::kReadOnly), DbError);
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(Sqlite, UsesWriteAheadLog) {
  Database db(testing::ScratchDir() + "/t.db");
  Statement mode(&db, "PRAGMA journal_mode");
  ASSERT_TRUE(mode.Step());
  EXPECT_EQ(mode.ColumnText(0), "wal");
}

// A cause the user can act on is said plainly, not as SQL text.
TEST(Sqlite, ReadOnlyAndBusyFilesAreSaidPlainly) {
  auto error_of = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const DbError& e) {
      return e.what();
    }
    return "(no error)";
  };
  const std::string path = testing::ScratchDir() + "/plain.db";
  {
    Database db(path, Database::Mode::kReadWrite);
    db.Execute("CREATE TABLE t(a INTEGER)");
  }
  Database read_only(path, Database::Mode::kReadOnly);
  const std::string write = error_of([&] { read_only.Execute("INSERT INTO t VALUES (1)"); });
  EXPECT_NE(write.find(path + ": cannot write: the file or its folder is read-only"),
            std::string::npos)
      << write;
  EXPECT_EQ(write.find("INSERT"), std::string::npos) << write;
  // Another connection holding the write lock.
  Database holder(path, Database::Mode::kReadWrite);
  holder.Execute("BEGIN IMMEDIATE");
  Database other(path, Database::Mode::kReadWrite);
  other.Execute("PRAGMA busy_timeout = 10");
  const std::string busy = error_of([&] { other.Execute("INSERT INTO t VALUES (2)"); });
  EXPECT_NE(busy.find("another process holds the database"), std::string::npos) << busy;
  holder.Execute("ROLLBACK");
}

}  // namespace
}  // namespace furn

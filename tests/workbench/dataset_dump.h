// A dataset database as text, for tests that compare two of them.
#pragma once

#include <string>

#include "db/sqlite.h"

namespace furn::testing {

// Every row of every generated table, as text, in key order.
inline std::string DumpDataset(const std::string& path) {
  Database db(path, Database::Mode::kReadOnly);
  std::string dump;
  for (const char* table :
       {"generation", "models", "rooms", "objects", "frames", "frame_objects"}) {
    Statement rows(&db, std::string("SELECT * FROM ") + table + " ORDER BY 1, 2");
    while (rows.Step()) {
      for (int c = 0; c < rows.ColumnCount(); ++c) dump += rows.ColumnText(c) + "|";
      dump += "\n";
    }
  }
  return dump;
}

}  // namespace furn::testing

// A dataset database, or its last evaluation run, as text, for tests that
// compare two of them.
#pragma once

#include <cstdio>
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

// Every evaluation run of a dataset as text, in id order, timings left out
// (they differ from run to run): kind, hashes, split, options and curves,
// every metric but the latencies and stage times, and every detection.
// Doubles in hex, exactly.
inline std::string DumpRuns(const std::string& path) {
  Database db(path, Database::Mode::kReadOnly);
  std::string dump;
  // Columns from `first_double` on are REAL.
  auto add = [&](const std::string& sql, int first_double) {
    Statement rows(&db, sql);
    while (rows.Step()) {
      for (int c = 0; c < rows.ColumnCount(); ++c) {
        if (c >= first_double) {
          char text[40];
          std::snprintf(text, sizeof(text), "%a|", rows.ColumnDouble(c));
          dump += text;
        } else {
          dump += rows.ColumnText(c) + "|";
        }
      }
      dump += "\n";
    }
  };
  add("SELECT id, kind, model_hash, dataset_hash, split, options_json, results_json FROM runs "
      "ORDER BY id",
      99);
  add("SELECT run_id, name, value FROM run_metrics WHERE name NOT LIKE '%latency%' AND name "
      "NOT LIKE '%\\_ms%' ESCAPE '\\' ORDER BY run_id, name",
      2);
  add("SELECT run_id, frame_id, class, model_id, x, y, z, yaw, score, vote_weight, verification, "
      "covered_fraction FROM run_detections ORDER BY run_id, rowid",
      4);
  return dump;
}

}  // namespace furn::testing

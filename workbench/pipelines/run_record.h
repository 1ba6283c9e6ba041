// What every stored run starts with: its provenance (results:
// reports/run_results.h).
#pragma once

#include <string>
#include <vector>

#include "db/dataset_db.h"  // RunRecord

namespace furn {

// Provenance of a new run: its kind and label, the time, the source commit
// and whether the tree had uncommitted changes.
RunRecord NewRunRecord(const std::string& kind, const std::string& label);

}  // namespace furn

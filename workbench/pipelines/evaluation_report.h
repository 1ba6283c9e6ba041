// `workbench report`: a run's report folder (reports/run_report.h) and its
// gallery of the frames with the most errors, detection rerun with the
// run's options and model, each frame's debug images and 3-D page.
#pragma once

#include <cstdint>
#include <string>

namespace furn {

// `workbench report`: the run's report folder, with a gallery of the frames
// with the most errors (detection rerun with the run's options and model).
void WriteReportForRun(const std::string& db_path, int64_t run_id, const std::string& out_dir);

}  // namespace furn

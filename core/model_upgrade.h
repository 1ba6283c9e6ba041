// A model file read without checking its vote network's block: only for
// `workbench model upgrade`, which converts an old block
// (learned/vote_net_upgrade.h). Everything else uses LoadTrainedModel, which
// refuses a block it cannot read in one line naming the file.
#pragma once

#include <string>

#include "core/trainer.h"

namespace furn {

TrainedModel LoadTrainedModelUnchecked(const std::string& path);

}  // namespace furn

// Converting a vote network of formats 2 and 3, whose weights are a
// TorchScript archive, to this build's plain tensor records (issue 39).
// Loading such an archive runs whatever code it holds: this is the only
// place that opens one, reached only by `workbench model upgrade
// --trust-torchscript` for model files the user made themselves.
#pragma once

#include <string>

namespace furn {

// The block in the current format (a current block comes back unchanged);
// InputError naming `what` for anything else.
std::string UpgradeTorchScriptVoteNet(const std::string& bytes, const std::string& what);

}  // namespace furn

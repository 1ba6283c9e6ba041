// Helpers for tests: a fresh scratch directory per test, and writing files.
#pragma once

#include <string>

namespace furn::testing {

// A new empty directory under the build tree, named after the running test.
std::string ScratchDir();

void WriteText(const std::string& path, const std::string& text);

}  // namespace furn::testing

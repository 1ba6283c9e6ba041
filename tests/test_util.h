// Helpers for tests: a fresh scratch directory per test, and writing files.
#pragma once

#include <functional>
#include <string>

namespace furn::testing {

// A new empty directory under the build tree, named after the running test.
std::string ScratchDir();

void WriteText(const std::string& path, const std::string& text);

// The message of the InputError `action` throws, or "(no error)".
std::string ErrorOf(const std::function<void()>& action);

}  // namespace furn::testing

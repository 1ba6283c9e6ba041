// Errors a caller can cause. Following Ceres and COLMAP there are two channels:
//   * a caller's mistake (bad file, bad value, impossible request) throws
//     furn::InputError whose message names the file or value and the rule;
//   * an expected outcome of an algorithm (no floor found, no convergence) is
//     returned in that algorithm's result struct, never thrown.
// The CLI prints InputError::what() as one line and exits non-zero.
//
//   if (width <= 0) throw InputError("width " + std::to_string(width) + " must
//   be > 0");
#pragma once

#include <stdexcept>
#include <string>

namespace furn {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// Throws InputError(message) when `condition` is false.
inline void Require(bool condition, const std::string& message) {
  if (!condition) throw InputError(message);
}

}  // namespace furn

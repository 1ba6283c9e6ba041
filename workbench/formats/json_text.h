// JSON text a user gave (options files, search spaces), parsed with an
// InputError that names the file: "<what>: not JSON (<parser message>)".
//
//   const nlohmann::ordered_json json = ParseUserJson(ReadFileBytes(path), path);
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"

namespace furn {

inline nlohmann::ordered_json ParseUserJson(const std::string& text, const std::string& what) {
  try {
    return nlohmann::ordered_json::parse(text);
  } catch (const nlohmann::json::exception& error) {
    throw InputError(what + ": not JSON (" + error.what() + ")");
  }
}

}  // namespace furn

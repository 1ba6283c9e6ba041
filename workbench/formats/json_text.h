// JSON text a user or another machine gave (options files, search spaces,
// job folders, shard files), parsed with an InputError that names the file:
// "<what>: not JSON (<parser message>)". Nesting deeper than kMaxJsonDepth
// is refused while parsing (a file nested 10^6 deep would otherwise exhaust
// the stack wherever the value is walked or printed).
//
//   const nlohmann::ordered_json json = ParseUserJson(ReadFileBytes(path), path);
//   const nlohmann::json jobs = ParseUserJson<nlohmann::json>(text, path);
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"

namespace furn {

inline constexpr int kMaxJsonDepth = 64;

template <typename Json = nlohmann::ordered_json>
Json ParseUserJson(const std::string& text, const std::string& what) {
  try {
    return Json::parse(text, [&what](int depth, typename Json::parse_event_t, Json&) {
      if (depth > kMaxJsonDepth)
        throw InputError(what + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) +
                         " levels");
      return true;
    });
  } catch (const nlohmann::json::exception& error) {
    throw InputError(what + ": not JSON (" + error.what() + ")");
  }
}

}  // namespace furn

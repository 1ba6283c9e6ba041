// JSON text a user or another machine gave (options files, search spaces,
// job folders, shard files), parsed with an InputError that names the file:
// "<what>: not JSON (<parser message>)". Nesting deeper than kMaxJsonDepth
// is refused while parsing (a file nested 10^6 deep would otherwise exhaust
// the stack wherever the value is walked or printed). A key twice in one
// object is refused too (nlohmann would keep the last silently).
//
//   const nlohmann::ordered_json json = ParseUserJson(ReadFileBytes(path), path);
//   const nlohmann::json jobs = ParseUserJson<nlohmann::json>(text, path);
#pragma once

#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/util/error.h"

namespace furn {

inline constexpr int kMaxJsonDepth = 64;

template <typename Json = nlohmann::ordered_json>
Json ParseUserJson(const std::string& text, const std::string& what) {
  using Event = typename Json::parse_event_t;
  std::vector<std::set<std::string>> keys;  // of each object being parsed
  try {
    return Json::parse(text, [&what, &keys](int depth, Event event, Json& parsed) {
      if (depth > kMaxJsonDepth)
        throw InputError(what + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) +
                         " levels");
      if (event == Event::object_start) keys.emplace_back();
      if (event == Event::object_end && !keys.empty()) keys.pop_back();
      if (event == Event::key && !keys.empty() && parsed.is_string() &&
          !keys.back().insert(parsed.template get<std::string>()).second)
        throw InputError(what + ": key \"" + parsed.template get<std::string>().substr(0, 64) +
                         "\" appears twice in one object");
      return true;
    });
  } catch (const nlohmann::json::exception& error) {
    throw InputError(what + ": not JSON (" + error.what() + ")");
  }
}

}  // namespace furn

// A class map for tests of the "vote_net_only" flag: the default class map
// plus six tables and sideboards of the three default catalogs marked
// vote_net_only (the six measured in docs/learned-voting.md; they are not
// in the default map).
#pragma once

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/test_util.h"

namespace furn::testing {

inline constexpr int kVoteNetOnlyExtras = 6;

// Writes the map to dir/with_vote_net_only.json and returns its path.
inline std::string WriteDefaultMapWithVoteNetOnlyExtras(const std::string& dir) {
  std::ifstream in(FURN_SOURCE_DIR "/data/class_map.json");
  nlohmann::json map = nlohmann::json::parse(in);
  const char* const extras[kVoteNetOnlyExtras][2] = {
      {"Scopia/round-table", "table"},
      {"Scopia/wooden_office_pear_table", "table"},
      {"Scopia/wooden_office_teak_table", "table"},
      {"BlendSwap-CC-0/technicalTable1", "table"},
      {"Scopia/changing-table", "sideboard"},
      {"BlendSwap-CC-BY/kitchenIsland", "sideboard"}};
  for (const auto& [id, furniture_class] : extras)
    map["entries"].push_back({{"id", id}, {"class", furniture_class}, {"vote_net_only", true}});
  const std::string path = dir + "/with_vote_net_only.json";
  WriteText(path, map.dump(1));
  return path;
}

}  // namespace furn::testing

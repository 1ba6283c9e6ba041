// A command-line option whose value is an enum named by core/util/enum_text.h:
// "--voting learned", "--vote-shape-sizes real". A name not in the table is a
// usage error naming the option, the value and the names it takes.
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <string>

#include "core/util/enum_text.h"

namespace furn {

template <typename E>
CLI::Option* AddEnumOption(CLI::App* app,
                           const std::string& flag,
                           E* value,
                           const std::string& help) {
  const std::string names = EnumNameList<E>();  // "auto, codebook, learned"
  std::string choices = "{" + names + "}";      // "{auto,codebook,learned}" in the help
  choices.erase(std::remove(choices.begin(), choices.end(), ' '), choices.end());
  const CLI::Validator known(
      [names](std::string& text) -> std::string {
        if (TryParseEnum<E>(text)) return "";
        return "'" + text + "' is not one of " + names;
      },
      "");
  return app
      ->add_option_function<std::string>(
          flag, [value](const std::string& text) { *value = ParseEnum<E>(text); }, help)
      ->check(known)
      ->type_name(choices)
      ->default_str(EnumName(*value));
}

}  // namespace furn

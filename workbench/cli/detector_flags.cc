#include "workbench/cli/detector_flags.h"

#include <CLI/CLI.hpp>
#include <string>
#include <type_traits>
#include <vector>

#include "core/util/file_util.h"
#include "workbench/cli/enum_option.h"
#include "workbench/formats/detector_option_table.h"
#include "workbench/formats/options_file.h"

namespace furn {

DetectorFlags::DetectorFlags(CLI::App* app, const std::set<std::string>& skip)
    : app_(app), skip_(skip) {
  ForEachDetectorOption(&parsed_, [this](const DetectorOptionInfo& info, auto& value) {
    if (*info.flag == '\0' || skip_.count(info.flag)) return;
    using T = std::remove_reference_t<decltype(value)>;
    if constexpr (std::is_enum_v<T>) {  // by name: "--voting learned"
      AddEnumOption(app_, info.flag, &value, info.help);
    } else if constexpr (std::is_same_v<T, bool>) {  // "--learned-fit" / "--no-learned-fit"
      app_->add_flag(std::string(info.flag) + ",!--no-" + (info.flag + 2), value, info.help)
          ->capture_default_str();
    } else {
      app_->add_option(info.flag, value, info.help)->capture_default_str();
    }
  });
  app_->add_option("--options",
                   options_file_,
                   "Options file (a run's options, a tuned file): its \"detector\" options; the "
                   "flags given apply on top");
  app_->add_flag(
      "--no-scorer", no_scorer_, "Decide by the fixed gates: no learned hypothesis scorer");
}

DetectorOptions DetectorFlags::Resolve(bool apply_no_scorer) const {
  DetectorOptions options =
      options_file_.empty() ? DetectorOptions{}
                            : DetectorOptionsFromJson(ReadFileBytes(options_file_), options_file_);
  // The table visits both structs in the same order: the k-th member of one
  // is the k-th of the other, of the same type.
  std::vector<void*> members;
  ForEachDetectorOption(
      &options, [&members](const DetectorOptionInfo&, auto& value) { members.push_back(&value); });
  size_t k = 0;
  DetectorOptions parsed = parsed_;
  ForEachDetectorOption(&parsed, [&](const DetectorOptionInfo& info, auto& value) {
    using T = std::remove_reference_t<decltype(value)>;
    if (*info.flag != '\0' && !skip_.count(info.flag) && app_->count(info.flag) > 0) {
      *static_cast<T*>(members[k]) = value;
    }
    ++k;
  });
  if (no_scorer_ && apply_no_scorer) options.use_scorer = false;
  options.Check();
  return options;
}

}  // namespace furn

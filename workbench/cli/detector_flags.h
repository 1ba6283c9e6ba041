// The detector's flags, made once from the option table
// (formats/detector_option_table.h) for every command that detects:
// `detect`, `evaluate`, `crossval` and `tune`. With --options FILE the file's
// detector options are the base and the flags given on the command line win.
//
//   CLI::App app{"..."};
//   DetectorFlags detector_flags(&app);
//   ParseCommandLine(&app, argc, argv);
//   const DetectorOptions options = detector_flags.Resolve();
#pragma once

#include <set>
#include <string>

#include "core/detector/detector.h"

namespace CLI {
class App;
}

namespace furn {

class DetectorFlags {
 public:
  // Registers every detector option that has a flag (but those in `skip`,
  // e.g. "--seed" where the command has a seed of its own), --options FILE
  // and --no-scorer on `app`, which must outlive this.
  explicit DetectorFlags(CLI::App* app, const std::set<std::string>& skip = {});

  // After parsing: the options file's detector options (or the defaults),
  // the flags given on top, --no-scorer applied unless `apply_no_scorer` is
  // false (crossval: it means no scorer is learnt); checked (InputError
  // naming the option and the rule).
  DetectorOptions Resolve(bool apply_no_scorer = true) const;

  const std::string& options_file() const { return options_file_; }
  bool no_scorer() const { return no_scorer_; }

 private:
  CLI::App* app_;
  DetectorOptions parsed_;  // the flags' values (defaults where not given)
  std::string options_file_;
  bool no_scorer_ = false;
  std::set<std::string> skip_;
};

}  // namespace furn

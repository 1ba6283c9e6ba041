// Where the project's data (class_map.json, tuning spaces, the real set's
// labels) is found at run time, never through a path compiled in: the
// FURN_DATA_DIR environment variable, else `share/furnidet/data` in the
// folder of the program or library holding this code or in one of its
// parents (an installed tree: <prefix>/bin/workbench, <prefix>/lib/
// libfurnidet.so and <prefix>/lib/python3.x/dist-packages/furnidet/ all
// reach <prefix>/share/furnidet/data; a build tree holds a link
// <build>/share/furnidet/data to the source's data/).
//
//   CatalogOpenOptions options;            // options.data_dir = DefaultDataDir()
//   const std::string dir = DefaultDataDir();
#pragma once

#include <string>

namespace furn {

// The data folder as above, or "" when there is none (the message of a
// command that needs it says to set FURN_DATA_DIR or --data-dir).
std::string DefaultDataDir();

// The file (executable or shared library) this code was loaded from.
std::string LoadedFromPath();

}  // namespace furn

#include "core/util/data_dir.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace furn {

std::string LoadedFromPath() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&LoadedFromPath), &info) == 0 || info.dli_fname == nullptr)
    return "";
  std::error_code error;
  // The main program reports the name it was started by: made absolute here.
  const std::filesystem::path path =
      std::filesystem::weakly_canonical(std::filesystem::path(info.dli_fname), error);
  if (!error && std::filesystem::exists(path, error)) return path.string();
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::string() : self.string();
}

std::string DefaultDataDir() {
  if (const char* env = std::getenv("FURN_DATA_DIR"); env != nullptr && *env != '\0') return env;
  const std::string loaded = LoadedFromPath();
  if (loaded.empty()) return "";
  std::error_code error;
  std::filesystem::path dir = std::filesystem::path(loaded).parent_path();
  for (int level = 0; level < 6 && !dir.empty(); ++level) {
    const std::filesystem::path data = dir / "share" / "furnidet" / "data";
    if (std::filesystem::is_regular_file(data / "class_map.json", error)) return data.string();
    if (dir == dir.parent_path()) break;
    dir = dir.parent_path();
  }
  return "";
}

}  // namespace furn

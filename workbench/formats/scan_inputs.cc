#include "workbench/formats/scan_inputs.h"

#include <glob.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

bool IsDepthFile(const std::string& path) {
  const ScanKind* kind = KindOfFile(path);
  return kind != nullptr && kind->path == &ScanSource::depth_path;
}

// ".pcd, .ply, .png, ...": every extension that names a scan.
std::string ScanExtensions() {
  std::string text;
  for (const ScanKind& kind : ScanKinds()) {
    for (const std::string& e : kind.extensions) text += (text.empty() ? "." : ", .") + e;
  }
  return text;
}

ScanSource SourceOfFile(const std::string& path, const ScanSource& common) {
  const ScanKind* kind = KindOfFile(path);
  if (!kind) {
    throw InputError(path + ": not a scan (" + ScanExtensions() +
                     "), TUM list (.txt), BOP folder or glob pattern");
  }
  ScanSource source = WithoutScan(common);
  source.*kind->path = path;
  return source;
}

// The depth images of one BOP scene folder, by image id.
void AddBopScene(const std::filesystem::path& scene,
                 const ScanSource& common,
                 std::vector<ScanSource>* out) {
  std::vector<std::filesystem::path> images;
  for (const auto& entry : std::filesystem::directory_iterator(scene / "depth")) {
    if (entry.is_regular_file() && IsDepthFile(entry.path().string()))
      images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  for (const std::filesystem::path& image : images) {
    ScanSource source = SourceOfFile(image.string(), common);
    if (source.camera_file.empty()) source.camera_file = (scene / "scene_camera.json").string();
    out->push_back(source);
  }
}

bool IsBopScene(const std::filesystem::path& dir) {
  return std::filesystem::is_regular_file(dir / "scene_camera.json") &&
         std::filesystem::is_directory(dir / "depth");
}

// Depth images of a TUM RGB-D list: depth.txt ("timestamp path") or
// associate.py's output ("timestamp path timestamp path"), the path naming
// depth (or the only one) taken; '#' lines are comments.
void AddTumList(const std::string& list, const ScanSource& common, std::vector<ScanSource>* out) {
  RequireRegularFile(list);
  std::ifstream in(list);
  Require(in.good(), list + ": cannot read the TUM list");
  const std::filesystem::path base = std::filesystem::path(list).parent_path();
  std::string line;
  int number = 0;
  const size_t before = out->size();
  while (std::getline(in, line)) {
    ++number;
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string t; fields >> t;) tokens.push_back(t);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    std::string depth;
    for (size_t k = 1; k < tokens.size(); k += 2) {
      if (tokens[k].find("depth") != std::string::npos || tokens.size() == 2) depth = tokens[k];
    }
    Require(!depth.empty() && (tokens.size() == 2 || tokens.size() == 4),
            list + ":" + std::to_string(number) +
                ": a TUM list line is 'timestamp depth/x.png' or 'timestamp rgb/x.png "
                "timestamp depth/y.png'");
    // Whatever the line names is its depth image: a directory or a file of
    // another kind fails as that scan's own line, and the others go on.
    ScanSource source = WithoutScan(common);
    source.depth_path = (base / depth).string();
    out->push_back(source);
  }
  Require(out->size() > before, list + ": the TUM list names no depth image");
}

}  // namespace

std::vector<ScanSource> ExpandScanInputs(const std::vector<std::string>& inputs,
                                         const ScanSource& common,
                                         bool intrinsics_given,
                                         bool depth_scale_given) {
  std::vector<ScanSource> sources;
  for (const std::string& input : inputs) {
    if (input.find_first_of("*?[") != std::string::npos) {
      glob_t matches{};
      const int status = glob(input.c_str(), 0, nullptr, &matches);
      std::vector<std::string> paths(matches.gl_pathv, matches.gl_pathv + matches.gl_pathc);
      globfree(&matches);
      Require(status == 0 && !paths.empty(), "'" + input + "' matches no file");
      std::sort(paths.begin(), paths.end());
      for (const std::string& path : paths) sources.push_back(SourceOfFile(path, common));
    } else if (std::filesystem::is_directory(input)) {
      const std::filesystem::path dir(input);
      if (IsBopScene(dir)) {
        AddBopScene(dir, common, &sources);
        continue;
      }
      std::vector<std::filesystem::path> scenes;
      for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (entry.is_directory() && IsBopScene(entry.path())) scenes.push_back(entry.path());
      }
      Require(!scenes.empty(),
              input +
                  ": a folder input must be a BOP scene (depth/ and scene_camera.json) or "
                  "a BOP split of such scenes");
      std::sort(scenes.begin(), scenes.end());
      for (const std::filesystem::path& scene : scenes) AddBopScene(scene, common, &sources);
    } else if (FileExtension(input) == "txt") {
      ScanSource tum = common;
      if (!intrinsics_given) tum.intrinsics = "525,525,319.5,239.5";
      if (!depth_scale_given) tum.depth_scale = 5000;
      AddTumList(input, tum, &sources);
    } else {
      sources.push_back(SourceOfFile(input, common));
    }
  }
  return sources;
}

}  // namespace furn

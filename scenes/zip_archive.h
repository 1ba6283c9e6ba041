// Read-only access to a zip file (libzip), with errors that name the archive.
// Safe to use from several threads.
// Used for Sweet Home 3D .sh3f catalogs, which are zips of OBJ/MTL files and
// a PluginFurnitureCatalog.properties.
//
//   ZipArchive zip("/usr/share/sweethome3d/furniture/Scopia.sh3f");
//   if (zip.Contains("PluginFurnitureCatalog.properties")) {
//     std::string text = zip.Read("PluginFurnitureCatalog.properties");
//   }
#pragma once

#include <memory>
#include <string>

namespace furn {

class ZipArchive {
 public:
  // Throws InputError "<path>: not a readable zip archive (<libzip reason>)".
  explicit ZipArchive(const std::string& path);
  ~ZipArchive();
  ZipArchive(const ZipArchive&) = delete;
  ZipArchive& operator=(const ZipArchive&) = delete;

  const std::string& path() const { return path_; }
  bool Contains(const std::string& name) const;
  // Whole entry; throws InputError naming archive and entry when it is missing
  // or its data is corrupt (CRC, truncated).
  std::string Read(const std::string& name) const;
  // 32 hex digits over the name, size and CRC-32 of every entry whose name
  // starts with `prefix` ("" : all), from the central directory: what the
  // entries hold, without reading them.
  std::string EntriesDigest(const std::string& prefix) const;

 private:
  struct Handle;
  std::string path_;
  std::unique_ptr<Handle> handle_;
};

}  // namespace furn

#include "scenes/sh3f_catalog.h"

#include <gtest/gtest.h>

#include <zip.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <utility>
#include <vector>

#include "core/util/text.h"

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "scenes/catalog.h"
#include "scenes/java_properties.h"
#include "scenes/mesh_io.h"
#include "scenes/zip_archive.h"
#include "tests/scenes/fixtures.h"
#include "tests/test_util.h"

namespace furn {
namespace {

using testing::ErrorOf;

TEST(JavaProperties, FollowsJavaRules) {
  const auto p = ParseJavaProperties(
      "# comment\n! other comment\n  key1 = value one  \nkey2:two\nkey3 three\n"
      "multi=a \\\n    b\\\n  c\nescaped\\=key=\\u00e9t\\u00e9\\ttab\nempty=\n"
      "windows=yes\r\nlast=no newline");
  EXPECT_EQ(p.at("key1"), "value one  ");
  EXPECT_EQ(p.at("key2"), "two");
  EXPECT_EQ(p.at("key3"), "three");
  EXPECT_EQ(p.at("multi"), "a bc");
  EXPECT_EQ(p.at("escaped=key"), "\xC3\xA9t\xC3\xA9\ttab");
  EXPECT_EQ(p.at("empty"), "");
  EXPECT_EQ(p.at("windows"), "yes");
  EXPECT_EQ(p.at("last"), "no newline");
  EXPECT_EQ(p.size(), 8u);
}

TEST(JavaProperties, Latin1IsConvertedToUtf8) {
  const auto p = ParseJavaProperties("name=Caf\xE9\n");
  EXPECT_EQ(p.at("name"), "Caf\xC3\xA9");
  const auto q = ParseJavaProperties("name=Caf\xC3\xA9\n");  // already UTF-8
  EXPECT_EQ(q.at("name"), "Caf\xC3\xA9");
}

// Java writes a code point above U+FFFF as a UTF-16 surrogate pair of
// escapes: one code point, valid UTF-8 (issue 68: it was decoded half by half
// into CESU-8, which JSON output then refused). A lone half is U+FFFD.
TEST(JavaProperties, SurrogatePairsAreOneCodePoint) {
  const auto p = ParseJavaProperties("id=emoji/chair\\uD83D\\uDE00\nlone=a\\uD83Db\nlow=\\uDE00\n");
  EXPECT_EQ(p.at("id"), "emoji/chair\U0001F600");
  EXPECT_EQ(p.at("lone"),
            "a\xEF\xBF\xBD"
            "b");
  EXPECT_EQ(p.at("low"), "\xEF\xBF\xBD");
  for (const auto& [key, value] : p) EXPECT_TRUE(IsValidUtf8(value)) << key;
}

TEST(Sh3f, ReadsEntriesAndReportsBadOnes) {
  const std::string path = testing::WriteTestSh3f(testing::ScratchDir(), "Test.sh3f");
  const Sh3fCatalog catalog(path);
  EXPECT_EQ(catalog.stem(), "Test");
  ASSERT_EQ(catalog.entries().size(), 3u);
  const Sh3fEntry* marker = catalog.Find("Test/marker");
  ASSERT_NE(marker, nullptr);
  EXPECT_EQ(marker->name, "Chaise \xC3\xA9l\xC3\xA9gante");
  EXPECT_EQ(marker->sh3d_id, "Test#marker");
  EXPECT_EQ(marker->model_path, "marker/marker.obj");
  EXPECT_FLOAT_EQ(marker->depth_cm, 60);
  EXPECT_FLOAT_EQ(marker->height_cm, 100);
  EXPECT_EQ(catalog.Find("Test/rotated")->name, "Rotated marker");
  ASSERT_EQ(catalog.problems().size(), 1u);
  EXPECT_NE(catalog.problems()[0].find("width#4 'abc' is not a number"), std::string::npos)
      << catalog.problems()[0];
}

TEST(Sh3f, ImportsWithCatalogScaleAndOrientation) {
  const std::string path = testing::WriteTestSh3f(testing::ScratchDir(), "Test.sh3f");
  const Sh3fCatalog catalog(path);
  const CadModel marker = catalog.LoadModel(*catalog.Find("Test/marker"));
  testing::ExpectMarkerPose(marker.mesh, Eigen::Vector3f(0.4f, 0.6f, 1.0f), 1e-5f);
  EXPECT_EQ(marker.source_path, path + "!/marker/marker.obj");
  EXPECT_EQ(marker.content_hash, HashMesh(marker.mesh));
}

TEST(Sh3f, AppliesModelRotationBeforeScaling) {
  const std::string path = testing::WriteTestSh3f(testing::ScratchDir(), "Test.sh3f");
  const Sh3fCatalog catalog(path);
  const CadModel rotated = catalog.LoadModel(*catalog.Find("Test/rotated"));
  testing::ExpectMarkerPose(rotated.mesh, Eigen::Vector3f(0.8f, 1.2f, 2.0f), 1e-5f);
}

TEST(Sh3f, EntryWithMissingModelIsReportedAndSkipped) {
  const std::string dir = testing::ScratchDir();
  const std::string path = testing::WriteTestSh3f(dir, "Test.sh3f");
  const Catalog catalog = OpenCatalog(path);
  const LoadedModels loaded = catalog.LoadModels({"Test/marker", "Test/missing", "Test/rotated"});
  ASSERT_EQ(loaded.models.size(), 2u);
  EXPECT_EQ(loaded.models[0].id, "Test/marker");
  EXPECT_EQ(loaded.models[1].id, "Test/rotated");
  ASSERT_EQ(loaded.failures.size(), 1u);
  EXPECT_EQ(loaded.failures[0].id, "Test/missing");
  EXPECT_THROW(loaded.RequireAll(), InputError);
  EXPECT_NO_THROW(catalog.LoadModels({"Test/marker"}, false).RequireAll());
  EXPECT_NE(loaded.failures[0].message.find("Test/missing"), std::string::npos);
  EXPECT_NE(loaded.failures[0].message.find("missing/missing.obj: no such entry"),
            std::string::npos)
      << loaded.failures[0].message;
}

TEST(Sh3f, MissingFileIsNamed) {
  EXPECT_EQ(ErrorOf([] { Sh3fCatalog("/nonexistent/Scopia.sh3f"); }),
            "/nonexistent/Scopia.sh3f: file does not exist");
}

TEST(Sh3f, CorruptZipIsRejected) {
  const std::string path = testing::ScratchDir() + "/corrupt.sh3f";
  testing::WriteText(path, std::string(4096, 'x'));
  const std::string message = ErrorOf([&] { Sh3fCatalog catalog(path); });
  EXPECT_NE(message.find(path + ": not a readable zip archive"), std::string::npos) << message;
}

TEST(Sh3f, TruncatedZipIsRejected) {
  const std::string dir = testing::ScratchDir();
  const std::string bytes = ReadFileBytes(testing::WriteTestSh3f(dir, "Test.sh3f"));
  const std::string path = dir + "/truncated.sh3f";
  testing::WriteText(path, bytes.substr(0, bytes.size() * 2 / 3));
  const std::string message = ErrorOf([&] { Sh3fCatalog catalog(path); });
  EXPECT_NE(message.find(path + ": not a readable zip archive"), std::string::npos) << message;
}

TEST(Sh3f, CorruptEntryDataFailsThatModelOnly) {
  const std::string dir = testing::ScratchDir();
  std::string bytes = ReadFileBytes(testing::WriteTestSh3f(dir, "Test.sh3f"));
  // marker.obj is stored uncompressed: damage its text so the CRC no longer
  // matches.
  const size_t at = bytes.find("mtllib marker.mtl");
  ASSERT_NE(at, std::string::npos);
  bytes[at + 20] ^= 0x55;
  const std::string path = dir + "/damaged.sh3f";
  testing::WriteText(path, bytes);
  const Sh3fCatalog catalog(path);
  const std::string message = ErrorOf([&] { catalog.LoadModel(*catalog.Find("damaged/marker")); });
  EXPECT_NE(message.find("corrupt entry"), std::string::npos) << message;
  EXPECT_NO_THROW(catalog.LoadModel(*catalog.Find("damaged/rotated")));
}

// Sets FURN_MESH_CACHE for one test.
class MeshCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::ScratchDir();
    setenv("FURN_MESH_CACHE", (dir_ + "/cache").c_str(), 1);
  }
  void TearDown() override { setenv("FURN_MESH_CACHE", "off", 1); }
  size_t CachedFiles() const {
    if (!std::filesystem::exists(dir_ + "/cache")) return 0;
    return std::distance(std::filesystem::directory_iterator(dir_ + "/cache"),
                         std::filesystem::directory_iterator());
  }
  std::string dir_;
};

TEST_F(MeshCacheTest, SecondImportComesFromTheCacheUntilTheArchiveChanges) {
  std::string bytes = ReadFileBytes(testing::WriteTestSh3f(dir_, "Test.sh3f"));
  const std::string path = dir_ + "/Cached.sh3f";
  testing::WriteText(path, bytes);
  const auto written = std::filesystem::last_write_time(path);
  CadModel first;
  {
    const Sh3fCatalog catalog(path);
    first = catalog.LoadModel(*catalog.Find("Cached/marker"));
  }
  EXPECT_EQ(CachedFiles(), 1u);

  // Damage the model's bytes in place, its CRC left as it was: the archive
  // still says it holds the same entry, so only a cache hit gives the mesh.
  const size_t at = bytes.find("mtllib marker.mtl");
  ASSERT_NE(at, std::string::npos);
  std::string damaged = bytes;
  damaged[at + 20] ^= 0x55;
  testing::WriteText(path, damaged);
  {
    const Sh3fCatalog catalog(path);
    const CadModel again = catalog.LoadModel(*catalog.Find("Cached/marker"));
    EXPECT_EQ(again.content_hash, first.content_hash);
    EXPECT_EQ(again.mesh.vertices, first.mesh.vertices);
    EXPECT_EQ(again.mesh.triangles, first.mesh.triangles);
  }
  EXPECT_EQ(CachedFiles(), 1u);

  // Another archive of the same size and modification time whose model
  // differs (two vertex lines swapped): imported afresh.
  const std::string original = dir_ + "/original.sh3f";
  testing::WriteText(original, bytes);
  const ZipArchive zip(original);
  std::map<std::string, std::string> files;
  for (const char* name : {"PluginFurnitureCatalog.properties",
                           "marker/marker.obj",
                           "marker/marker.mtl",
                           "rotated/rotated.obj"})
    files[name] = zip.Read(name);
  std::string& obj = files["marker/marker.obj"];
  std::vector<std::pair<size_t, size_t>> lines;  // offset, length of each "v" line
  for (size_t at = obj.find("\nv "); at != std::string::npos; at = obj.find("\nv ", at + 1))
    lines.emplace_back(at + 1, obj.find('\n', at + 1) - at - 1);
  bool swapped = false;
  for (size_t a = 0; a < lines.size() && !swapped; ++a) {
    for (size_t b = a + 1; b < lines.size() && !swapped; ++b) {
      const std::string first_line = obj.substr(lines[a].first, lines[a].second);
      const std::string second_line = obj.substr(lines[b].first, lines[b].second);
      if (first_line.size() != second_line.size() || first_line == second_line) continue;
      obj.replace(lines[a].first, first_line.size(), second_line);
      obj.replace(lines[b].first, second_line.size(), first_line);
      swapped = true;
    }
  }
  ASSERT_TRUE(swapped);
  testing::WriteZip(path, files, {"marker/marker.obj"});
  ASSERT_EQ(std::filesystem::file_size(path), bytes.size());
  std::filesystem::last_write_time(path, written);
  {
    const Sh3fCatalog catalog(path);
    const CadModel replaced = catalog.LoadModel(*catalog.Find("Cached/marker"));
    EXPECT_NE(replaced.content_hash, first.content_hash);
  }
  EXPECT_EQ(CachedFiles(), 2u);

  // A copy of the first archive elsewhere shares its cache entry.
  const std::string copy = dir_ + "/copy/Cached.sh3f";
  std::filesystem::create_directories(dir_ + "/copy");
  testing::WriteText(copy, bytes);
  const Sh3fCatalog copied(copy);
  EXPECT_EQ(copied.LoadModel(*copied.Find("Cached/marker")).content_hash, first.content_hash);
  EXPECT_EQ(CachedFiles(), 2u);
}

TEST_F(MeshCacheTest, DamagedCacheFilesAreIgnoredAndRewritten) {
  const std::string path = testing::WriteTestSh3f(dir_, "Test.sh3f");
  const CadModel first = Sh3fCatalog(path).LoadModel(*Sh3fCatalog(path).Find("Test/marker"));
  ASSERT_EQ(CachedFiles(), 1u);
  const std::string file = std::filesystem::directory_iterator(dir_ + "/cache")->path().string();
  const std::string good = ReadFileBytes(file);
  for (const std::string& damaged : {good.substr(0, good.size() / 2),  // truncated
                                     std::string(good).replace(good.size() - 3, 1, "\x7f"),
                                     std::string("not a mesh")}) {
    testing::WriteText(file, damaged);
    const Sh3fCatalog catalog(path);
    const CadModel again = catalog.LoadModel(*catalog.Find("Test/marker"));
    EXPECT_EQ(again.content_hash, first.content_hash);
    EXPECT_EQ(ReadFileBytes(file), good);  // rewritten
  }
  setenv("FURN_MESH_CACHE", "off", 1);
  EXPECT_FALSE(MeshCache::FromEnvironment().enabled());
}

TEST(Sh3f, ArchiveWithoutPropertiesIsRejected) {
  const std::string path = testing::ScratchDir() + "/plain.sh3f";
  testing::WriteZip(path, {{"readme.txt", "hello"}});
  const std::string message = ErrorOf([&] { Sh3fCatalog catalog(path); });
  EXPECT_NE(message.find("no PluginFurnitureCatalog.properties"), std::string::npos) << message;
}

TEST(Sh3f, PropertiesWithoutModelsAreRejected) {
  const std::string path = testing::ScratchDir() + "/empty.sh3f";
  testing::WriteZip(path,
                    {{"PluginFurnitureCatalog.properties", "id=X\nname=Nothing here\nname#1=A\n"}});
  const std::string message = ErrorOf([&] { Sh3fCatalog catalog(path); });
  EXPECT_NE(message.find("declares no usable models"), std::string::npos) << message;
  // An entry that is there but bad: the reason, not just "no models".
  const std::string bad = testing::ScratchDir() + "/bad.sh3f";
  testing::WriteZip(bad,
                    {{"PluginFurnitureCatalog.properties",
                      "id#1=X#a\nname#1=A\nmodel#1=/a.obj\nwidth#1=abc\ndepth#1=50\nheight#1=80\n"},
                     {"a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"}});
  const std::string reason = ErrorOf([&] { Sh3fCatalog catalog(bad); });
  EXPECT_NE(reason.find("width#1 'abc' is not a number"), std::string::npos) << reason;
}

TEST(Sh3f, FlatModelCannotBeScaled) {
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
  flat.triangles = {{0, 1, 2}};
  const std::string message = ErrorOf([&] {
    NormalizeSweetHome3dMesh(flat, Eigen::Matrix3f::Identity(), 10, 10, 10, "flat entry");
  });
  EXPECT_NE(message.find("flat entry: model is flat along its height"), std::string::npos)
      << message;
}

// An MTL statement before any newmtl crashed assimp (tests/data/crashers):
// such statements belong to no material and are dropped; the model loads.
TEST(Sh3f, MtlStatementsBeforeNewmtlAreDroppedNotACrash) {
  EXPECT_EQ(SanitizeMtl("map_Kd t.jpg\nKd 1 0 0\n# note\nnewmtl a\nKd 0 1 0\n\nnewmtl b\nNs 3"),
            "# note\nnewmtl a\nKd 0 1 0\n\nnewmtl b\nNs 3");
  EXPECT_EQ(SanitizeMtl(""), "");
  const Catalog catalog =
      OpenCatalog(FURN_SOURCE_DIR "/tests/data/crashers/manual_mtl_map_before_newmtl.sh3f");
  LoadedModels loaded = catalog.LoadModels({"manual_mtl_map_before_newmtl/box"}, false);
  loaded.RequireAll();
  EXPECT_EQ(loaded.models[0].mesh.NumTriangles(), 4u);
}

// A zip entry whose declared size is forged, or that inflates beyond what
// deflate can: refused before anything is allocated for it.
TEST(ZipArchive, ForgedSizesAndBombsAreRefusedBeforeAllocating) {
  const std::string dir = testing::ScratchDir();
  const std::string path = dir + "/small.zip";
  {
    int error = 0;
    zip_t* zip = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &error);
    ASSERT_NE(zip, nullptr);
    static const std::string text(4000, 'a');
    zip_source_t* source = zip_source_buffer(zip, text.data(), text.size(), 0);
    ASSERT_GE(zip_file_add(zip, "a.txt", source, ZIP_FL_OVERWRITE), 0);
    ASSERT_EQ(zip_close(zip), 0);
  }
  EXPECT_EQ(ZipArchive(path).Read("a.txt").size(), 4000u);
  // The uncompressed size in the local and central headers, set to `size`.
  auto forged = [&](uint32_t size) {
    std::string bytes = ReadFileBytes(path);
    for (const auto& [signature, offset] :
         std::vector<std::pair<std::string, size_t>>{{"PK\x03\x04", 22}, {"PK\x01\x02", 24}}) {
      const size_t at = bytes.find(signature);
      EXPECT_NE(at, std::string::npos);
      std::memcpy(&bytes[at + offset], &size, sizeof(size));
    }
    const std::string out = dir + "/forged-" + std::to_string(size) + ".zip";
    testing::WriteText(out, bytes);
    return out;
  };
  EXPECT_NE(ErrorOf([&] {
              ZipArchive(forged(0xFFFFFFF0u)).Read("a.txt");
            }).find("larger than the 512 MiB"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              ZipArchive(forged(200u << 20)).Read("a.txt");
            }).find("beyond what deflate can"),
            std::string::npos);
}

}  // namespace
}  // namespace furn

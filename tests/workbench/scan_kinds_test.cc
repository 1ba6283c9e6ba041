// The scan-kind table: every kind of scan a ScanSource names, found by its
// field and by its files' extensions, and the rules LoadScan reads from it.
#include <gtest/gtest.h>

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "tests/test_util.h"
#include "workbench/formats/scan_file.h"
#include "workbench/formats/scan_inputs.h"

namespace furn {
namespace {

// `action` throws an InputError whose message holds `text`.
::testing::AssertionResult Refused(const std::function<void()>& action, const std::string& text) {
  const std::string message = testing::ErrorOf(action);
  if (message.find(text) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "the message was: " << message;
}

TEST(ScanKinds, EachKindHasItsOwnFlagFieldAndExtensions) {
  std::set<std::string> flags, extensions;
  std::vector<std::string ScanSource::*> fields;
  for (const ScanKind& kind : ScanKinds()) {
    EXPECT_TRUE(flags.insert(kind.flag).second) << kind.flag;
    for (std::string ScanSource::*other : fields) EXPECT_NE(other, kind.path) << kind.name;
    fields.push_back(kind.path);
    EXPECT_NE(kind.load, nullptr) << kind.name;
    for (const std::string& e : kind.extensions) {
      EXPECT_TRUE(extensions.insert(e).second) << e;
      EXPECT_EQ(KindOfFile("scan." + e), &kind) << e;
    }
    ScanSource source;
    source.*kind.path = "scan";
    EXPECT_EQ(&KindOf(source), &kind);
    EXPECT_TRUE(NamesAScan(source));
    EXPECT_FALSE(NamesAScan(WithoutScan(source)));
    EXPECT_EQ(ScanSourceName(source).rfind("scan", 0), 0u) << kind.name;
  }
  EXPECT_EQ(KindOfFile("scan.PCD"), KindOfFile("scan.pcd"));  // extensions ignore case
  EXPECT_EQ(KindOfFile("notes.txt"), nullptr);
}

TEST(ScanKinds, NoneOrTwoScansAreRefusedNamingEveryFlag) {
  ScanSource none;
  EXPECT_FALSE(NamesAScan(none));
  EXPECT_TRUE(Refused([&] { KindOf(none); }, "give exactly one of --cloud, --depth or --db"));
  ScanSource two;
  two.cloud_path = "a.pcd";
  two.depth_path = "a.png";
  EXPECT_TRUE(Refused([&] { LoadScan(two); }, "give exactly one of --cloud, --depth or --db"));
}

TEST(ScanKinds, PoseOptionsOnlyWhereTheKindTakesThem) {
  ScanSource frame;
  frame.db_path = "rooms.db";
  frame.frame_id = 0;
  frame.floor_aligned = true;
  EXPECT_TRUE(Refused([&] { LoadScan(frame); },
                      "--world-from-camera applies to --cloud or --depth scans, not --db"));
  ScanSource depth;
  depth.depth_path = "a.png";
  depth.sensor = "0,0,1";
  EXPECT_TRUE(Refused([&] { LoadScan(depth); }, "--sensor applies to point clouds"));
}

TEST(ScanKinds, InputFilesOfNoKindNameTheKnownExtensions) {
  EXPECT_TRUE(Refused([&] { ExpandScanInputs({"notes.csv"}, ScanSource{}, false, false); },
                      "not a scan (.pcd, .ply, .png, .tif, .tiff, .exr)"));
}

}  // namespace
}  // namespace furn

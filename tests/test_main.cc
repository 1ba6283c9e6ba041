// GoogleTest main shared by every test binary: before each test it reseeds the
// C library generator, so no test depends on the order tests run in. Tests
// take their randomness from furn::Rng with fixed seeds. The mesh cache is off
// (tests that exercise it set FURN_MESH_CACHE themselves), so tests neither
// read nor fill the user's cache.
#include <gtest/gtest.h>

#include <cstdlib>

namespace {

class ReseedListener : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo& /*info*/) override { std::srand(1); }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  setenv("FURN_MESH_CACHE", "off", 1);
  ::testing::UnitTest::GetInstance()->listeners().Append(new ReseedListener);
  return RUN_ALL_TESTS();
}

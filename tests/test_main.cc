// GoogleTest main shared by every test binary: before each test it reseeds the
// C library generator, so no test depends on the order tests run in. Tests
// take their randomness from furn::Rng with fixed seeds.
#include <gtest/gtest.h>

#include <cstdlib>

namespace {

class ReseedListener : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo& /*info*/) override { std::srand(1); }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::UnitTest::GetInstance()->listeners().Append(new ReseedListener);
  return RUN_ALL_TESTS();
}

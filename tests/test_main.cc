// GoogleTest main shared by every test binary: before each test it reseeds the
// C library generator, so no test depends on the order tests run in. Tests
// take their randomness from furn::Rng with fixed seeds. The mesh cache is off
// (tests that exercise it set FURN_MESH_CACHE themselves), so tests neither
// read nor fill the user's cache.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace {

class ReseedListener : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo& /*info*/) override { std::srand(1); }
};

// The ISA variants of the renderer, generate and evaluate tests force Embree
// onto a narrower instruction set (FURN_EMBREE_CONFIG=isa=...). On a CPU
// without that set they are skipped, not crashed with an illegal instruction.
class ForcedIsaEnvironment : public ::testing::Environment {
  void SetUp() override {
    const char* config = std::getenv("FURN_EMBREE_CONFIG");
    if (config == nullptr) return;
    const std::string text = config;
    __builtin_cpu_init();
    if (text.find("isa=avx2") != std::string::npos && !__builtin_cpu_supports("avx2"))
      GTEST_SKIP() << "this CPU has no AVX2 for FURN_EMBREE_CONFIG=" << text;
    if (text.find("isa=avx512") != std::string::npos && !__builtin_cpu_supports("avx512f"))
      GTEST_SKIP() << "this CPU has no AVX-512 for FURN_EMBREE_CONFIG=" << text;
    if (text.find("isa=sse4.2") != std::string::npos && !__builtin_cpu_supports("sse4.2"))
      GTEST_SKIP() << "this CPU has no SSE4.2 for FURN_EMBREE_CONFIG=" << text;
  }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  setenv("FURN_MESH_CACHE", "off", 1);
  ::testing::UnitTest::GetInstance()->listeners().Append(new ReseedListener);
  ::testing::AddGlobalTestEnvironment(new ForcedIsaEnvironment);
  return RUN_ALL_TESTS();
}

// GoogleTest main shared by every test binary: before each test it reseeds the
// C library generator, so no test depends on the order tests run in. Tests
// take their randomness from furn::Rng with fixed seeds. The mesh cache is off
// (tests that exercise it set FURN_MESH_CACHE themselves), so tests neither
// read nor fill the user's cache. The vote network computes in float unless
// FURN_NETWORK_PRECISION is set (vote_net.h).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/learned/vote_net.h"
#include "core/util/leak_suppressions.h"

namespace {

class ReseedListener : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo& /*info*/) override { std::srand(1); }
};

// The ISA variants of the renderer, generate and evaluate tests force Embree
// onto a narrower instruction set (FURN_EMBREE_CONFIG=isa=...), those of the
// vote-net tests libtorch (FURN_TORCH_ISA=avx2, ForceTorchIsa). On a CPU
// without that set they are skipped, not crashed with an illegal instruction.
class ForcedIsaEnvironment : public ::testing::Environment {
  void SetUp() override {
    __builtin_cpu_init();
    if (const char* torch = std::getenv("FURN_TORCH_ISA");
        torch != nullptr && !__builtin_cpu_supports("avx2"))
      GTEST_SKIP() << "this CPU lacks the ISA of FURN_TORCH_ISA=" << torch;
    if (const char* precision = std::getenv("FURN_NETWORK_PRECISION");
        precision != nullptr && std::string(precision) == "bf16" && !furn::CpuHasBf16())
      GTEST_SKIP() << "this CPU has no bfloat16 instructions (FURN_NETWORK_PRECISION=bf16)";
    const char* config = std::getenv("FURN_EMBREE_CONFIG");
    if (config == nullptr) return;
    const std::string text = config;
    const bool cpu_has[] = {__builtin_cpu_supports("avx2") != 0,
                            __builtin_cpu_supports("avx512f") != 0,
                            __builtin_cpu_supports("sse4.2") != 0};
    const char* const isas[] = {"isa=avx2", "isa=avx512", "isa=sse4.2"};
    for (int k = 0; k < 3; ++k) {
      if (text.find(isas[k]) != std::string::npos && !cpu_has[k])
        GTEST_SKIP() << "this CPU lacks the ISA of FURN_EMBREE_CONFIG=" << text;
    }
  }
};

// FURN_TORCH_ISA=avx2 (the [torch-avx2] variants): libtorch's and oneDNN's
// kernels capped at AVX2 before either first runs, so a machine with AVX-512
// also tests the path most CPUs take. False for another value.
bool ForceTorchIsa() {
  const char* isa = std::getenv("FURN_TORCH_ISA");
  if (isa == nullptr) return true;
  if (std::string(isa) != "avx2") return false;
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("avx2")) return true;  // ForcedIsaEnvironment skips
  setenv("ATEN_CPU_CAPABILITY", "avx2", 1);
  setenv("DNNL_MAX_CPU_ISA", "AVX2", 1);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  if (!ForceTorchIsa()) {
    std::fprintf(stderr, "FURN_TORCH_ISA='%s' must be avx2\n", std::getenv("FURN_TORCH_ISA"));
    return 2;
  }
  setenv("FURN_MESH_CACHE", "off", 1);
  // The network's reference arithmetic on every machine (auto would be
  // bfloat16 on a CPU with AMX-BF16): the tests of bfloat16 ask for it, and
  // the [bf16] variants set FURN_NETWORK_PRECISION=bf16 themselves.
  setenv("FURN_NETWORK_PRECISION", "fp32", 0);
  ::testing::UnitTest::GetInstance()->listeners().Append(new ReseedListener);
  ::testing::AddGlobalTestEnvironment(new ForcedIsaEnvironment);
  return RUN_ALL_TESTS();
}

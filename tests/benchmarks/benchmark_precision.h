// The vote network's arithmetic as a benchmark argument (detect_benchmark,
// train_benchmark): 1 bfloat16, 0 float.
#pragma once

#include <benchmark/benchmark.h>

#include <cstdint>
#include <optional>

#include "core/learned/vote_net.h"

namespace furn {

// The precision `bf16_arg` names, or none with the benchmark skipped on a
// CPU without bfloat16 instructions.
inline std::optional<NetworkPrecision> BenchmarkPrecision(int64_t bf16_arg,
                                                          benchmark::State* state) {
  if (bf16_arg == 0) return NetworkPrecision::kFloat32;
  if (!CpuHasBf16()) {
    state->SkipWithError("this CPU has no bfloat16 instructions");
    return std::nullopt;
  }
  return NetworkPrecision::kBfloat16;
}

}  // namespace furn

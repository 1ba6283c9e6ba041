// Deterministic random numbers. Every random choice in the engine takes an Rng
// passed in (no global generator). The engine (std::mt19937_64) is specified by
// the C++ standard, and the conversions below are ours, so a seed gives the
// same numbers with every compiler and standard library.
//
//   Rng rng(DeriveSeed(master_seed, room_index));   // independent stream per
//   room double x = rng.Uniform(0.4, 0.5); int k = rng.UniformInt(0, 3); // 0,
//   1, 2 or 3
#pragma once

#include <cstdint>
#include <random>

namespace furn {

// SplitMix64 of (seed, stream): well-separated sub-seeds, so part k of a job
// gives the same result whether run alone, in a batch or in a shard.
inline uint64_t DeriveSeed(uint64_t seed, uint64_t stream) {
  uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}

  uint64_t Next() { return engine_(); }

  // Uniform in [0, 1) with 53 random bits.
  double Uniform01() {
    return static_cast<double>(engine_() >> 11) * 0x1.0p-53;
  }

  // Uniform in [low, high).
  double Uniform(double low, double high) {
    return low + (high - low) * Uniform01();
  }

  // Uniform integer in [low, high] (both inclusive), without modulo bias.
  int64_t UniformInt(int64_t low, int64_t high) {
    const uint64_t span = static_cast<uint64_t>(high - low) + 1;
    if (span == 0) return static_cast<int64_t>(engine_());
    const uint64_t limit = UINT64_MAX - UINT64_MAX % span;
    uint64_t x;
    do {
      x = engine_();
    } while (x >= limit);
    return low + static_cast<int64_t>(x % span);
  }

  bool Bernoulli(double p) { return Uniform01() < p; }

  std::mt19937_64& engine() { return engine_; }

 private:
  std::mt19937_64 engine_;
};

}  // namespace furn

// Deterministic random numbers. Every random choice in the engine takes an Rng
// passed in (no global generator). The engine (std::mt19937_64) is specified by
// the C++ standard, and the conversions below are ours, so a seed gives the
// same numbers with every compiler and standard library.
//
//   Rng rng(DeriveSeed(master_seed, room_index));   // independent stream per
//   room double x = rng.Uniform(0.4, 0.5); int k = rng.UniformInt(0, 3); // 0,
//   1, 2 or 3
#pragma once

#include <cmath>
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
  double Uniform01() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  // Uniform in [low, high).
  double Uniform(double low, double high) { return low + (high - low) * Uniform01(); }

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

// A small fast generator for per-pixel noise (xoshiro256**, Blackman and
// Vigna 2018, seeded through SplitMix64) with a Marsaglia polar normal
// sampler. Use one per image row, seeded by DeriveSeed(frame_seed, row), so the
// result does not depend on how rows are spread over threads.
class FastRng {
 public:
  explicit FastRng(uint64_t seed) {
    for (uint64_t& word : state_) {
      seed += 0x9E3779B97F4A7C15ull;
      uint64_t z = seed;
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
      word = z ^ (z >> 31);
    }
  }

  uint64_t Next() {
    const uint64_t result = Rotl(state_[1] * 5, 7) * 9;
    const uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = Rotl(state_[3], 45);
    return result;
  }

  double Uniform01() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

  // Uniform in [0, 1) from 32 bits (for table look-ups where 32 bits suffice).
  float Uniform01f() { return static_cast<float>(Next() >> 40) * 0x1.0p-24f; }

  // Standard normal by the ziggurat method (Marsaglia and Tsang 2000, 128
  // layers). The layer index and the value come from different bits of one
  // 64-bit draw (Doornik 2005), which avoids the original's correlation.
  double Normal();

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t state_[4];
};

}  // namespace furn

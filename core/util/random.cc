#include "core/util/random.h"

#include <array>
#include <cmath>

namespace furn {
namespace {

// Ziggurat tables for the standard normal with 128 layers (Marsaglia and
// Tsang 2000, "The Ziggurat Method for Generating Random Variables").
struct ZigguratTables {
  static constexpr double kR = 3.442619855899;          // start of the tail
  static constexpr double kArea = 9.91256303526217e-3;  // area of each layer
  static constexpr double kScale = 2147483648.0;        // 2^31
  std::array<uint32_t, 128> k;
  std::array<double, 128> w;
  std::array<double, 128> f;

  ZigguratTables() {
    double d = kR, t = kR;
    const double q = kArea / std::exp(-0.5 * d * d);
    k[0] = static_cast<uint32_t>((d / q) * kScale);
    k[1] = 0;
    w[0] = q / kScale;
    w[127] = d / kScale;
    f[0] = 1.0;
    f[127] = std::exp(-0.5 * d * d);
    for (int i = 126; i >= 1; --i) {
      d = std::sqrt(-2.0 * std::log(kArea / d + std::exp(-0.5 * d * d)));
      k[i + 1] = static_cast<uint32_t>((d / t) * kScale);
      t = d;
      f[i] = std::exp(-0.5 * d * d);
      w[i] = d / kScale;
    }
  }
};

const ZigguratTables& Tables() {
  static const ZigguratTables tables;
  return tables;
}

}  // namespace

double FastRng::Normal() {
  const ZigguratTables& z = Tables();
  for (;;) {
    const uint64_t bits = Next();
    const int layer = static_cast<int>(bits & 127);
    const int32_t value = static_cast<int32_t>(bits >> 32);
    const uint32_t magnitude =
        value < 0 ? static_cast<uint32_t>(-(int64_t)value) : static_cast<uint32_t>(value);
    const double x = value * z.w[layer];
    if (magnitude < z.k[layer]) return x;  // inside the layer's rectangle: ~99 % of draws
    if (layer == 0) {
      // The tail beyond kR (Marsaglia 1964).
      double tail, y;
      do {
        tail = -std::log(1.0 - Uniform01()) / ZigguratTables::kR;
        y = -std::log(1.0 - Uniform01());
      } while (y + y < tail * tail);
      return value > 0 ? ZigguratTables::kR + tail : -ZigguratTables::kR - tail;
    }
    // In the wedge between the rectangle and the curve.
    if (z.f[layer] + Uniform01() * (z.f[layer - 1] - z.f[layer]) < std::exp(-0.5 * x * x)) return x;
  }
}

}  // namespace furn

#include "core/learned/self_training.h"

#include <algorithm>
#include <string>
#include <vector>

#include "core/util/error.h"

namespace furn {
namespace {

BevObject ObjectOf(const BevPeak& peak) {
  BevObject object;
  object.furniture_class = peak.furniture_class;
  object.box() = peak.box();
  return object;
}

// The network's kept maxima on the image's mirror, turned back into the
// image's world (MirroredObject is its own inverse).
std::vector<BevObject> MirrorMaxima(const VoteNet& net,
                                    const BevImage& image,
                                    const BevDecodeOptions& decode,
                                    std::vector<double>* heats) {
  const BevImage mirrored = image.Mirrored();
  std::vector<BevObject> objects;
  for (const BevPeak& peak : DecodeBevOutput(mirrored, net.Predict(mirrored), decode)) {
    if (peak.suppressed) continue;
    objects.push_back(MirroredObject(ObjectOf(peak), image.frame));
    heats->push_back(peak.heat);
  }
  return objects;
}

}  // namespace

void PseudoLabelOptions::Check() const {
  for (double value : min_heat)
    Require(value == -1 || (value >= 0 && value <= 1),
            "a pseudo-label threshold (" + std::to_string(value) + ") must be in 0..1, or -1");
  Require(fallback_min_heat > 0 && fallback_min_heat <= 1,
          "the pseudo-labels' fallback threshold must be in (0, 1] (got " +
              std::to_string(fallback_min_heat) + ")");
  Require(heat_share > 0 && heat_share <= 4,
          "--pseudo-share must be in (0, 4] (got " + std::to_string(heat_share) + ")");
  Require(mirror_match_m > 0 && mirror_match_m <= 2,
          "--mirror-match must be in (0, 2] m (got " + std::to_string(mirror_match_m) + ")");
  Require(ignore_min_heat >= 0 && ignore_min_heat <= 1,
          "--ignore-heat must be in [0, 1] (got " + std::to_string(ignore_min_heat) + ")");
  decode.Check();
}

double PseudoLabelOptions::Threshold(FurnitureClass furniture_class) const {
  const double own = min_heat[static_cast<size_t>(furniture_class)];
  return std::min(1.0, (own < 0 ? fallback_min_heat : own) * heat_share);
}

int PseudoLabelCounts::Targets() const {
  int sum = 0;
  for (int count : targets) sum += count;
  return sum;
}

BevSample PseudoLabelledSample(const VoteNet& net,
                               const BevImage& image,
                               const PseudoLabelOptions& options,
                               PseudoLabelCounts* counts) {
  BevSample sample;
  sample.image = image;
  std::vector<double> mirror_heats;
  const std::vector<BevObject> mirror = MirrorMaxima(net, image, options.decode, &mirror_heats);
  for (const BevPeak& peak : DecodeBevOutput(image, net.Predict(image), options.decode)) {
    if (peak.suppressed || peak.heat < options.ignore_min_heat) continue;
    BevObject object = ObjectOf(peak);
    const double threshold = options.Threshold(peak.furniture_class);
    bool confirmed = false;
    for (size_t i = 0; i < mirror.size() && !confirmed && peak.heat >= threshold; ++i) {
      if (mirror[i].furniture_class != peak.furniture_class || mirror_heats[i] < threshold)
        continue;
      if ((mirror[i].Centre() - object.Centre()).norm() > options.mirror_match_m) continue;
      object.SetCentre(0.5 * (object.Centre() + mirror[i].Centre()));
      confirmed = true;
    }
    object.target = confirmed;
    sample.objects.push_back(object);
    if (counts == nullptr) continue;
    if (confirmed)
      ++counts->targets[static_cast<size_t>(peak.furniture_class)];
    else
      ++counts->ignored;
  }
  if (counts != nullptr) ++counts->images;
  return sample;
}

}  // namespace furn

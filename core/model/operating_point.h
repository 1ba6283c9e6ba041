// The operating point (issue 38): per class, the least score at which a
// candidate becomes a detection. The detector's candidates (every heat-map
// maximum, or every verified Hough hypothesis) are what average precision
// sweeps; the operating point is the decision a robot acts on. It is chosen
// for the best F1 on validation frames (reports/evaluation.h:
// ChooseOperatingPoint), stored in the model file, shown by `model info`, and
// applied by the detector unless DetectorOptions::all_candidates.
//
//   OperatingPoint point = model.operating_point;
//   if (point.Keeps(FurnitureClass::kTable, detection.score)) ...
#pragma once

#include <array>
#include <cmath>
#include <string>

#include "core/model/furniture_class.h"

namespace furn {

struct ClassOperatingPoint {
  double min_score = -1;  // < 0: no threshold, every candidate of the class is kept
  // Measured where it was chosen, at OperatingPoint::match_m (NaN: unknown).
  double precision = std::nan(""), recall = std::nan(""), f1 = std::nan("");
  int targets = 0;  // objects of the class to find there
};

// The match distance operating points are chosen and reported at (m): a
// decision ("there is a table here"), looser than AP@10cm's localisation.
inline constexpr double kOperatingMatchM = 0.2;

struct OperatingPoint {
  std::array<ClassOperatingPoint, kAllClasses.size()> classes{};
  double match_m = kOperatingMatchM;  // a detection this near a true object of its class is true
  std::string chosen_on;              // "240 validation frames of the training rooms", or empty

  // Whether no class has a threshold (a model trained before the operating
  // point, or one nobody chose one for).
  bool Empty() const {
    for (const ClassOperatingPoint& c : classes) {
      if (c.min_score >= 0) return false;
    }
    return true;
  }
  double MinScore(FurnitureClass furniture_class) const {
    return classes[static_cast<size_t>(furniture_class)].min_score;
  }
  bool Keeps(FurnitureClass furniture_class, double score) const {
    const double min_score = MinScore(furniture_class);
    return min_score < 0 || score >= min_score;
  }
};

}  // namespace furn

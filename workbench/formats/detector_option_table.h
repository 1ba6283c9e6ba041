// The one table of detector options: each option's key in options files and
// runs, its command-line flag (empty: files only) and its help. Options files
// (options_file.h) and the flags of `detect`, `evaluate`, `crossval` and
// `tune` (cli/detector_flags.h) are both made from it, so a new option is
// added once, here (COLMAP's AddAndRegisterDefaultOption).
//
//   ForEachDetectorOption(&options, [](const DetectorOptionInfo& info, auto& value) {
//     std::cout << info.key << " = " << value << "\n";
//   });
#pragma once

#include <array>
#include <string>

#include "core/detector/detector.h"

namespace furn {

struct DetectorOptionInfo {
  const char* key;   // dotted path in the "detector" object of options files
  const char* flag;  // "--name", or "" for an option set by files only
  const char* help;
};

// The key, flag and help of each class's operating-point option, made once
// (DetectorOptionInfo points into them).
struct ClassOptionNames {
  std::string key, flag, help;
};
inline const std::array<ClassOptionNames, kAllClasses.size()>& ClassMinScoreOptionNames() {
  static const std::array<ClassOptionNames, kAllClasses.size()> names = [] {
    std::array<ClassOptionNames, kAllClasses.size()> made;
    for (size_t c = 0; c < kAllClasses.size(); ++c) {
      const std::string name = ClassName(kAllClasses[c]);
      const char* article = std::string("aeiou").find(name[0]) == std::string::npos ? "a" : "an";
      made[c] = {"class_min_score." + name,
                 "--op-" + name,
                 std::string("Operating point: least score of ") + article + " " + name +
                     " detection (-1: the model's)"};
    }
    return made;
  }();
  return names;
}

// Calls visit(info, member) for every field of `options`, in the order runs
// store them (that order is part of the stored text: do not reorder).
template <typename Options, typename Visit>
void ForEachDetectorOption(Options* options, Visit&& visit) {
  Options& o = *options;
  visit(DetectorOptionInfo{"max_range_m",
                           "--max-range",
                           "Drop points beyond (m; the vote map keeps its model's range)"},
        o.max_range_m);
  visit(
      DetectorOptionInfo{"floor_band_m", "--floor-band", "Points below this height are floor (m)"},
      o.floor_band_m);
  visit(
      DetectorOptionInfo{
          "floor.distance_m", "--floor-distance", "Floor search: RANSAC inlier distance (m)"},
      o.floor.distance_m);
  visit(DetectorOptionInfo{"floor.iterations", "", ""}, o.floor.iterations);
  visit(DetectorOptionInfo{"floor.sample_points",
                           "--floor-sample",
                           "Floor search: RANSAC draws from about this many of the points"},
        o.floor.sample_points);
  visit(DetectorOptionInfo{"floor.max_tilt_deg",
                           "--floor-max-tilt",
                           "Floor search: largest angle of the floor to the camera's up (deg)"},
        o.floor.max_tilt_deg);
  visit(DetectorOptionInfo{"floor.min_fraction", "", ""}, o.floor.min_fraction);
  visit(DetectorOptionInfo{"floor.min_camera_height_m", "", ""}, o.floor.min_camera_height_m);
  visit(DetectorOptionInfo{"floor.max_camera_height_m", "", ""}, o.floor.max_camera_height_m);
  visit(DetectorOptionInfo{"max_segment_extent_m", "", ""}, o.max_segment_extent_m);
  visit(DetectorOptionInfo{"cell_m", "", ""}, o.cell_m);
  visit(DetectorOptionInfo{"vote_sigma_m", "", ""}, o.vote_sigma_m);
  visit(DetectorOptionInfo{"vote_height_tolerance_m", "", ""}, o.vote_height_tolerance_m);
  visit(DetectorOptionInfo{"relative_threshold",
                           "--threshold",
                           "Codebook voting: relative vote threshold t (eq. 8)"},
        o.relative_threshold);
  visit(
      DetectorOptionInfo{
          "absolute_threshold", "--absolute-threshold", "Codebook voting: minimum vote weight"},
      o.absolute_threshold);
  visit(DetectorOptionInfo{"max_hypotheses_per_class",
                           "--max-hypotheses",
                           "Codebook voting: strongest maxima kept per class"},
        o.max_hypotheses_per_class);
  visit(DetectorOptionInfo{"support_radius_m", "", ""}, o.support_radius_m);
  visit(DetectorOptionInfo{"neighbours", "", ""}, o.neighbours);
  visit(DetectorOptionInfo{"top_models", "--top-models", "CAD models fitted per hypothesis"},
        o.top_models);
  visit(DetectorOptionInfo{"fit.iterations", "--fit-iterations", "RANSAC draws per fit"},
        o.fit.iterations);
  visit(DetectorOptionInfo{"fit.height_tolerance_m", "", ""}, o.fit.height_tolerance_m);
  visit(DetectorOptionInfo{"fit.inlier_m", "", ""}, o.fit.inlier_m);
  visit(DetectorOptionInfo{"fit.max_offset_m", "", ""}, o.fit.max_offset_m);
  visit(DetectorOptionInfo{"fit.refine_iterations", "", ""}, o.fit.refine_iterations);
  visit(DetectorOptionInfo{"fit.above_m", "", ""}, o.fit.above_m);
  visit(
      DetectorOptionInfo{
          "min_covered_fraction",
          "--min-covered",
          "Codebook voting, fixed gates: share of the box's points a fit must explain"},
      o.min_covered_fraction);
  visit(
      DetectorOptionInfo{
          "own_segment_share",
          "--own-segments",
          "Codebook voting: count in the covered share only segments at least this much inside "
          "the fit's box (0: off; e.g. 0.5 finds chairs pushed under desks)"},
      o.own_segment_share);
  visit(DetectorOptionInfo{"occupancy_voxel_m", "", ""}, o.occupancy_voxel_m);
  visit(DetectorOptionInfo{"occupied_weight", "", ""}, o.occupied_weight);
  visit(DetectorOptionInfo{"min_verification",
                           "--min-verification",
                           "Codebook voting, fixed gates: visibility score"},
        o.min_verification);
  visit(
      DetectorOptionInfo{
          "min_seen_occupied",
          "--min-seen",
          "Codebook voting, fixed gates: share of the fit's observable surface seen"},
      o.min_seen_occupied);
  visit(
      DetectorOptionInfo{"min_score", "--min-score", "Codebook voting, fixed gates: ranking score"},
      o.min_score);
  visit(DetectorOptionInfo{"max_shared_support", "", ""}, o.max_shared_support);
  visit(DetectorOptionInfo{"max_footprint_overlap", "", ""}, o.max_footprint_overlap);
  visit(DetectorOptionInfo{"use_scorer", "", ""}, o.use_scorer);
  visit(DetectorOptionInfo{"scorer_min_covered_fraction", "", ""}, o.scorer_min_covered_fraction);
  visit(DetectorOptionInfo{"scorer_min_verification", "", ""}, o.scorer_min_verification);
  visit(DetectorOptionInfo{"scorer_min_seen_occupied", "", ""}, o.scorer_min_seen_occupied);
  visit(DetectorOptionInfo{"min_probability",
                           "--min-probability",
                           "Codebook voting with the model's scorer: least detection probability"},
        o.min_probability);
  visit(DetectorOptionInfo{"scorer_max_seen_through", "", ""}, o.scorer_max_seen_through);
  visit(DetectorOptionInfo{"seed", "--seed", "Seed of the RANSAC draws"}, o.seed);
  visit(DetectorOptionInfo{"voting",
                           "--voting",
                           "Hypotheses from: auto (the model's vote network when it has one), "
                           "learned, or codebook (the paper's Hough votes)"},
        o.voting);
  visit(DetectorOptionInfo{"learned_min_heat",
                           "--min-heat",
                           "Learned voting: least heat of a maximum that becomes a candidate (the "
                           "operating point decides the detections)"},
        o.learned_decode.min_heat);
  visit(DetectorOptionInfo{"learned_max_per_class", "", ""}, o.learned_decode.max_per_class);
  visit(DetectorOptionInfo{"learned_suppress_m",
                           "--suppress-radius",
                           "Learned voting: a weaker maximum of any class this near a stronger "
                           "one is dropped (m; 0, the default: off)"},
        o.learned_decode.suppress_m);
  visit(
      DetectorOptionInfo{"learned_same_class_m",
                         "--same-class-radius",
                         "Learned voting: a weaker maximum of a class this near a stronger one of "
                         "the same class is dropped, one object seen twice (m; 0: off)"},
      o.learned_decode.same_class_m);
  visit(DetectorOptionInfo{"torch_threads",
                           "--torch-threads",
                           "Learned voting: the network's threads (0: the library's default)"},
        o.torch_threads);
  visit(DetectorOptionInfo{"network_precision",
                           "--network-precision",
                           "Learned voting: the network's arithmetic: auto (bf16 on a CPU with "
                           "AMX-BF16, else fp32), fp32 or bf16"},
        o.network_precision);
  visit(
      DetectorOptionInfo{
          "learned_fit",
          "--learned-fit",
          "Learned voting (on by default): rank and fit the CAD models in each detection's box; "
          "an agreeing fit gives the yaw and names the model"},
      o.learned_fit);
  visit(
      DetectorOptionInfo{
          "learned_fit_agree_m",
          "--fit-agree",
          "Learned voting: a fit this near the network's centre gives the yaw and model (m)"},
      o.learned_fit_agree_m);
  visit(DetectorOptionInfo{"learned_centre",
                           "--centre-from",
                           "Learned voting: a maximum's centre from 'votes' (the mean shift of the "
                           "dense votes around it) or 'peak' (its own cell's vote)"},
        o.learned_decode.centre);
  visit(DetectorOptionInfo{"learned_vote_bandwidth_m",
                           "--vote-bandwidth",
                           "Learned voting: the mean shift's kernel width (m)"},
        o.learned_decode.vote_bandwidth_m);
  visit(DetectorOptionInfo{"learned_vote_heat_power",
                           "--vote-heat-power",
                           "Learned voting: a vote's weight is its membership times the class's "
                           "heat at its cell to this power (0: membership alone)"},
        o.learned_decode.vote_heat_power);
  visit(DetectorOptionInfo{"learned_edge_classes",
                           "--edge-centres",
                           "Learned voting, networks trained with edge votes: the classes centred "
                           "between the four sides their cells place ('none', the default: the "
                           "peak cell's centre; 'large': tables, sideboards and sofas; 'all')"},
        o.learned_decode.edge_classes);
  visit(DetectorOptionInfo{"learned_edge_near_m",
                           "--edge-reach",
                           "Learned voting, --edge-centres: a cell's say on a side falls off as "
                           "exp(-its distance to the side / this) (m)"},
        o.learned_decode.edge_near_m);
  visit(DetectorOptionInfo{"learned_edge_agree_m",
                           "--edge-agree",
                           "Learned voting, --edge-centres: the cells whose distances put the "
                           "centre this near the maximum's own are the object's (m)"},
        o.learned_decode.edge_agree_m);
  visit(DetectorOptionInfo{"learned_mirror_average",
                           "--mirror-average",
                           "Learned voting: average the network's outputs with those of the "
                           "mirrored image (test-time augmentation; twice the network's time; "
                           "--no-mirror-average: the image alone)"},
        o.learned_mirror_average);
  visit(DetectorOptionInfo{"learned_extent_fit",
                           "--extent-fit",
                           "Learned voting: move the boxes of these classes ('none', 'tables', "
                           "'large': tables, sideboards and sofas, 'all') to the edges of the "
                           "surface the scan saw end"},
        o.learned_extent_fit);
  visit(DetectorOptionInfo{"learned_extent_one_edge",
                           "--extent-one-edge",
                           "Learned voting: an axis of the extent fit with one edge seen keeps "
                           "the network's size from it (else only axes with both edges seen move)"},
        o.learned_extent_one_edge);
  visit(
      DetectorOptionInfo{"all_candidates",
                         "--all-candidates",
                         "Output every candidate (each maximum that passed its stages), not only "
                         "those at the model's operating point (evaluate always sweeps them all)"},
      o.all_candidates);
  // One operating-point option per class: class_min_score.<class>, --op-<class>.
  const auto& names = ClassMinScoreOptionNames();
  for (size_t c = 0; c < kAllClasses.size(); ++c) {
    visit(DetectorOptionInfo{names[c].key.c_str(), names[c].flag.c_str(), names[c].help.c_str()},
          o.class_min_score[static_cast<size_t>(kAllClasses[c])]);
  }
}

}  // namespace furn

// Detection (SPEC.md §8; Usenko et al. Sec. IV): furniture in one depth scan.
//
//   1. points in the world frame (floor z = 0; found by RANSAC when the camera
//      pose is unknown), farther than max_range_m from the sensor dropped,
//      floor points (z < floor_band_m) set aside;
//   2. segments and SGFs through SegmentView, the training code path;
//   3. probabilistic Hough voting: each segment activates words; every shape
//      entry (class o, relation d) of word A_i whose training height matches
//      votes at the segment centroid + d (view-aligned, as trained) with
//      weight p(A_i | f) / #(A_i, o), on a per-class xy grid, then smoothed;
//   4. local maxima per class in a window of half the class's width, above
//      (max - min) * t + min of the grid (paper eq. 8) and an absolute floor;
//   5. the segments that voted near a maximum -> VFH -> k nearest part subsets
//      -> the top-M CAD models of that class;
//   6. each candidate fitted by 3-DOF RANSAC + ICP (pose_fit.h);
//   7. the fit verified against the scene's occupancy grid (occupancy.h);
//      a detection whose points better ones already explain, or whose
//      footprint overlaps a better one's, is dropped.
//
// The shared preprocessing projects points onto their MLS quadric, which is
// the smoothing SPEC §8.1 asks for; training and detection both get it.
//
// Steps 2-7 are the codebook's hypothesis source (codebook_source.h); the
// learned vote map (learned_source.h, the default when the model holds a
// network) is the other. Detect places the scan (PlaceScan), lets the
// model's source propose candidates, and runs one tail for both
// (hypothesis_source.h: operating point, the source's refinement, share in
// view, timings, debug record). Each step is a stage of its own that tests
// and tools can call alone (PlaceScan, SegmentScan, Vote, FindMaxima,
// RankCandidates, then per hypothesis FitHypothesis, VerifyFit and
// ScoreHypothesis, which FitAndVerify runs on both cores, and Suppress; the
// learned source's Rasterise, RunNetwork, Decode, FitCandidates,
// FitExtents); each fills an output struct.
//
// A model trained with a hypothesis scorer (hypothesis_scorer.h) replaces the
// fixed verification thresholds by looser gates and the scorer's calibrated
// probability as the detection score.
//
//   Detector detector(LoadTrainedModel("model.fcm"), DetectorOptions{});
//   DetectionResult result = detector.Detect(input);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/codebook/hypothesis_scorer.h"
#include "core/codebook/segment_view.h"
#include "core/codebook/view_segments.h"
#include "core/geometry/depth_scan.h"
#include "core/geometry/floor.h"
#include "core/geometry/occupancy.h"
#include "core/geometry/pose_fit.h"
#include "core/geometry/render_compare.h"
#include "core/learned/bev_box_coder.h"
#include "core/learned/bev_extent.h"
#include "core/learned/vote_net.h"
#include "core/model/furniture_box.h"
#include "core/model/operating_point.h"
#include "core/model/trained_model.h"

namespace furn {

// Where hypotheses come from: the codebook's Hough votes (the paper's
// path), the learned vote map of the model file (issue 30), or (auto) the
// learned map when the model holds one.
enum class VotingMode { kAuto, kCodebook, kLearned };
template <>
struct EnumText<VotingMode> {
  static constexpr const char* kKind = "voting";
  static constexpr EnumEntry<VotingMode> kEntries[] = {
      {VotingMode::kAuto, "auto"},
      {VotingMode::kCodebook, "codebook"},
      {VotingMode::kLearned, "learned"},
  };
};

struct DetectorOptions {
  // Input (m): points farther from the sensor are dropped (the learned vote
  // map rasterises the range its network was trained on, VoteNetOptions::
  // range_m, and drops its maxima farther than this across the floor);
  // points below the floor band are floor. FindFloor's options apply when the pose is unknown.
  double max_range_m = 3.0;
  double floor_band_m = 0.03;
  FloorOptions floor;

  // Voting: segments larger than max_segment_extent_m (walls) do not vote;
  // grid cell and Gaussian smoothing (m); a shape entry votes only when its
  // training height is within the tolerance of the segment's (0: off).
  double max_segment_extent_m = 2.5;
  double cell_m = 0.02;
  double vote_sigma_m = 0.03;
  double vote_height_tolerance_m = 0.15;

  // Hypotheses: t of paper eq. 8 (0..1), an absolute floor on the smoothed
  // vote weight, the strongest maxima kept per class, and the radius (m)
  // within which a segment's votes make it support a maximum.
  double relative_threshold = 0.15;
  double absolute_threshold = 0.0;
  int max_hypotheses_per_class = 12;
  double support_radius_m = 0.12;

  // Ranking: part subsets retrieved per supporting segment; CAD models
  // fitted per hypothesis (M).
  int neighbours = 20;
  int top_models = 3;

  FitOptions fit;

  // Verification (all shares in 0..1): the fit must explain min_covered of
  // the scene points in its box; occupancy voxel (m) and w of the visibility
  // score vs, which must reach min_verification; of the fit's observable
  // surface the sensor must have seen min_seen_occupied; and the ranking
  // score (vs x covered x seen) must reach min_score. The seen share was
  // 0.75, set on the CAD models trained on; furniture of other shapes covers
  // its fitted model less, and 0.6 measured better (protocol E mAP@10cm 0.118
  // -> 0.138 over 3 fold seeds). Coverage stays 0.75: at 0.6 protocol E gains
  // little more (0.143) but a 1.2 m column passes as a sideboard (covers 0.69).
  double min_covered_fraction = 0.75;
  // With own_segment_share > 0, the covered share counts only the segments
  // that lie at least this much inside the fitted box (a desk top over a
  // chair pushed under it belongs to the desk); 0: every point in the box.
  // Off by default until measured on protocol E (on the real set of
  // data/real it finds the office chairs under desks; see README).
  double own_segment_share = 0;
  double occupancy_voxel_m = 0.05;
  double occupied_weight = 5;
  double min_verification = 0.6;
  double min_seen_occupied = 0.6;
  double min_score = 0.4;

  // Suppression of weaker detections: by the share of their points that
  // better ones already explain, and by footprint overlap with a better one
  // (of the smaller footprint). Both in 0..1.
  double max_shared_support = 0.5;
  double max_footprint_overlap = 0.6;

  // With a model that holds a hypothesis scorer (and use_scorer), the fit
  // must pass these looser gates instead of the three above, and the
  // scorer's probability, the detection score, must reach min_probability.
  bool use_scorer = true;
  double scorer_min_covered_fraction = 0.5;
  double scorer_min_verification = 0.4;
  double scorer_min_seen_occupied = 0.3;
  double min_probability = 0.05;
  // Render-and-compare (render_compare.h, organised scans only): with the
  // scorer, a fit the sensor saw through on more than this share of its
  // compared pixels is dropped (1: off). Off by default: its shares are
  // scorer features, and as a gate at 0.6 it dropped correct fits of
  // furniture shaped otherwise than its CAD model (protocol E, fold seed 1:
  // mAP@10cm 0.129 without the gate, 0.103 with it).
  double scorer_max_seen_through = 1.0;

  uint64_t seed = 1;  // RANSAC draws

  // Learned voting (core/learned/): how the network's heat-map maxima
  // become candidates is learned_decode (bev_box_coder.h, its defaults the
  // product's; its range is max_range_m); torch_threads: the network's
  // intra-op threads (0: the library's default).
  VotingMode voting = VotingMode::kAuto;
  // The network's outputs averaged with those of the mirrored image
  // (VoteNet::Predict; the network's time twice, the frame's +3 %). On by
  // default since issue 37 measured it on three fold seeds of protocol E
  // (docs/learned-voting.md); the operating point is chosen without it.
  bool learned_mirror_average = true;
  // Floor, maxima per class, suppression, same-class separation, centring
  // (the mean shift of the dense votes, or the peak cell's own) and edge
  // votes; max_distance_m is ignored (LearnedDecode sets max_range_m).
  BevDecodeOptions learned_decode;
  int torch_threads = 1;
  // The network's arithmetic (vote_net.h): auto is bfloat16 on a CPU with
  // AMX-BF16 (protocol E, the real set and NYU's train frames within 0.006
  // AP of float's, the network 2.6 times faster), float elsewhere.
  NetworkPrecision network_precision = NetworkPrecision::kAuto;
  // The paper's stages after the learned vote: each detection's CAD models
  // ranked by the VFH part subsets of the segments inside its box (top_models
  // of them) and fitted by 3-DOF RANSAC; where the best fit's reference point
  // lies within learned_fit_agree_m of the network's, the detection takes
  // the fit's yaw and names its CAD model (position and footprint stay the
  // network's). Off: the network's boxes alone. On by default: on protocol E
  // (2 fold seeds) the same mAP, yaw error median 6° instead of 42–49°.
  bool learned_fit = true;
  double learned_fit_agree_m = 0.15;
  // The extent fit (core/learned/bev_extent.h): the detections of these
  // classes move their box to the edges of the surface the scan shows, where
  // it saw them end (a long table's centre from its two ends, not from one
  // peak cell).
  ExtentFitClasses learned_extent_fit = ExtentFitClasses::kNone;
  bool learned_extent_one_edge = true;  // ExtentFitOptions::one_edge_moves

  // The operating point (core/model/operating_point.h): a candidate whose score is
  // below its class's threshold is no detection (HypothesisOutcome
  // kBelowOperatingPoint). The threshold is class_min_score's where that is
  // >= 0, else the model's operating point's (none: every candidate).
  // all_candidates: every candidate is a detection (what AP sweeps; evaluate
  // sets it).
  bool all_candidates = false;
  std::array<double, kAllClasses.size()> class_min_score = {-1, -1, -1, -1, -1};

  // The score a detection of each class needs under these options and the
  // model's operating point (< 0: none).
  OperatingPoint EffectiveOperatingPoint(const OperatingPoint& model_point) const;

  // learned_decode within max_range_m.
  BevDecodeOptions LearnedDecode() const;

  // Throws InputError naming the field and the rule.
  void Check() const;
};

// The box (FurnitureBox: reference point, yaw, footprint; the footprint 0
// when the detector gives none) and what found it.
struct Detection : FurnitureBox {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  double z = 0;          // height of the reference point (the floor's, world frame)
  int model_index = -1;  // into the trained model's names
  std::string model_name;
  double score = 0;  // learned: the heat; else the scorer's probability or vs x covered x seen
  double vote_weight = 0;       // smoothed Hough value at the maximum
  double verification = 0;      // visibility score vs
  double covered_fraction = 0;  // of the scene points inside the fitted box, those it explains
  // Of the box (BoxOf), the share inside the sensor's view (ShareOfBoxInView:
  // the image of an organised scan, else the scan's tangent span). Below 1
  // the box is cut by the frame, and its centre and size are guessed from
  // the part in view.
  double in_view = 1;
};

// A detection's box in its own frame (yaw about its reference point, base on
// the floor): the learned footprint when there is one (with the named CAD
// model's height, else the class's typical height), else the fitted CAD
// model's bounds.
struct DetectionBox {
  Eigen::Vector3f low = Eigen::Vector3f::Zero(), high = Eigen::Vector3f::Zero();
};
DetectionBox BoxOf(const Detection& detection, const TrainedModel& model);

// What became of a Hough maximum, in pipeline order (a later value is a
// further stage): each stage a hypothesis can stop at (SPEC §8 steps 4 to 7).
enum class HypothesisOutcome {
  kNoSupport,            // no segment voted into it
  kSameSupport,          // backed by the same segments as a stronger maximum of its class
  kNoFit,                // no candidate model gave a pose
  kLowCoverage,          // the best fit explains too few scene points in its box
  kLowVerification,      // visibility score below min_verification
  kLowSeenOccupied,      // too little of the fit's observable surface was seen
  kSeenThrough,          // render-and-compare: the sensor saw through too much of the fit
  kLowScore,             // ranking score below min_score (probability below min_probability)
  kSuppressed,           // a better detection explains its points or overlaps it
  kBelowOperatingPoint,  // a candidate whose score is below its class's operating point
  kDetected,
};
template <>
struct EnumText<HypothesisOutcome> {
  static constexpr const char* kKind = "hypothesis outcome";
  static constexpr EnumEntry<HypothesisOutcome> kEntries[] = {
      {HypothesisOutcome::kNoSupport, "no_support"},
      {HypothesisOutcome::kSameSupport, "same_support"},
      {HypothesisOutcome::kNoFit, "no_fit"},
      {HypothesisOutcome::kLowCoverage, "low_coverage"},
      {HypothesisOutcome::kLowVerification, "low_verification"},
      {HypothesisOutcome::kLowSeenOccupied, "low_seen_occupied"},
      {HypothesisOutcome::kSeenThrough, "seen_through"},
      {HypothesisOutcome::kLowScore, "low_score"},
      {HypothesisOutcome::kSuppressed, "suppressed"},
      {HypothesisOutcome::kBelowOperatingPoint, "below_operating_point"},
      {HypothesisOutcome::kDetected, "detected"},
  };
};
inline const char* OutcomeName(HypothesisOutcome outcome) { return EnumName(outcome); }

// The stages Detect times, in order; their names are the keys of
// DetectionResult::timings_ms in JSON and runs.
enum class DetectionStage {
  kFloor,
  kPreprocess,
  kSegment,
  kFeatures,
  kOccupancy,
  kVote,
  kBev,
  kNetwork,
  kMaxima,
  kRank,
  kFitAndVerify,
  kSuppress,
  kTotal,  // the whole call
};
template <>
struct EnumText<DetectionStage> {
  static constexpr const char* kKind = "detection stage";
  static constexpr EnumEntry<DetectionStage> kEntries[] = {
      {DetectionStage::kFloor, "floor"},
      {DetectionStage::kPreprocess, "preprocess"},
      {DetectionStage::kSegment, "segment"},
      {DetectionStage::kFeatures, "features"},
      {DetectionStage::kOccupancy, "occupancy"},
      {DetectionStage::kVote, "vote"},
      {DetectionStage::kBev, "bev"},
      {DetectionStage::kNetwork, "network"},
      {DetectionStage::kMaxima, "maxima"},
      {DetectionStage::kRank, "rank"},
      {DetectionStage::kFitAndVerify, "fit+verify"},
      {DetectionStage::kSuppress, "suppress"},
      {DetectionStage::kTotal, "total"},
  };
};

struct StageTime {
  DetectionStage stage = DetectionStage::kTotal;
  double ms = 0;
};
// Per stage, in order of running; Detect's end with kTotal.
struct StageTimings {
  std::vector<StageTime> stages;
  void Add(DetectionStage stage, double ms) { stages.push_back({stage, ms}); }
  // The stage's time, or 0 when it did not run.
  double Of(DetectionStage stage) const {
    for (const StageTime& t : stages) {
      if (t.stage == stage) return t.ms;
    }
    return 0;
  }
};

// Everything a report needs to show how the detections came about.
struct DetectionDebug {
  struct VoteGrid {
    FurnitureClass furniture_class = FurnitureClass::kChair;
    Eigen::Vector2f origin = Eigen::Vector2f::Zero();  // world xy of the grid's corner
    double cell_m = 0;
    int cols = 0, rows = 0;
    std::vector<float> values;  // smoothed votes, row-major, row = y
    double threshold = 0;       // of the maxima
    bool learned = false;       // the network's heat (0..1), not Hough votes
  };
  // A learned maximum's record (Hypothesis::learned).
  struct LearnedPeak {
    // Where the peak cell's own vote put the centre, the summed weight of
    // the dense votes that placed it (0: the peak's own), and the cells
    // whose edge votes placed it (0: not by edges).
    double peak_x = 0, peak_y = 0, votes = 0;
    int edge_cells = 0;
    double suppressed_by_m = 0;  // kSuppressed: the distance to the stronger maximum
    // With learned_fit: the best fit agreed with the network and gave the
    // detection its yaw and CAD model.
    bool refined = false;
    // With learned_extent_fit: how many of the box's four edges the scan saw
    // end (its box moved to them; 0: the network's box stayed; -1: not
    // tried), and how far its centre moved (m).
    int extent_edges = -1;
    double extent_moved_m = 0;
  };
  // The box: the maximum's position and, on the learned path, the network's
  // yaw and footprint there (0 on the codebook path: a Hough maximum has
  // neither).
  struct Hypothesis : FurnitureBox {
    FurnitureClass furniture_class = FurnitureClass::kChair;
    // Codebook: the smoothed Hough value at the maximum; learned: its heat.
    double vote_weight = 0;
    double relative_weight = 0;         // (vote - min) / (max - min) of the class grid
    std::vector<int> segments;          // that voted for it
    std::vector<int> candidate_models;  // ranked by the part subsets
    struct Fit {
      int model_index = -1;
      double x = 0, y = 0, yaw = 0;
      double covered_fraction = 0, verification = 0, score = 0;
    };
    std::vector<Fit> fits;  // of the candidates that gave a pose
    HypothesisOutcome outcome = HypothesisOutcome::kNoSupport;
    // The value that failed its test (coverage, verification, seen-occupied
    // or score; kBelowOperatingPoint: the score and the threshold), or for a
    // codebook kSuppressed the shared support and footprint overlap (a
    // learned one: LearnedPeak::suppressed_by_m).
    double outcome_values[2] = {0, 0};
    // The best fit's pose and scorer features, set when it passed the
    // scorer's gates (whether or not a scorer decided): what a scorer
    // learns from. On the learned path fit_x, fit_y are the best CAD fit's
    // position (the maximum's own until a fit ran).
    std::optional<HypothesisFeatures> features;
    double fit_x = 0, fit_y = 0;
    double probability = -1;  // the scorer's, when one decided
    // Set on the learned path only: what the network said at the maximum.
    std::optional<LearnedPeak> learned;
  };
  // One line for people: "detected", "covers 0.62 of the points", ...
  static std::string Describe(const Hypothesis& hypothesis);
  std::vector<Eigen::Vector3f> points;  // preprocessed, floor removed, world frame
  std::vector<int> segment_of_point;    // -1 when in no segment
  std::vector<VoteGrid> grids;          // one per class
  std::vector<Hypothesis> hypotheses;
  std::vector<std::vector<Eigen::Vector3f>> fitted_points;  // per detection, world frame
};

// How a detection call ended. Anything but kDetected leaves `detections` empty
// and says why in DetectionResult::message.
enum class DetectionStatus {
  kDetected,         // the pipeline ran (it may still have found nothing)
  kNoPointsInRange,  // no finite point within max_range_m of the sensor
  kNoFloor,          // no pose given and no floor found (message says why)
};
template <>
struct EnumText<DetectionStatus> {
  static constexpr const char* kKind = "detection status";
  static constexpr EnumEntry<DetectionStatus> kEntries[] = {
      {DetectionStatus::kDetected, "detected"},
      {DetectionStatus::kNoPointsInRange, "no_points_in_range"},
      {DetectionStatus::kNoFloor, "no_floor"},
  };
};

struct DetectionResult {
  DetectionStatus status = DetectionStatus::kDetected;
  std::string message;                // why, when status is not kDetected
  std::vector<Detection> detections;  // best score first
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  bool floor_estimated = false;  // world_from_camera came from FindFloor
  int input_points = 0;          // finite and within max_range_m of the sensor
  // What segmentation saw (preprocessed, floor removed) and made of it; both
  // 0 when no segmentation ran (the learned path without learned_fit).
  int scene_points = 0, segments = 0;
  StageTimings timings_ms;  // per stage, in order, then kTotal
  DetectionDebug debug;     // hypotheses always; points, grids and fits when asked for
};

// One Hough vote, kept to find the segments behind a maximum.
struct HoughVote {
  int segment = 0;
  int class_index = 0;
  float x = 0, y = 0;
  float weight = 0;
};

// Stage 1: the scan in the world frame, segmented, with its occupancy.
struct PreparedScan {
  DetectionStatus status = DetectionStatus::kDetected;
  std::string message;  // why, when status is not kDetected
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  bool floor_estimated = false;
  Eigen::Vector3f sensor = Eigen::Vector3f::Zero();  // world frame
  int input_points = 0;                              // finite and in range
  ViewSegments view;                               // above the floor: preprocessed, segments, SGFs
  std::vector<char> structure, structure_segment;  // walls: per point, per segment
  std::vector<int> segment_of_point;               // of view.cloud; -1: in no segment
  std::optional<OccupancyGrid> occupancy;          // every point in range, floor included
  // Organised scans: the observed depth per pixel (camera z; NaN: no
  // return) and the intrinsics that project onto it, for render-and-compare.
  std::optional<PinholeIntrinsics> intrinsics;
  std::vector<float> depth;
  int width = 0, height = 0;
  StageTimings timings_ms;  // floor, preprocess, ...
  // Learned voting: the camera-frame points the scan was given (what the
  // network's grid is rasterised from); empty on the codebook path.
  std::vector<Eigen::Vector3f> camera_points;
};

// Stage 2: per-class vote grids (smoothed) and the votes behind them.
struct VoteMaps {
  Eigen::Vector2f origin = Eigen::Vector2f::Zero();  // world xy of the grids' corner
  double cell_m = 0;
  int cols = 0, rows = 0;
  std::vector<std::vector<float>> grids;  // per class index, row-major (row = y); empty: none
  std::vector<HoughVote> votes;
};

// Stage 6 (fit): the scene around a hypothesis, and every candidate CAD
// model fitted to it by RANSAC + ICP and ranked by its score.
struct HypothesisRegion {
  std::vector<Eigen::Vector3f> points;  // scene points within the candidates' reach (no structure)
  std::vector<int> cloud_index;         // their indices into view.cloud
  // An even subsample of at most kMaxFitPoints of them, what RANSAC fits to.
  std::vector<Eigen::Vector3f> fit_points, fit_normals;
  std::vector<int> fit_cloud_index;
};
inline constexpr size_t kMaxFitPoints = 800;

struct CandidateFit {
  int model = -1;  // into the trained model's names
  int rank = 0;    // among the hypothesis' candidates
  PoseFit fit;
  VisibilityCounts counts;  // of the posed model against the occupancy grid
  // The ranking score: the visibility score vs times the covered share
  // times the seen share (occluded points neither help nor hurt).
  double covered = 0, verification = 0, score = -1;
  std::vector<Eigen::Vector3f> posed;  // the model's shape points at the fit, world frame
};

struct HypothesisFit {
  HypothesisRegion region;
  std::optional<CandidateFit> best;                    // none: no candidate gave a pose
  double second_score = 0;                             // the best score of the other candidates
  int fits = 0;                                        // candidates that gave a pose
  std::vector<DetectionDebug::Hypothesis::Fit> tried;  // every pose, for reports

  // A candidate's pose counted, recorded, and kept when it beats the best
  // so far (candidates are added in rank order).
  void Add(CandidateFit candidate);
};

// Stage 7 (verify): what the scan says of the best fit.
struct FitVerification {
  double covered = 0;        // share of the box's scene points it explains
  double verification = 0;   // visibility score vs
  double seen_occupied = 0;  // share of its observable surface the sensor saw
  // Render-and-compare from the actual camera (organised scans; -1 else):
  // shares of the compared pixels the sensor saw through, and that support it.
  double seen_through = -1, render_support = -1;
  bool scorer_gates = false;  // passes the scorer's looser gates
};

// Stage 8 (score): the scorer's features and probability, the gates, and
// the outcome.
struct HypothesisScore {
  std::optional<HypothesisFeatures> features;  // set when it passed the scorer's gates
  double score = 0;                            // the detection score
  double probability = -1;                     // the scorer's, when one decided
  HypothesisOutcome outcome = HypothesisOutcome::kDetected;
  double failed_value = 0;            // the value that failed its gate
  std::vector<int> explained_points;  // of region.points, when computed for the features
};

// Stages 6-8: a hypothesis' accepted fit, if any.
struct FittedHypothesis {
  std::optional<Detection> detection;
  std::vector<Eigen::Vector3f> fitted_points;  // the posed model, world frame
  std::vector<int> support;                    // scan points (view.cloud) it explains
};

class StageTimer;
class OccupancyHandoff;

class Detector {
 public:
  // Checks the options; indexes the shape model and part-subset library.
  Detector(TrainedModel model, const DetectorOptions& options);
  ~Detector();
  Detector(const Detector&) = delete;  // its hypothesis source refers to it
  Detector& operator=(const Detector&) = delete;

  // A scan with no finite point in range comes back with status
  // kNoPointsInRange. Throws InputError for a malformed input (organised size
  // not matching), or no floor found when the pose is unknown. Uses both cores; the same input
  // gives the same result.
  DetectionResult Detect(const DetectionInput& input, bool keep_debug = false) const;

  // The stages of Detect, in order. Prepare is PlaceScan (range, floor or
  // the given pose) then SegmentScan (preprocessing, segments, features,
  // structure, occupancy; learned voting without fits needs none of it:
  // Prepare leaves it out, and Detect runs it beside the network).
  PreparedScan Prepare(const DetectionInput& input) const;
  PreparedScan PlaceScan(const DetectionInput& input) const;
  void SegmentScan(const DetectionInput& input, PreparedScan* scan) const;
  // The same, leaving the occupancy grid to whichever thread comes to it
  // first (`handoff`: Detect's network branch may build it).
  void SegmentScan(const DetectionInput& input,
                   PreparedScan* scan,
                   OccupancyHandoff* handoff) const;
  VoteMaps Vote(const PreparedScan& scan) const;
  // Maxima of every class, strongest first within a class; `grids` (may be
  // null) gets each class grid's threshold, and its values when keep_values.
  std::vector<DetectionDebug::Hypothesis> FindMaxima(const VoteMaps& votes,
                                                     std::vector<DetectionDebug::VoteGrid>* grids,
                                                     bool keep_values) const;
  // The segments behind each maximum and its candidate CAD models (or
  // outcome kNoSupport / kSameSupport).
  void RankCandidates(const PreparedScan& scan,
                      const VoteMaps& votes,
                      std::vector<DetectionDebug::Hypothesis>* hypotheses) const;
  // Stage 6: every candidate of a ranked hypothesis fitted (RANSAC draws
  // seeded by `hypothesis_index`), the best by the ranking score.
  HypothesisFit FitHypothesis(const PreparedScan& scan,
                              const DetectionDebug::Hypothesis& hypothesis,
                              int hypothesis_index) const;
  // FitHypothesis of hypotheses[indices[k]] for every k, with every
  // (hypothesis, candidate) pair fitted on its own across the cores: the
  // same fits to the bit.
  std::vector<HypothesisFit> FitHypotheses(
      const PreparedScan& scan,
      const std::vector<DetectionDebug::Hypothesis>& hypotheses,
      const std::vector<int>& indices) const;
  // FitHypothesis's pieces: the scene around a hypothesis, and one candidate
  // (`rank` into its candidate models) fitted there (none when RANSAC found
  // no pose).
  HypothesisRegion RegionOf(const PreparedScan& scan,
                            const DetectionDebug::Hypothesis& hypothesis) const;
  std::optional<CandidateFit> FitCandidate(const PreparedScan& scan,
                                           const DetectionDebug::Hypothesis& hypothesis,
                                           const HypothesisRegion& region,
                                           int hypothesis_index,
                                           int rank) const;
  // Stage 7: the best fit verified (`fit.best` must be set).
  FitVerification VerifyFit(const PreparedScan& scan, const HypothesisFit& fit) const;
  // Stage 8: features, probability, gates and outcome of a verified fit.
  HypothesisScore ScoreHypothesis(const PreparedScan& scan,
                                  const DetectionDebug::Hypothesis& hypothesis,
                                  const HypothesisFit& fit,
                                  const FitVerification& verification) const;
  // Stages 6-8 for every hypothesis (both cores); their outcomes, fits and
  // features recorded in `hypotheses`.
  std::vector<FittedHypothesis> FitAndVerify(
      const PreparedScan& scan, std::vector<DetectionDebug::Hypothesis>* hypotheses) const;
  // Best score first, drops detections that better ones explain or overlap;
  // returns the indices of the kept hypotheses in that order.
  std::vector<int> Suppress(const PreparedScan& scan,
                            const std::vector<FittedHypothesis>& fits,
                            std::vector<DetectionDebug::Hypothesis>* hypotheses) const;

  // Whether detection scores are the scorer's probabilities.
  bool scored() const;
  // Whether hypotheses come from the learned vote map.
  bool learned() const;

  const TrainedModel& model() const;
  const DetectorOptions& options() const;
  // The thresholds detections are kept at (DetectorOptions::all_candidates:
  // none).
  const OperatingPoint& operating_point() const;

 private:
  // The hypothesis sources run the stages above on the detector's model.
  friend class CodebookSource;
  friend class LearnedSource;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Structure (walls and the like): segments wider than `max_extent` or
// reaching above `max_height`, which no model explains, and every point on
// the vertical plane of such a segment within its span (Kinect noise breaks
// a wall seen head-on into many small segments). Returns a flag per point of
// view.cloud; `segment_flags` gets one per segment, set when most of its
// points are structure. Detection leaves structure out of voting and fitting.
std::vector<char> FindStructure(const ViewSegments& view,
                                double max_extent,
                                float max_height,
                                std::vector<char>* segment_flags);

}  // namespace furn

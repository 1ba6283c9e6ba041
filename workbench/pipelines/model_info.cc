#include "workbench/pipelines/model_info.h"

#include <cstdio>
#include <map>
#include <sstream>

#include "core/codebook/hypothesis_scorer.h"
#include "core/geometry/mesh.h"  // ShortHash
#include "core/learned/vote_net.h"
#include "core/util/file_util.h"
#include "core/util/text.h"
#include "reports/evaluation.h"

namespace furn {

namespace {

// What a vote network was trained to regress, as `model info` prints it.
std::string TargetsText(const BevCoderOptions& coder) {
  std::string text = coder.dense_votes ? "dense votes" : "centre cell";
  if (!coder.dense_votes && coder.centre_radius_cells > 0) {
    std::ostringstream radius;
    radius << coder.centre_radius_cells;
    text += " and the cells within " + radius.str() + " of it";
  }
  if (coder.edge_votes) text += ", edge votes";
  return text;
}

}  // namespace

std::string DescribeTrainedModel(const TrainedModel& model) {
  std::ostringstream out;
  std::map<std::string, int> per_class;
  for (FurnitureClass c : model.model_classes) ++per_class[ClassName(c)];
  out << "models:      " << model.model_names.size() << " (";
  bool first = true;
  for (const auto& [name, count] : per_class) {
    out << (first ? "" : ", ") << name << " " << count;
    first = false;
  }
  const VocabularyOptions& v = model.options.vocabulary;
  out << ")\nsegments:    " << model.training_segments
      << "\nvocabulary:  " << (v.kind == VocabularyKind::kRim ? "RIM" : "k-means") << " ("
      << (v.kind == VocabularyKind::kRim
              ? (v.rim_init == RimInit::kPcaSplit ? "PCA-split init, " : "k-means init, ")
              : "")
      << model.vocabulary.NumWords() << " words, " << model.vocabulary.NumUsedWords()
      << " used, seed " << v.seed << ")\nshape model: " << model.shape.size()
      << " entries\nsegmentation: voxel " << model.options.preprocess.voxel_size_m
      << " m, normal radius " << model.options.preprocess.normal_radius_m << " m, delta "
      << model.options.region_growing.delta_m << " m, alpha "
      << model.options.region_growing.alpha_deg << " deg, min segment "
      << model.options.region_growing.min_segment_size << " points\n";
  const PartSubsetOptions& p = model.options.part_subsets;
  out << "part subsets: " << model.part_models.size() << " of " << p.min_subset_size << "-"
      << p.max_subset_size << " segments, at most " << p.max_subsets_per_view
      << " per view, VFH size component " << (p.vfh_size_component ? "on" : "off") << "\n";
  if (model.scorer.empty()) {
    out << "scorer:      none (fixed verification gates)\n";
  } else {
    const HypothesisScorer scorer =
        HypothesisScorer::Deserialize(model.scorer, "the model's scorer");
    out << "scorer:      random forest from " << scorer.training_samples()
        << " hypotheses, Platt a " << scorer.platt_a() << " b " << scorer.platt_b() << "\n";
  }
  if (model.vote_net.empty()) {
    out << "vote net:    none (codebook voting)\n";
  } else {
    const VoteNet net = VoteNet::Deserialize(model.vote_net, "the model's vote network");
    const BevGridSpec& grid = net.options().grid;
    out << "vote net:    "
        << (net.Members() > 1 ? "an ensemble of " + std::to_string(net.Members()) + " U-Nets"
                              : std::string("U-Net"))
        << ", " << net.options().levels << " halvings, " << net.Parameters()
        << " parameters, width " << net.options().width << "; BEV grid " << grid.rows << " x "
        << grid.cols << " cells of " << grid.cell_m << " m, points within " << net.options().range_m
        << " m (" << model.vote_net.size() / 1024
        << " KiB); targets: " << TargetsText(net.options().coder) << "\n"
        << "vote net input: " << DescribeVoteNetInput(model.vote_net_input) << "\n";
  }
  out << "score:       " << ScoreMeaning(model) << "\n";
  out << DescribeOperatingPoint(model.operating_point);
  return out.str();
}

std::string ScoreMeaning(const TrainedModel& model) {
  if (!model.vote_net.empty())
    return "the vote network's heat at the maximum (0..1): a ranking, not a calibrated "
           "probability; the operating point's threshold per class is the decision";
  if (!model.scorer.empty())
    return "the scorer's probability that the hypothesis is an object of its class within "
           "10 cm (Platt-scaled on crossval hypotheses; calibrated on synthetic rooms only)";
  return "the fixed gates' product: a ranking, not a probability";
}

std::string DescribeVoteNetInput(const VoteNetInput& input) {
  if (!input.recorded) return "not recorded (a model file older than format 10)";
  if (!input.Fused()) return "single frames";
  std::ostringstream out;
  out << "fused frames in " << input.fused_share * 100 << " % of its training";
  if (input.pose_noise_m > 0 || input.pose_noise_deg > 0) {
    out << ", their room-mates off by " << input.pose_noise_m * 100 << " cm / "
        << input.pose_noise_deg << " deg" << (input.planar ? " (x, y and yaw)" : "");
  } else {
    out << ", exact poses";
  }
  return out.str();
}

std::string VoteNetInputNote(const TrainedModel& model,
                             const std::string& model_path,
                             bool fused_input) {
  if (model.vote_net.empty()) return "";
  if (fused_input && model.vote_net_input.SingleFrames())
    return model_path +
           ": its vote network was trained on single frames; for fused scans a model trained "
           "with --vote-fused-share 0.5 --vote-fused-pose-noise 0.02,1 finds more, and needs no "
           "registration for poses off by up to about 2 cm / 1 deg (docs/detection.md)";
  if (!fused_input && model.vote_net_input.Fused())
    return model_path + ": its vote network was trained for fused scans (" +
           DescribeVoteNetInput(model.vote_net_input) +
           "); on single frames a model trained without --vote-fused-share finds more tables "
           "(docs/detection.md)";
  return "";
}

std::string DescribeOperatingPoint(const OperatingPoint& point) {
  if (point.Empty()) return "operating point: none (every candidate is a detection)\n";
  std::ostringstream out;
  out << "operating point: least score per class, chosen for the best F1 at " << point.match_m * 100
      << " cm on " << PrintableText(point.chosen_on) << "\n";
  for (FurnitureClass c : kAllClasses) {
    const ClassOperatingPoint& entry = point.classes[static_cast<size_t>(c)];
    if (entry.min_score < 0 && entry.targets == 0) continue;
    char line[160];
    if (entry.min_score < 0) {
      std::snprintf(line,
                    sizeof(line),
                    "  %-10s none (%d objects; nothing found to choose on)\n",
                    ClassName(c),
                    entry.targets);
    } else if (entry.targets == 0) {
      std::snprintf(line,
                    sizeof(line),
                    "  %-10s %.3f (no objects to choose on: every class's detections pooled)\n",
                    ClassName(c),
                    entry.min_score);
    } else {
      std::snprintf(line,
                    sizeof(line),
                    "  %-10s %.3f  precision %.2f recall %.2f F1 %.2f (%d objects%s)\n",
                    ClassName(c),
                    entry.min_score,
                    entry.precision,
                    entry.recall,
                    entry.f1,
                    entry.targets,
                    entry.targets < kOwnOperatingPointObjects
                        ? "; too few for its own: every class's detections pooled"
                        : "");
    }
    out << line;
  }
  return out.str();
}

std::string ModelFileHash(const std::string& path) { return ShortHash(ReadFileBytes(path), 32); }

}  // namespace furn

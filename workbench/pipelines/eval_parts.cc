#include "workbench/pipelines/eval_parts.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>

#include "core/codebook/segment_view.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "core/util/random.h"
#include "reports/confusion.h"

namespace furn {
namespace {

struct Subset {
  VfhDescriptor descriptor;
  int view = 0;
  int model_index = 0;
};

void MeanStd(const std::vector<double>& values, double* mean, double* stddev) {
  double sum = 0, sum2 = 0;
  for (double v : values) {
    sum += v;
    sum2 += v * v;
  }
  *mean = sum / values.size();
  *stddev = std::sqrt(std::max(0.0, sum2 / values.size() - *mean * *mean));
}

}  // namespace

PartSplit ParsePartSplit(const std::string& text) {
  if (text == "view") return PartSplit::kByView;
  if (text == "subset") return PartSplit::kBySubset;
  throw InputError("split '" + text + "' must be view or subset");
}

const char* PartSplitName(PartSplit split) {
  return split == PartSplit::kByView ? "view" : "subset";
}

namespace {

// Every view's part subsets and their VFHs, in parallel, in view order.
std::vector<Subset> DescribeSubsets(const std::vector<TrainingView>& views,
                                    const TrainerOptions& trainer,
                                    const PartSubsetOptions& options) {
  std::vector<std::vector<Subset>> per_view(views.size());
  Progress progress("part subsets", views.size(), "views");
  std::mutex progress_mutex;
  ParallelFor(0, static_cast<int>(views.size()), [&](int v) {
    const ViewSegments segmented = SegmentView(views[v].points, views[v].sensor_origin, trainer);
    for (const std::vector<int>& subset : PartSubsets(segmented, options)) {
      per_view[v].push_back({ComputeVfh(segmented.cloud,
                                        PointsOfSegments(segmented, subset),
                                        views[v].sensor_origin,
                                        options.vfh_size_component),
                             v,
                             views[v].model_index});
    }
    std::lock_guard<std::mutex> lock(progress_mutex);
    progress.Advance();
  });
  progress.Finish();
  std::vector<Subset> subsets;
  for (const auto& v : per_view) subsets.insert(subsets.end(), v.begin(), v.end());
  Require(!subsets.empty(), "the views yield no part subsets");
  return subsets;
}

// One repetition: a random split (per view or per subset), the library of
// the training subsets, and each test subset classified by the majority of
// its k nearest (a tie goes to the model met first, the nearer).
void RunRepetition(const std::vector<Subset>& subsets,
                   size_t views,
                   const TrainedModel& model,
                   const PartEvaluationOptions& options,
                   int repetition,
                   const std::map<FurnitureClass, int>& class_index,
                   PartEvaluation* result) {
  Rng rng(DeriveSeed(options.seed, static_cast<uint64_t>(repetition)));
  // A draw per view or per subset, in their order (the same seed, the same split).
  std::vector<bool> is_test(options.split == PartSplit::kByView ? views : subsets.size());
  for (size_t k = 0; k < is_test.size(); ++k) is_test[k] = rng.Uniform01() < options.test_fraction;
  auto tested_subset = [&](size_t k) {
    return is_test[options.split == PartSplit::kByView ? static_cast<size_t>(subsets[k].view) : k];
  };
  std::vector<VfhDescriptor> library;
  std::vector<int> library_model;
  for (size_t k = 0; k < subsets.size(); ++k) {
    if (tested_subset(k)) continue;
    library.push_back(subsets[k].descriptor);
    library_model.push_back(subsets[k].model_index);
  }
  Require(!library.empty(),
          std::string("every ") + PartSplitName(options.split) +
              " fell in the test split; use more views");
  const PartSubsetIndex index(library, options.index_dimensions);
  int64_t tested = 0, model_hits = 0, class_hits = 0;
  for (size_t k = 0; k < subsets.size(); ++k) {
    if (!tested_subset(k)) continue;
    const Subset& s = subsets[k];
    std::map<int, int> votes;
    int predicted = -1, best_votes = 0;
    for (int neighbour : index.Nearest(s.descriptor, options.neighbours)) {
      const int candidate = library_model[neighbour];
      if (++votes[candidate] > best_votes) {
        best_votes = votes[candidate];
        predicted = candidate;
      }
    }
    const FurnitureClass truth = model.model_classes[s.model_index];
    const FurnitureClass guess = model.model_classes[predicted];
    ++tested;
    model_hits += predicted == s.model_index;
    class_hits += guess == truth;
    ++result->confusion[class_index.at(truth)][class_index.at(guess)];
    ++result->model_confusion[s.model_index][predicted];
  }
  result->model_accuracy.push_back(tested ? static_cast<double>(model_hits) / tested : 0);
  result->category_accuracy.push_back(tested ? static_cast<double>(class_hits) / tested : 0);
}

void CheckPartEvaluationOptions(const PartEvaluationOptions& options) {
  Require(options.repetitions >= 1 && options.repetitions <= 100, "repetitions must be in 1..100");
  Require(options.test_fraction > 0 && options.test_fraction < 1,
          "test fraction must be in (0, 1)");
  Require(options.neighbours >= 1 && options.neighbours <= 50, "neighbours (k) must be in 1..50");
  Require(options.index_dimensions >= 1 && options.index_dimensions <= 308,
          "index dimensions " + std::to_string(options.index_dimensions) + " must be in 1..308");
  options.subsets.Check();
}

}  // namespace

PartEvaluation EvaluatePartSubsets(const Catalog& catalog,
                                   const TrainedModel& model,
                                   const PartEvaluationOptions& options) {
  CheckPartEvaluationOptions(options);
  const LoadedModels loaded = catalog.LoadModels(model.model_names, /*show_progress=*/false);
  loaded.RequireAll();
  std::vector<TrainingView> views;
  for (size_t m = 0; m < loaded.models.size(); ++m) {
    std::vector<TrainingView> v =
        ScanModel(loaded.models[m], static_cast<int>(m), model.model_classes[m], options.scan);
    views.insert(views.end(), std::make_move_iterator(v.begin()), std::make_move_iterator(v.end()));
  }
  const std::vector<Subset> subsets = DescribeSubsets(views, model.options, options.subsets);
  PartEvaluation result;
  result.views = static_cast<int>(views.size());
  result.subsets = static_cast<int>(subsets.size());
  std::map<FurnitureClass, int> class_index;
  for (FurnitureClass c : model.model_classes) class_index.emplace(c, 0);
  for (auto& [c, index] : class_index) {
    index = static_cast<int>(result.classes.size());
    result.classes.push_back(ClassName(c));
  }
  result.confusion.assign(result.classes.size(), std::vector<int64_t>(result.classes.size(), 0));
  result.split = options.split;
  result.model_names = model.model_names;
  result.model_confusion.assign(model.model_names.size(),
                                std::vector<int64_t>(model.model_names.size(), 0));
  for (int repetition = 0; repetition < options.repetitions; ++repetition)
    RunRepetition(subsets, views.size(), model, options, repetition, class_index, &result);
  MeanStd(result.model_accuracy, &result.model_mean, &result.model_std);
  MeanStd(result.category_accuracy, &result.category_mean, &result.category_std);
  return result;
}

void WritePartEvaluation(const PartEvaluation& result, const std::string& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  Require(std::filesystem::is_directory(out_dir, ec),
          out_dir + ": cannot create the output directory");
  nlohmann::ordered_json json{
      {"protocol",
       std::string("C: part-subset classification, 80/20 by ") + PartSplitName(result.split)},
      {"views", result.views},
      {"subsets", result.subsets},
      {"cad_model_accuracy",
       {{"mean", result.model_mean},
        {"std", result.model_std},
        {"per_repetition", result.model_accuracy}}},
      {"category_accuracy",
       {{"mean", result.category_mean},
        {"std", result.category_std},
        {"per_repetition", result.category_accuracy}}},
      {"classes", result.classes},
      {"confusion_true_by_predicted", result.confusion},
      {"cad_models", result.model_names},
      {"cad_model_confusion_true_by_predicted", result.model_confusion}};
  WriteFileAtomically((std::filesystem::path(out_dir) / "parts.json").string(),
                      json.dump(2) + "\n");
  WriteConfusionPng(result.classes,
                    result.confusion,
                    "Part-subset category",
                    (std::filesystem::path(out_dir) / "confusion.png").string());
  WriteConfusionPng(result.model_names,
                    result.model_confusion,
                    "Part-subset CAD model",
                    (std::filesystem::path(out_dir) / "confusion_models.png").string());
}

}  // namespace furn

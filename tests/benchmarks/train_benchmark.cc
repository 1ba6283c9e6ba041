// Training on the default catalog (procedural without the package): virtual
// scans, segmentation and features, part subsets and VFH, vocabulary (RIM),
// shape model, saving. Target (SPEC.md §13): <= 120 s on 2 cores. One run;
// the counters give each stage's seconds. The vote network: its training
// step, inference, and where its training's time goes by stage
// (BM_VoteNetTrainingStages).
//
//   build/tests/benchmarks/train_benchmark
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <random>

#include "core/learned/vote_net.h"
#include "core/learned/vote_net_training.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "tests/benchmarks/benchmark_precision.h"
#include "workbench/pipelines/train.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {
namespace {

void BM_TrainDefaultCatalog(benchmark::State& state) {
  Progress::SetQuiet(true);
  const Catalog catalog = OpenCatalog("default");
  const std::string path =
      (std::filesystem::temp_directory_path() / "furn_train_benchmark.fcm").string();
  TrainSummary summary;
  for (auto _ : state) summary = TrainFromCatalog(catalog, ScanOptions{}, TrainerOptions{}, path);
  state.counters["models"] = summary.models;
  state.counters["views"] = summary.views;
  state.counters["segments"] = summary.segments;
  state.counters["scan_s"] = summary.scan_s;
  state.counters["segment_s"] = summary.stages.segment_s;
  state.counters["subsets_s"] = summary.stages.part_subsets_s;
  state.counters["vocabulary_s"] = summary.stages.vocabulary_s;
  state.counters["shape_s"] = summary.stages.shape_s;
  std::filesystem::remove(path);
}
BENCHMARK(BM_TrainDefaultCatalog)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

// The vote network (issue 30): one training step and one inference on the
// default grid (72 x 96 cells), random images. Args: batch, width, torch
// threads, bf16 (1: NetworkPrecision::kBfloat16, skipped on a CPU without
// it; 0: float). Counters: frames per second through training.
BevImage RandomImage(std::mt19937_64* random) {
  BevImage image;
  image.values.resize(static_cast<size_t>(kBevChannels) * image.spec.rows * image.spec.cols);
  std::uniform_real_distribution<float> value(0, 1);
  for (float& v : image.values) v = value(*random) < 0.9f ? 0.0f : value(*random);
  return image;
}

// The network in the arithmetic of a benchmark argument (false: skipped).
bool SetBenchmarkPrecision(int64_t bf16_arg, VoteNet* net, benchmark::State* state) {
  const std::optional<NetworkPrecision> precision = BenchmarkPrecision(bf16_arg, state);
  if (precision) net->SetPrecision(*precision);
  return precision.has_value();
}

void BM_VoteNetTrainStep(benchmark::State& state) {
  const int batch = static_cast<int>(state.range(0));
  VoteNetOptions options;
  options.width = static_cast<int>(state.range(1));
  SetTorchThreads(static_cast<int>(state.range(2)));
  VoteNet net = VoteNet::Create(options, 1);
  if (!SetBenchmarkPrecision(state.range(3), &net, &state)) return;
  VoteNetOptimizer optimizer(&net, VoteNetLossWeights{});
  std::mt19937_64 random(1);
  TrainingBatch training;
  for (int i = 0; i < batch; ++i) {
    training.images.push_back(RandomImage(&random));
    training.targets.push_back(EncodeBevTargets(
        {{{1.5, 0.2, 0.5, 0.5, 0.5}, FurnitureClass::kChair}}, training.images.back(), {}));
  }
  for (auto _ : state) benchmark::DoNotOptimize(optimizer.Step(training, 1e-3));
  state.counters["frames_per_s"] = benchmark::Counter(
      static_cast<double>(batch) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["parameters"] = static_cast<double>(net.Parameters());
}
BENCHMARK(BM_VoteNetTrainStep)
    ->Args({16, 16, 2, 0})
    ->Args({16, 16, 2, 1})
    ->Args({16, 16, 1, 0})
    ->Args({16, 16, 1, 1})
    ->Args({4, 16, 2, 0})
    ->Args({16, 12, 2, 0})
    ->Args({16, 8, 2, 0})
    ->ArgNames({"batch", "width", "threads", "bf16"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One update of the weight average (--vote-average) after a step, on the
// default network: its cost beside BM_VoteNetTrainStep's. Arg: torch threads.
void BM_VoteNetWeightAverageUpdate(benchmark::State& state) {
  SetTorchThreads(static_cast<int>(state.range(0)));
  const VoteNet net = VoteNet::Create(VoteNetOptions{}, 1);
  VoteNetWeightAverage average(net, 0.999);
  for (auto _ : state) average.Update(net);
  state.counters["parameters"] = static_cast<double>(net.Parameters());
}
BENCHMARK(BM_VoteNetWeightAverageUpdate)
    ->Arg(1)
    ->ArgName("threads")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_VoteNetPredict(benchmark::State& state) {
  VoteNetOptions options;
  options.width = static_cast<int>(state.range(0));
  SetTorchThreads(static_cast<int>(state.range(1)));
  VoteNet net = VoteNet::Create(options, 1);
  if (!SetBenchmarkPrecision(state.range(2), &net, &state)) return;
  std::mt19937_64 random(1);
  const BevImage image = RandomImage(&random);
  for (auto _ : state) benchmark::DoNotOptimize(net.Predict(image).values.size());
}
BENCHMARK(BM_VoteNetPredict)
    ->Args({16, 1, 0})
    ->Args({16, 1, 1})
    ->Args({16, 2, 0})
    ->Args({16, 2, 1})
    ->ArgNames({"width", "threads", "bf16"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Where the vote network's training time goes (issue 70): `train`'s vote
// net path at the default budget's shapes (the default catalog, grid,
// network, batch, 4 frames per room, one epoch, torch's default 2 threads)
// on `rooms` rooms, each stage per unit (ms per room generated, per frame
// read and rasterised, per training frame and epoch for the step's parts,
// per validation frame and epoch), and the default budget (2400 rooms x 10
// epochs) projected from them in seconds (default_budget_s, each stage's
// share in *_share).
void BM_VoteNetTrainingStages(benchmark::State& state) {
  Progress::SetQuiet(true);
  const Catalog catalog = OpenCatalog("default");
  const std::string path =
      (std::filesystem::temp_directory_path() / "furn_train_benchmark_rooms.db").string();
  VoteNetTrainingOptions options;
  options.rooms = static_cast<int>(state.range(0));
  options.epochs = 1;
  options.quiet = true;
  VoteNetTrainingSummary summary;
  for (auto _ : state) {
    state.PauseTiming();
    RemoveDatabaseFiles(path);
    summary = VoteNetTrainingSummary{};
    state.ResumeTiming();
    TrainVoteNet(catalog, {}, options, path, &summary);
  }
  RemoveDatabaseFiles(path);
  const VoteNetStageTimes& t = summary.stages;
  const double rooms = summary.rooms, frames = summary.frames + summary.validation_frames;
  const double train = summary.frames, validation = std::max(1, summary.validation_frames);
  const VoteNetTrainingOptions budget;  // the default's rooms and epochs
  const double scale_rooms = budget.rooms / rooms;
  const std::vector<std::pair<std::string, double>> projected = {
      {"generate", t.generate_s * scale_rooms},
      {"read", t.read_s * scale_rooms},
      {"raster", t.raster_s * scale_rooms},
      {"batch", t.batch_s * scale_rooms * budget.epochs},
      {"tensors", t.tensors_s * scale_rooms * budget.epochs},
      {"forward", t.forward_s * scale_rooms * budget.epochs},
      {"backward", t.backward_s * scale_rooms * budget.epochs},
      {"adam", t.update_s * scale_rooms * budget.epochs},
      {"validation", t.validation_s * scale_rooms * budget.epochs},
      {"operating_point", t.operating_point_s * scale_rooms},
  };
  double total = 0;
  for (const auto& [name, seconds] : projected) total += seconds;
  state.counters["generate_ms_per_room"] = 1000 * t.generate_s / rooms;
  state.counters["read_ms_per_frame"] = 1000 * t.read_s / frames;
  state.counters["raster_ms_per_frame"] = 1000 * t.raster_s / frames;
  state.counters["batch_ms_per_frame"] = 1000 * t.batch_s / train;
  state.counters["tensors_ms_per_frame"] = 1000 * t.tensors_s / train;
  state.counters["forward_ms_per_frame"] = 1000 * t.forward_s / train;
  state.counters["backward_ms_per_frame"] = 1000 * t.backward_s / train;
  state.counters["adam_ms_per_frame"] = 1000 * t.update_s / train;
  state.counters["validation_ms_per_frame"] = 1000 * t.validation_s / validation;
  state.counters["default_budget_s"] = total;
  for (const auto& [name, seconds] : projected) state.counters[name + "_share"] = seconds / total;
}
BENCHMARK(BM_VoteNetTrainingStages)
    ->Arg(40)
    ->ArgName("rooms")
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

// Training on the default catalog (procedural without the package): virtual
// scans, segmentation and features, part subsets and VFH, vocabulary (RIM),
// shape model, saving. Target (SPEC.md §13): <= 120 s on 2 cores. One run;
// the counters give each stage's seconds.
//
//   build/tests/benchmarks/train_benchmark
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include "core/learned/vote_net.h"
#include "core/learned/vote_net_training.h"
#include "core/progress.h"
#include "workbench/pipelines/train.h"

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
// threads. Counters: frames per second through training.
BevImage RandomImage(std::mt19937_64* random) {
  BevImage image;
  image.values.resize(static_cast<size_t>(kBevChannels) * image.spec.rows * image.spec.cols);
  std::uniform_real_distribution<float> value(0, 1);
  for (float& v : image.values) v = value(*random) < 0.9f ? 0.0f : value(*random);
  return image;
}

void BM_VoteNetTrainStep(benchmark::State& state) {
  const int batch = static_cast<int>(state.range(0));
  VoteNetOptions options;
  options.width = static_cast<int>(state.range(1));
  SetTorchThreads(static_cast<int>(state.range(2)));
  VoteNet net = VoteNet::Create(options, 1);
  VoteNetOptimizer optimizer(&net, VoteNetLossWeights{});
  std::mt19937_64 random(1);
  TrainingBatch training;
  for (int i = 0; i < batch; ++i) {
    training.images.push_back(RandomImage(&random));
    training.targets.push_back(EncodeBevTargets(
        {{FurnitureClass::kChair, {1.5, 0.2}, 0.5, 0.5, 0.5}}, training.images.back(), {}));
  }
  for (auto _ : state) benchmark::DoNotOptimize(optimizer.Step(training, 1e-3));
  state.counters["frames_per_s"] = benchmark::Counter(
      static_cast<double>(batch) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["parameters"] = static_cast<double>(net.Parameters());
}
BENCHMARK(BM_VoteNetTrainStep)
    ->Args({16, 16, 2})
    ->Args({16, 16, 1})
    ->Args({4, 16, 2})
    ->Args({16, 12, 2})
    ->Args({16, 8, 2})
    ->ArgNames({"batch", "width", "threads"})
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
  const VoteNet net = VoteNet::Create(options, 1);
  std::mt19937_64 random(1);
  const BevImage image = RandomImage(&random);
  for (auto _ : state) benchmark::DoNotOptimize(net.Predict(image).values.size());
}
BENCHMARK(BM_VoteNetPredict)
    ->Args({16, 1})
    ->Args({16, 2})
    ->ArgNames({"width", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

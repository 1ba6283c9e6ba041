// Training on the default catalog (procedural without the package): virtual
// scans, segmentation and features, part subsets and VFH, vocabulary (RIM),
// shape model, saving. Target (SPEC.md §13): <= 120 s on 2 cores. One run;
// the counters give each stage's seconds.
//
//   build/tests/benchmarks/train_benchmark
#include <benchmark/benchmark.h>

#include <filesystem>

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

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

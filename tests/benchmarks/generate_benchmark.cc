// End-to-end dataset generation (compose, load, render, sensor model, ground
// truth, PNG encoding, SQLite insert) on the default catalog, or the
// procedural one without the package. Target (SPEC.md §13): >= 50 labelled
// frames/s on 2 cores. `workbench generate` prints the same per-stage split.
//
//   build/tests/benchmarks/generate_benchmark
#include <benchmark/benchmark.h>

#include <filesystem>

#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "workbench/pipelines/generate.h"

namespace furn {
namespace {

void BM_GenerateFrames(benchmark::State& state) {
  Progress::SetQuiet(true);
  const Catalog catalog = OpenCatalog("default");
  const std::string path =
      (std::filesystem::temp_directory_path() / "furn_generate_benchmark.db").string();
  GenerateOptions options;
  options.rooms = static_cast<int>(state.range(0));
  options.room.frames_per_room = 4;
  GenerateSummary last;
  uint64_t seed = 0;
  for (auto _ : state) {
    state.PauseTiming();
    RemoveDatabaseFiles(path);
    options.seed = ++seed;
    state.ResumeTiming();
    last = GenerateDataset(catalog, options, path);
  }
  state.counters["frames/s"] =
      benchmark::Counter(last.frames_written, benchmark::Counter::kIsIterationInvariantRate);
  const double frames = last.frames_written;
  state.counters["render_ms"] = 1000 * last.render_s / frames;
  state.counters["truth_ms"] = 1000 * last.ground_truth_s / frames;
  state.counters["png_ms"] = 1000 * last.encode_s / frames;
  state.counters["db_ms"] = 1000 * last.insert_s / frames;
  state.counters["load_ms"] = 1000 * last.load_s / frames;
  RemoveDatabaseFiles(path);
}
// 8 rooms: model import weighs in (about 60 models for 32 frames); 50 rooms
// (the README's command): import is spread over 200 frames. Stage counters
// are thread-milliseconds per frame, summed over the workers.
BENCHMARK(BM_GenerateFrames)
    ->Arg(8)
    ->Arg(50)
    ->ArgName("rooms")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(5);

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

// Catalog import speed: opening the default catalog (three .sh3f zips and the
// class map) and loading each classified model (zip read, assimp OBJ import,
// Sweet Home 3D normalisation). Falls back to the procedural catalog when the
// package is absent.
//
//   build/tests/benchmarks/catalog_benchmark
#include <benchmark/benchmark.h>

#include "scenes/catalog.h"

namespace furn {
namespace {

void BM_OpenDefaultCatalog(benchmark::State& state) {
  for (auto _ : state) {
    Catalog catalog = OpenCatalog("default");
    benchmark::DoNotOptimize(catalog.entries().size());
  }
}
BENCHMARK(BM_OpenDefaultCatalog)->Unit(benchmark::kMillisecond);

void BM_LoadAllClassifiedModels(benchmark::State& state) {
  const Catalog catalog = OpenCatalog("default");
  std::vector<std::string> ids;
  for (const CatalogEntry* entry : catalog.Classified()) ids.push_back(entry->id);
  size_t triangles = 0;
  for (auto _ : state) {
    triangles = 0;
    for (const std::string& id : ids) triangles += catalog.LoadModel(id).mesh.NumTriangles();
  }
  state.counters["models"] = static_cast<double>(ids.size());
  state.counters["triangles"] = static_cast<double>(triangles);
  state.counters["models/s"] = benchmark::Counter(static_cast<double>(ids.size()),
                                                  benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_LoadAllClassifiedModels)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

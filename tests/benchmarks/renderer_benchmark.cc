// Renderer speed on a furnished room of ~50k triangles at 640x480 (SPEC.md
// §13): ideal depth + ids + normals by OSMesa (target <= 8 ms) and by Embree
// (<= 10 ms, acceleration structures built once per mesh and scene, their
// cost measured apart), the sensor model alone, and a full noisy frame (<= 12 ms).
//
//   build/tests/benchmarks/renderer_benchmark
#include <benchmark/benchmark.h>

#include "renderers/embree_caster.h"
#include "renderers/kinect_simulator.h"
#include "renderers/osmesa_renderer.h"
#include "tests/renderers/render_fixtures.h"

namespace furn {
namespace {

constexpr size_t kTriangles = 50000;

const Scene& Room() {
  static const Scene room = testing::FurnishedRoom(1, kTriangles);
  return room;
}

void SetCounters(benchmark::State& state) {
  state.counters["triangles"] = static_cast<double>(Room().NumTriangles());
  state.counters["frames/s"] = benchmark::Counter(1, benchmark::Counter::kIsIterationInvariantRate);
}

// Ideal frames of one room, with or without normals (the bar of SPEC.md §13
// is for depth + ids). The first render uploads meshes or builds the BVH.
template <class Renderer, bool kNormals>
void BM_Ideal(benchmark::State& state) {
  Renderer renderer;
  renderer.set_compute_normals(kNormals);
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  DepthFrame frame;
  renderer.RenderInto(Room(), camera, testing::FurnishedRoomCamera(), &frame);
  for (auto _ : state) {
    renderer.RenderInto(Room(), camera, testing::FurnishedRoomCamera(), &frame);
    benchmark::DoNotOptimize(frame.depth.data());
  }
  SetCounters(state);
}
BENCHMARK(BM_Ideal<OsMesaRenderer, false>)
    ->Name("BM_OsMesaDepthAndIds")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Ideal<OsMesaRenderer, true>)
    ->Name("BM_OsMesaIdeal")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Ideal<EmbreeCaster, false>)
    ->Name("BM_EmbreeDepthAndIds")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Ideal<EmbreeCaster, true>)
    ->Name("BM_EmbreeIdeal")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Scene set-up: with new meshes, their object-space structures are built
// (once per mesh for the process); with meshes built before, as for catalog
// models reused across rooms, only the top-level structure over the instances.
void BM_EmbreeSceneBuild(benchmark::State& state) {
  const bool new_meshes = state.range(0) != 0;
  for (auto _ : state) {
    state.PauseTiming();
    auto scene = std::make_unique<Scene>(Room());
    if (new_meshes) {
      for (SceneObject& object : scene->objects)
        object.mesh = std::make_shared<const TriangleMesh>(*object.mesh);
    }
    auto caster = std::make_unique<EmbreeCaster>();
    state.ResumeTiming();
    caster->SetScene(*scene);
    state.PauseTiming();  // freeing is not set-up
    caster.reset();
    scene.reset();
    state.ResumeTiming();
  }
  SetCounters(state);
}
BENCHMARK(BM_EmbreeSceneBuild)
    ->ArgName("new_meshes")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_KinectNoiseOnly(benchmark::State& state) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const DepthFrame ideal = OsMesaRenderer().Render(Room(), camera, testing::FurnishedRoomCamera());
  KinectNoiseModel model{KinectNoiseOptions{}};
  DepthFrame noisy;
  uint64_t seed = 0;
  for (auto _ : state) {
    model.Apply(ideal, camera, ++seed, &noisy);
    benchmark::DoNotOptimize(noisy.depth.data());
  }
  SetCounters(state);
}
BENCHMARK(BM_KinectNoiseOnly)->Unit(benchmark::kMillisecond)->UseRealTime();

// Render + sensor model, as the dataset generator runs them frame after frame.
template <class Renderer>
void BM_FullNoisyFrame(benchmark::State& state) {
  Renderer renderer;
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  KinectSimulator simulator(&renderer, KinectNoiseOptions{});
  simulator.Capture(Room(), camera, testing::FurnishedRoomCamera(), 0);
  uint64_t seed = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        simulator.Capture(Room(), camera, testing::FurnishedRoomCamera(), ++seed)
            .noisy.depth.data());
  }
  SetCounters(state);
}
BENCHMARK(BM_FullNoisyFrame<OsMesaRenderer>)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FullNoisyFrame<EmbreeCaster>)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

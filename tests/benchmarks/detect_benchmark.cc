// Detection of one 640x480 frame end to end (world frame, preprocessing,
// segmentation, features, occupancy, voting, maxima, ranking, fitting,
// verification, suppression) over frames of a generated dataset, with the
// model the main job trains. Target (SPEC.md §13): median <= 100 ms on
// 2 cores. Reports the median total and per-stage medians as counters.
// BM_DetectRealFrame does the same over the real scans of data/real/;
// BM_DetectFusedFrame over the same frames each fused with its room's
// other frames (detect --fuse), BM_RegisterRoomFrames times the registration
// of those room-mates (--fuse-register) with odometry-like pose error.
//
//   bash tools/quickstart.sh main      # makes out/model.fcm and out/synth.db
//   build/tests/benchmarks/detect_benchmark
//   FURN_BENCH_MODEL=m.fcm FURN_BENCH_DB=d.db build/tests/benchmarks/detect_benchmark
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "core/detector/detector.h"
#include "core/geometry/floor.h"
#include "core/geometry/scan_fusion.h"
#include "core/learned/bev_grid.h"
#include "core/learned/vote_net.h"
#include "db/dataset_db.h"
#include "tests/benchmarks/benchmark_precision.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/import_real.h"

namespace furn {
namespace {

std::string FromEnv(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value != nullptr ? value : fallback;
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// Detects in the scans in turn, one per iteration; the median of every
// stage (and of the total) as counters.
void DetectInTurn(const Detector& detector,
                  const std::vector<LoadedScan>& scans,
                  benchmark::State& state) {
  std::map<std::string, std::vector<double>> stages;
  size_t next = 0;
  for (auto _ : state) {
    const DetectionResult result = detector.Detect(scans[next++ % scans.size()].input);
    for (const StageTime& t : result.timings_ms.stages) stages[EnumName(t.stage)].push_back(t.ms);
    benchmark::DoNotOptimize(result.detections.size());
  }
  state.counters["frames"] = static_cast<double>(scans.size());
  for (const auto& [stage, ms] : stages) state.counters[stage + "_ms"] = Median(ms);
}

// The model and dataset the benchmarks read, or a skip naming them.
bool FindModelAndDataset(benchmark::State& state, std::string* model_path, std::string* db_path) {
  *model_path = FromEnv("FURN_BENCH_MODEL", FURN_SOURCE_DIR "/out/model.fcm");
  *db_path = FromEnv("FURN_BENCH_DB", FURN_SOURCE_DIR "/out/synth.db");
  if (std::filesystem::exists(*model_path) && std::filesystem::exists(*db_path)) return true;
  state.SkipWithError(("needs " + *model_path + " and " + *db_path +
                       " (run the main job, or set FURN_BENCH_MODEL / FURN_BENCH_DB)")
                          .c_str());
  return false;
}

// Every 3rd frame of the dataset (up to 27; every frame index of the rooms
// is represented), loaded once as `detect --db` loads it (with `fusion`).
std::vector<LoadedScan> EveryThirdFrame(const std::string& db_path, const FrameFusion& fusion) {
  std::vector<LoadedScan> scans;
  DatasetDb db(db_path, DatasetDb::Mode::kReadOnly);
  for (int64_t room : db.RoomIds()) {
    for (const FrameRecord& frame : db.ReadRoom(room, false).frames) {
      if (frame.id % 3 != 0 || scans.size() >= 27) continue;
      ScanSource source;
      source.db_path = db_path;
      source.frame_id = frame.id;
      source.fusion = fusion;
      scans.push_back(LoadScan(source));
    }
  }
  return scans;
}

// The network's arithmetic from a benchmark argument (false: skipped).
bool SetPrecision(int64_t bf16_arg, DetectorOptions* options, benchmark::State* state) {
  const std::optional<NetworkPrecision> precision = BenchmarkPrecision(bf16_arg, state);
  if (precision) options->network_precision = *precision;
  return precision.has_value();
}

// The real scans of data/real/ (FURN_BENCH_REAL), loaded as `detect` loads
// them; only the organised 640x480 ones when `organised640`.
std::vector<LoadedScan> RealScans(bool organised640) {
  const std::string labels = FromEnv("FURN_BENCH_REAL", FURN_SOURCE_DIR "/data/real/labels.json");
  std::vector<LoadedScan> scans;
  for (const RealScan& scan : ReadRealSet(labels).scans) {
    LoadedScan loaded = LoadScan(scan.source);
    if (!organised640 || (loaded.input.width == 640 && loaded.input.height == 480))
      scans.push_back(std::move(loaded));
  }
  return scans;
}

void BM_DetectFrame(benchmark::State& state) {
  std::string model_path, db_path;
  if (!FindModelAndDataset(state, &model_path, &db_path)) return;
  DetectorOptions options;
  options.torch_threads = static_cast<int>(state.range(0));  // the learned path's network
  options.learned_mirror_average = state.range(1) != 0;
  if (!SetPrecision(state.range(2), &options, &state)) return;
  const Detector detector(LoadTrainedModel(model_path), options);
  DetectInTurn(detector, EveryThirdFrame(db_path, FrameFusion{}), state);
}

// The same frames, each with its room's other frames fused in (exact poses),
// with the defaults (one torch thread, the mirror average).
void BM_DetectFusedFrame(benchmark::State& state) {
  std::string model_path, db_path;
  if (!FindModelAndDataset(state, &model_path, &db_path)) return;
  const Detector detector(LoadTrainedModel(model_path), DetectorOptions{});
  FrameFusion fusion;
  fusion.room_frames = true;
  DetectInTurn(detector, EveryThirdFrame(db_path, fusion), state);
}
BENCHMARK(BM_DetectFusedFrame)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(27);

// Registering each selected frame's room-mates against it (RegisterScans,
// the default options), their poses off by 2 cm / 1 degree per axis as
// `evaluate --fuse-pose-noise 0.02,1` draws them; the share of poses refined
// as a counter. Arg planar 1: the error along x and y and about z only, and
// registration in x, y and yaw (`--fuse-pose-noise 0.02,1,planar
// --fuse-planar`).
void BM_RegisterRoomFrames(benchmark::State& state) {
  std::string model_path, db_path;
  if (!FindModelAndDataset(state, &model_path, &db_path)) return;
  struct Room {
    std::vector<DetectionInput> scans;
    size_t reference = 0;
  };
  std::vector<Room> rooms;
  {
    DatasetDb db(db_path, DatasetDb::Mode::kReadOnly);
    for (int64_t id : db.RoomIds()) {
      const RoomRecord room = db.ReadRoom(id, /*with_images=*/true);
      for (const FrameRecord& frame : room.frames) {
        if (frame.id % 3 != 0 || rooms.size() >= 27 || room.frames.size() < 2) continue;
        FrameFusion fusion;  // the error `evaluate --fuse-pose-noise 0.02,1` draws
        fusion.room_frames = true;
        fusion.pose_noise_m = 0.02;
        fusion.pose_noise_deg = 1;
        fusion.planar_noise = state.range(0) != 0;
        Room r;
        r.scans = RoomScans(room, frame, fusion, db_path, &r.reference);
        rooms.push_back(std::move(r));
      }
    }
  }
  ScanRegistrationOptions registration;
  registration.planar = state.range(0) != 0;
  size_t next = 0;
  int refined = 0, registered = 0;
  for (auto _ : state) {
    const Room& room = rooms[next++ % rooms.size()];
    const std::vector<RegisteredPose> poses =
        RegisterScans(room.scans, room.reference, registration);
    for (size_t k = 0; k < poses.size(); ++k) {
      if (k == room.reference) continue;
      ++registered;
      refined += poses[k].refined;
    }
  }
  state.counters["frames"] = static_cast<double>(rooms.size());
  state.counters["refined_share"] = registered > 0 ? static_cast<double>(refined) / registered : 0;
}
BENCHMARK(BM_RegisterRoomFrames)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("planar")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(27);
// Args: the network's torch threads, --mirror-average and bf16 (the
// network's arithmetic: 1 bf16, 0 fp32; learned voting; the codebook path
// ignores them).
BENCHMARK(BM_DetectFrame)
    ->Args({1, 0, 0})
    ->Args({2, 0, 0})
    ->Args({1, 1, 0})
    ->Args({1, 1, 1})
    ->Args({2, 1, 0})
    ->ArgNames({"torch_threads", "mirror_average", "bf16"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(81);

// The vote network's input alone (RasteriseScan: the bird's-eye-view image
// of a frame's points in range, its "seen" channel by bearing), over the
// same dataset frames as BM_DetectFrame with their known poses: the
// network branch's first stage in detection and the training's
// rasterising stage.
void BM_RasteriseScan(benchmark::State& state) {
  const std::string db_path = FromEnv("FURN_BENCH_DB", FURN_SOURCE_DIR "/out/synth.db");
  if (!std::filesystem::exists(db_path)) {
    state.SkipWithError(("needs " + db_path + " (run the main job, or set FURN_BENCH_DB)").c_str());
    return;
  }
  const std::vector<LoadedScan> scans = EveryThirdFrame(db_path, FrameFusion{});
  const VoteNetOptions net;  // the default grid and range
  size_t next = 0;
  for (auto _ : state) {
    const DetectionInput& input = scans[next++ % scans.size()].input;
    const BevImage image =
        RasteriseScan(input.points, *input.world_from_camera, net.range_m, net.grid);
    benchmark::DoNotOptimize(image.values.data());
  }
  state.counters["frames"] = static_cast<double>(scans.size());
}
BENCHMARK(BM_RasteriseScan)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(270);

// Detection in the real scans of data/real/ (issue 17: median <= 150 ms on
// a 640x480 real frame, 2 cores), each loaded as `detect` would: the floor
// searched where the pose is unknown, which synthetic frames never need.
// Arg 1: the organised 640x480 scans only (the target's frames); 0: all.
// Second arg: the network's torch threads; third: bf16 (1) or fp32 (0).
void BM_DetectRealFrame(benchmark::State& state) {
  const std::string model_path = FromEnv("FURN_BENCH_MODEL", FURN_SOURCE_DIR "/out/model.fcm");
  if (!std::filesystem::exists(model_path)) {
    state.SkipWithError(("needs " + model_path + " (run the main job)").c_str());
    return;
  }
  DetectorOptions options;
  options.torch_threads = static_cast<int>(state.range(1));
  if (!SetPrecision(state.range(2), &options, &state)) return;
  const Detector detector(LoadTrainedModel(model_path), options);
  DetectInTurn(detector, RealScans(state.range(0) != 0), state);
}
BENCHMARK(BM_DetectRealFrame)
    ->Args({1, 1, 0})
    ->Args({1, 1, 1})
    ->Args({1, 2, 0})
    ->Args({0, 1, 0})
    ->ArgNames({"organised640", "torch_threads", "bf16"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(44);

// The floor RANSAC's inner loop on its sample's size (20000 points, the
// default FloorOptions::sample_points), by each code path: arg 0 SSE2 (four
// points at a time), 1 AVX2 (eight; skipped on a CPU without it). The same
// counts (tests/core/floor_test.cc).
void BM_CountNearPlane(benchmark::State& state) {
  const SimdPath path = state.range(0) == 0 ? SimdPath::kSse2 : SimdPath::kAvx2;
  if (path == SimdPath::kAvx2 && !__builtin_cpu_supports("avx2")) {
    state.SkipWithError("this CPU has no AVX2");
    return;
  }
  constexpr size_t kPoints = 20000;
  std::vector<float> x(kPoints), y(kPoints), z(kPoints);
  for (size_t i = 0; i < kPoints; ++i) {  // a floor 1.2 m below, and other points
    x[i] = static_cast<float>(i % 200) * 0.02f - 2;
    z[i] = static_cast<float>(i / 200) * 0.04f + 0.5f;
    y[i] = i % 3 == 0 ? 1.2f : static_cast<float>(i % 97) * 0.02f - 1;
  }
  const Eigen::Vector4f plane(0.05f, -0.998f, 0.03f, 1.19f);
  size_t count = 0;
  for (auto _ : state) {
    count += CountNearPlane(x, y, z, plane, 0.02, path);
    benchmark::DoNotOptimize(count);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kPoints));
}
BENCHMARK(BM_CountNearPlane)->Arg(0)->Arg(1)->ArgName("avx2")->Unit(benchmark::kMicrosecond);

// The floor found in each organised real 640x480 frame of data/real/ (what
// `detect` does first when the camera's pose is not given).
void BM_EstimateFloorRealFrame(benchmark::State& state) {
  const std::vector<LoadedScan> scans = RealScans(true);
  const DetectorOptions options;
  size_t next = 0, found = 0;
  for (auto _ : state) {
    const FloorEstimate floor = EstimateFloor(
        scans[next].input.points, options.floor, std::max(kFloorSearchRangeM, options.max_range_m));
    found += floor.found;
    next = (next + 1) % scans.size();
  }
  state.counters["frames"] = static_cast<double>(scans.size());
  state.counters["found"] = static_cast<double>(found) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_EstimateFloorRealFrame)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(45);

// Loading the model file, and loading it into a ready detector (what every
// `detect` process pays once). Target (issue 17): <= 200 ms for the default
// model.
void BM_LoadModel(benchmark::State& state) {
  const std::string model_path = FromEnv("FURN_BENCH_MODEL", FURN_SOURCE_DIR "/out/model.fcm");
  if (!std::filesystem::exists(model_path)) {
    state.SkipWithError(("needs " + model_path + " (run the main job)").c_str());
    return;
  }
  const bool detector = state.range(0) != 0;
  for (auto _ : state) {
    TrainedModel model = LoadTrainedModel(model_path);
    if (detector) {
      const Detector ready(std::move(model), DetectorOptions{});
      benchmark::DoNotOptimize(&ready);
    } else {
      benchmark::DoNotOptimize(model.shape.size());
    }
  }
  state.counters["bytes"] = static_cast<double>(std::filesystem::file_size(model_path));
}
BENCHMARK(BM_LoadModel)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("detector")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(5);

}  // namespace
}  // namespace furn

BENCHMARK_MAIN();

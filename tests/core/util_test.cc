#include <gtest/gtest.h>
#include <sched.h>
#include <sys/stat.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>
#include <thread>

#include "core/model/furniture_class.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "core/util/random.h"
#include "tests/test_util.h"

namespace furn {
namespace {

// Progress in a log (stderr not a terminal): a line per 10 %, and one at
// least every interval of slow work (issue 70: a line a minute), none when
// quiet.
size_t LinesLogged(size_t total, size_t steps, double interval_s, int sleep_ms) {
  Progress::SetLogInterval(interval_s);
  ::testing::internal::CaptureStderr();
  {
    Progress progress("work", total, "items");
    for (size_t i = 0; i < steps; ++i) {
      if (sleep_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(sleep_ms));
      progress.Advance();
    }
    progress.Finish();
  }
  const std::string text = ::testing::internal::GetCapturedStderr();
  Progress::SetLogInterval(60);
  return static_cast<size_t>(std::count(text.begin(), text.end(), '\n'));
}

TEST(Progress, LogLinesEveryTenthAndAtLeastEveryInterval) {
  if (isatty(2)) GTEST_SKIP() << "stderr is a terminal: the bar is drawn instead";
  EXPECT_EQ(LinesLogged(1000, 1000, 60, 0), 11u) << "0 %, 10 % ... 100 %";
  // 30 slow steps (>= 5 ms each) within the first tenth of 1000: the first
  // and last line alone, or a line per 20 ms (at most one per 4 steps).
  EXPECT_EQ(LinesLogged(1000, 30, 60, 5), 2u);
  const size_t slow = LinesLogged(1000, 30, 0.02, 5);
  EXPECT_GE(slow, 6u);
  EXPECT_LE(slow, 31u);
  Progress::SetQuiet(true);
  EXPECT_EQ(LinesLogged(1000, 30, 0.02, 5), 0u);
  Progress::SetQuiet(false);
}

// Every index once, whether the loop has the pool or (another thread's loop
// holding it) runs serially; nested loops too; RunBeside's two sides run
// at once (each waits for the other to start) and their errors come back.
TEST(Parallel, LoopsFromTwoThreadsAtOnceEachCoverTheirRange) {
  constexpr int kCount = 5000;
  auto count_loop = [](std::vector<std::atomic<int>>* hits) {
    ParallelFor(0, kCount, [&](int i) { ParallelFor(0, 3, [&](int) { ++(*hits)[i]; }); });
  };
  std::vector<std::atomic<int>> beside(kCount), here(kCount);
  for (int round = 0; round < 20; ++round) {
    for (auto& h : beside) h = 0;
    for (auto& h : here) h = 0;
    RunBeside([&] { count_loop(&beside); }, [&] { count_loop(&here); });
    for (int i = 0; i < kCount; ++i) {
      ASSERT_EQ(beside[i], 3) << "round " << round << " index " << i;
      ASSERT_EQ(here[i], 3) << "round " << round << " index " << i;
    }
  }
  std::atomic<int> started{0};
  auto meet = [&] {
    ++started;
    for (int k = 0; k < 2000 && started < 2; ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    EXPECT_EQ(started, 2) << "the two sides did not run at once";
  };
  RunBeside(meet, meet);
  EXPECT_THROW(RunBeside([] { throw std::runtime_error("beside"); }, [] {}), std::runtime_error);
  EXPECT_THROW(RunBeside([] {}, [] { throw std::runtime_error("here"); }), std::runtime_error);
}

// The CPUs a process may use are its affinity mask's (taskset, cgroups,
// Slurm's binding), capped by SLURM_CPUS_PER_TASK; a Slurm value that is no
// count is ignored.
TEST(Parallel, AvailableCpusFollowAffinityAndSlurm) {
  cpu_set_t all;
  ASSERT_EQ(sched_getaffinity(0, sizeof(all), &all), 0);
  const int mask = CPU_COUNT(&all);
  ASSERT_EQ(unsetenv("SLURM_CPUS_PER_TASK"), 0);
  EXPECT_EQ(AvailableCpus(), mask);
  cpu_set_t one;
  CPU_ZERO(&one);
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (!CPU_ISSET(cpu, &all)) continue;
    CPU_SET(cpu, &one);
    break;
  }
  ASSERT_EQ(sched_setaffinity(0, sizeof(one), &one), 0);
  EXPECT_EQ(AvailableCpus(), 1);
  ASSERT_EQ(sched_setaffinity(0, sizeof(all), &all), 0);
  setenv("SLURM_CPUS_PER_TASK", "1", 1);
  EXPECT_EQ(AvailableCpus(), 1);
  setenv("SLURM_CPUS_PER_TASK", "4096", 1);  // more than the mask: the mask
  EXPECT_EQ(AvailableCpus(), mask);
  setenv("SLURM_CPUS_PER_TASK", "two", 1);
  EXPECT_EQ(AvailableCpus(), mask);
  unsetenv("SLURM_CPUS_PER_TASK");
}

TEST(Random, SameSeedSameSequenceAndKnownValues) {
  Rng a(42), b(42);
  for (int i = 0; i < 100; ++i) ASSERT_EQ(a.Next(), b.Next());
  // std::mt19937_64 is fully specified: its 10000th output for the default
  // seed.
  std::mt19937_64 reference;
  reference.discard(9999);
  EXPECT_EQ(reference(), 9981545732273789042ull);
}

TEST(Random, UniformStaysInRangeAndCoversIt) {
  Rng rng(7);
  std::set<int64_t> seen;
  for (int i = 0; i < 2000; ++i) {
    const double x = rng.Uniform(-2.0, 3.0);
    ASSERT_GE(x, -2.0);
    ASSERT_LT(x, 3.0);
    const int64_t k = rng.UniformInt(0, 5);
    ASSERT_GE(k, 0);
    ASSERT_LE(k, 5);
    seen.insert(k);
  }
  EXPECT_EQ(seen.size(), 6u);
}

TEST(Random, DerivedSeedsDiffer) {
  std::set<uint64_t> seeds;
  for (uint64_t stream = 0; stream < 1000; ++stream) seeds.insert(DeriveSeed(1, stream));
  EXPECT_EQ(seeds.size(), 1000u);
  EXPECT_NE(DeriveSeed(1, 0), DeriveSeed(2, 0));
  EXPECT_EQ(DeriveSeed(5, 9), DeriveSeed(5, 9));
}

TEST(FurnitureClass, NamesRoundTripAndUnknownIsRejected) {
  for (FurnitureClass c : kAllClasses) EXPECT_EQ(ParseFurnitureClass(ClassName(c)), c);
  try {
    ParseFurnitureClass("stool");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("unknown class 'stool'"), std::string::npos);
  }
}

TEST(FileUtil, AtomicWriteReplacesAndLeavesNoTemporaryFile) {
  const std::string dir = testing::ScratchDir();
  const std::string path = dir + "/out.txt";
  WriteFileAtomically(path, "first");
  WriteFileAtomically(path, "second");
  EXPECT_EQ(ReadFileBytes(path), "second");
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1);
}

TEST(FileUtil, ErrorsNameThePath) {
  try {
    ReadFileBytes("/nonexistent/file.obj");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/file.obj: cannot read"),
              std::string::npos);
  }
  EXPECT_THROW(WriteFileAtomically("/nonexistent/dir/out.txt", "x"), InputError);
  EXPECT_EQ(FileExtension("a/b/Model.PLY"), "ply");
  EXPECT_EQ(FileExtension("noext"), "");
}

// Issue 40: a FIFO or device is never replaced by a regular file; "-" is
// standard output for bytes, refused for writers that need a path.
TEST(FileUtil, NonRegularTargetsAreRefusedAndDashIsStandardOutput) {
  const std::string dir = testing::ScratchDir();
  const std::string fifo = dir + "/pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(testing::ErrorOf([&] { WriteFileAtomically(fifo, "x"); }).find("not a regular file"),
            std::string::npos);
  struct stat info {};
  ASSERT_EQ(::stat(fifo.c_str(), &info), 0);
  EXPECT_TRUE(S_ISFIFO(info.st_mode)) << "the FIFO was replaced";
  EXPECT_NE(testing::ErrorOf([&] { WriteFileAtomically(dir, "x"); }).find("not a regular file"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] { AtomicFile file("-"); }).find("standard output"),
            std::string::npos);
  ::testing::internal::CaptureStdout();
  WriteFileAtomically("-", "{\"detections\": []}\n");
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "{\"detections\": []}\n");
  EXPECT_FALSE(std::filesystem::exists("-"));
}

// The null device is the one non-regular output taken: written to, never
// renamed over, still the device afterwards.
TEST(FileUtil, TheNullDeviceTakesOutputAndStaysTheDevice) {
  WriteFileAtomically("/dev/null", "discarded");
  {
    AtomicFile file("/dev/null");
    EXPECT_EQ(file.TempPath(), "/dev/null");
    std::ofstream(file.TempPath()) << "discarded";
    file.Commit();
  }
  { AtomicFile uncommitted("/dev/null"); }  // destroyed: removes nothing
  struct stat device {};
  ASSERT_EQ(stat("/dev/null", &device), 0);
  EXPECT_TRUE(S_ISCHR(device.st_mode));
  EXPECT_THROW(WriteFileAtomically("/dev/zero", "x"), InputError);  // other devices: refused
}

TEST(FileUtil, UncommittedAtomicFileLeavesTargetUntouched) {
  const std::string dir = testing::ScratchDir();
  const std::string path = dir + "/keep.txt";
  WriteFileAtomically(path, "original");
  {
    AtomicFile file(path);
    testing::WriteText(file.TempPath(), "half-written");
  }  // no Commit(): as if the writer failed
  EXPECT_EQ(ReadFileBytes(path), "original");
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp-" + std::to_string(::getpid())));
}

}  // namespace
}  // namespace furn

namespace furn {
namespace {

TEST(Random, ZigguratNormalHasStandardMoments) {
  FastRng rng(123);
  constexpr int kSamples = 2000000;
  double sum = 0, sum2 = 0, sum4 = 0;
  int beyond3 = 0;
  for (int i = 0; i < kSamples; ++i) {
    const double x = rng.Normal();
    sum += x;
    sum2 += x * x;
    sum4 += x * x * x * x;
    beyond3 += std::abs(x) > 3;
  }
  const double mean = sum / kSamples, variance = sum2 / kSamples - mean * mean;
  EXPECT_NEAR(mean, 0, 0.003);
  EXPECT_NEAR(variance, 1, 0.005);
  EXPECT_NEAR(sum4 / kSamples, 3, 0.03);                       // kurtosis of a normal
  EXPECT_NEAR(beyond3 / double(kSamples), 0.0026998, 0.0003);  // tails beyond 3 sigma
  FastRng a(9), b(9);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.Normal(), b.Normal());
}

TEST(FileUtil, DirectoriesAreWrittenWholeOrNotAtAll) {
  namespace fs = std::filesystem;
  const std::string dir = testing::ScratchDir();
  // A failure midway: no output folder, no temporary one.
  EXPECT_THROW(WriteDirectoryAtomically(dir + "/report",
                                        [](const std::string& d) {
                                          testing::WriteText(d + "/index.html", "half");
                                          throw InputError("run 9 does not exist");
                                        }),
               InputError);
  EXPECT_FALSE(fs::exists(dir + "/report"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 0);
  // Success: the folder appears whole.
  WriteDirectoryAtomically(dir + "/report", [](const std::string& d) {
    testing::WriteText(d + "/index.html", "v1");
    fs::create_directory(d + "/fold-0");
    testing::WriteText(d + "/fold-0/index.html", "f1");
  });
  EXPECT_EQ(ReadFileBytes(dir + "/report/index.html"), "v1");
  // Into an existing folder: files of the same names replaced, others kept.
  testing::WriteText(dir + "/report/notes.txt", "mine");
  WriteDirectoryAtomically(
      dir + "/report", [](const std::string& d) { testing::WriteText(d + "/index.html", "v2"); });
  EXPECT_EQ(ReadFileBytes(dir + "/report/index.html"), "v2");
  EXPECT_EQ(ReadFileBytes(dir + "/report/notes.txt"), "mine");
  EXPECT_EQ(ReadFileBytes(dir + "/report/fold-0/index.html"), "f1");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  // Where a file is, or below a missing folder: one line.
  testing::WriteText(dir + "/file", "x");
  EXPECT_NE(testing::ErrorOf([&] {
              WriteDirectoryAtomically(dir + "/file", [](const std::string&) {});
            }).find("a file of that name exists"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              WriteDirectoryAtomically(dir + "/no/such/out", [](const std::string&) {});
            }).find("does not exist"),
            std::string::npos);
}

}  // namespace
}  // namespace furn

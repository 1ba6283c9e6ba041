#include "core/util/parallel.h"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/util/error.h"

namespace furn {
namespace {

std::atomic<int> g_requested_threads{0};  // SetParallelThreads's, 0: none
std::atomic<const char*> g_threads_source{"CPUs"};

// A whole number in [1, max] or nothing; `text` is the environment's.
std::optional<int> PositiveCount(const char* text, int max) {
  if (text == nullptr || *text == '\0') return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text, &end, 10);
  if (*end != '\0' || errno != 0 || value < 1 || value > max) return std::nullopt;
  return static_cast<int>(value);
}

int WantedThreads() {
  if (const int requested = g_requested_threads.load()) {
    g_threads_source = "--threads";
    return requested;
  }
  if (const char* text = std::getenv("FURN_THREADS")) {
    const std::optional<int> threads = PositiveCount(text, kMaxParallelThreads);
    Require(threads.has_value(),
            "FURN_THREADS='" + std::string(text) + "' must be a whole number in 1.." +
                std::to_string(kMaxParallelThreads) + " (unset it to use every CPU available)");
    g_threads_source = "FURN_THREADS";
    return *threads;
  }
  g_threads_source = "CPUs";
  return AvailableCpus();
}

thread_local bool t_inside_parallel_for = false;

// One loop in flight: indices are handed out in chunks through `next`.
struct Loop {
  const std::function<void(int)>* body = nullptr;
  int end = 0;
  int chunk = 1;
  std::atomic<int> next{0};
  int workers_inside = 0;  // guarded by the pool mutex
  std::exception_ptr error;
  std::mutex error_mutex;

  void Run() {
    const bool was_inside = t_inside_parallel_for;
    t_inside_parallel_for = true;
    for (;;) {
      const int first = next.fetch_add(chunk);
      if (first >= end) break;
      const int last = std::min(end, first + chunk);
      try {
        for (int i = first; i < last; ++i) (*body)(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next.store(end);  // stop handing out work
      }
    }
    t_inside_parallel_for = was_inside;
  }
};

class Pool {
 public:
  explicit Pool(int threads) {
    for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { WorkerLoop(); });
  }
  ~Pool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& worker : workers_) worker.join();
  }

  int Threads() const { return static_cast<int>(workers_.size()) + 1; }

  // One loop at a time: false when another thread's loop holds the pool.
  bool TryAcquire() { return !busy_.exchange(true, std::memory_order_acquire); }
  void Release() { busy_.store(false, std::memory_order_release); }

  void Run(Loop* loop) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      loop_ = loop;
      ++generation_;
    }
    wake_.notify_all();
    loop->Run();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return loop->workers_inside == 0; });
    loop_ = nullptr;  // late wakers find nothing to join
  }

 private:
  void WorkerLoop() {
    uint64_t seen = 0;
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      Loop* loop = loop_;
      if (loop == nullptr) continue;
      ++loop->workers_inside;
      lock.unlock();
      loop->Run();
      lock.lock();
      if (--loop->workers_inside == 0) done_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;
  Loop* loop_ = nullptr;
  uint64_t generation_ = 0;
  bool stop_ = false;
  std::atomic<bool> busy_{false};
};

Pool& SharedPool() {
  static Pool pool(WantedThreads());
  return pool;
}

}  // namespace

int ParallelThreads() { return SharedPool().Threads(); }

void SetParallelThreads(int threads) {
  Require(threads >= 1 && threads <= kMaxParallelThreads,
          "threads " + std::to_string(threads) + " must be in 1.." +
              std::to_string(kMaxParallelThreads));
  g_requested_threads = threads;
  if (SharedPool().Threads() != threads)
    throw std::logic_error("SetParallelThreads(" + std::to_string(threads) +
                           ") after the pool started with " +
                           std::to_string(SharedPool().Threads()));
}

int AvailableCpus() {
  int cpus = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) cpus = std::max(1, CPU_COUNT(&set));
  if (const std::optional<int> slurm =
          PositiveCount(std::getenv("SLURM_CPUS_PER_TASK"), kMaxParallelThreads))
    cpus = std::min(cpus, *slurm);
  return cpus;
}

const char* ParallelThreadsSource() {
  SharedPool();
  return g_threads_source.load();
}

void ParallelFor(int begin, int end, const std::function<void(int)>& body) {
  if (begin >= end) return;
  Pool& pool = SharedPool();
  if (t_inside_parallel_for || pool.Threads() == 1 || end - begin == 1 || !pool.TryAcquire()) {
    for (int i = begin; i < end; ++i) body(i);
    return;
  }
  Loop loop;
  loop.body = &body;
  loop.next.store(begin);
  loop.end = end;
  // About 8 chunks per thread: balance without much contention on `next`.
  loop.chunk = std::max(1, (end - begin) / (8 * pool.Threads()));
  pool.Run(&loop);
  pool.Release();
  if (loop.error) std::rethrow_exception(loop.error);
}

void RunBeside(const std::function<void()>& beside, const std::function<void()>& here) {
  std::exception_ptr beside_error, here_error;
  std::thread thread([&] {
    try {
      beside();
    } catch (...) {
      beside_error = std::current_exception();
    }
  });
  try {
    here();
  } catch (...) {
    here_error = std::current_exception();
  }
  thread.join();
  if (here_error) std::rethrow_exception(here_error);
  if (beside_error) std::rethrow_exception(beside_error);
}

}  // namespace furn

#include "core/util/parallel.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace furn {
namespace {

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
  Pool() {
    const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
    for (unsigned i = 1; i < hardware; ++i) workers_.emplace_back([this] { WorkerLoop(); });
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
  static Pool pool;
  return pool;
}

}  // namespace

int ParallelThreads() { return SharedPool().Threads(); }

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

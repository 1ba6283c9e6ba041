// Parallel loops on a shared pool of worker threads that sleep while idle.
//
// OpenMP's idle workers spin; on a 2-core machine that steals a core from
// other thread pools in the process (llvmpipe's rasteriser, Embree's
// builder). These workers block on a condition variable instead.
// Results must not depend on how the range is split: give each index its own
// seeded generator (see FastRng), never a shared one.
//
//   ParallelFor(0, height, [&](int row) { ... });
#pragma once

#include <functional>

namespace furn {

// Calls body(i) for every i in [begin, end), spread over the shared pool (the
// calling thread takes part). Nested calls from inside a body run serially,
// and so does a call while another thread's loop holds the pool.
// An exception thrown by a body is rethrown in the caller after the loop.
void ParallelFor(int begin, int end, const std::function<void(int)>& body);

// Runs `beside` on a thread of its own while the calling thread runs `here`
// (the ParallelFor loops of either on the pool when it is free, else
// serially); returns when both ended and rethrows the first exception
// either threw. Two stages that need each other's cores, e.g. the vote
// network beside the segmentation (Detector::Detect).
void RunBeside(const std::function<void()>& beside, const std::function<void()>& here);

// Threads taking part in ParallelFor, the caller included (>= 1). The pool
// is made at the first call of any of these functions with, first found:
// SetParallelThreads's count, the FURN_THREADS environment variable, or
// AvailableCpus(). Throws InputError for a FURN_THREADS that is not a whole
// number in 1..kMaxParallelThreads.
int ParallelThreads();

constexpr int kMaxParallelThreads = 1024;

// The pool's size before its first use (`workbench --threads N`); throws
// InputError for a count outside 1..kMaxParallelThreads and logic_error once
// the pool runs with another count.
void SetParallelThreads(int threads);

// The CPUs this process may run on: its affinity mask (taskset, cgroups,
// Slurm's binding), capped by SLURM_CPUS_PER_TASK when Slurm sets it (a task
// of 2 CPUs on a 64-core node without binding); at least 1.
int AvailableCpus();

// Where the pool's size came from: "--threads", "FURN_THREADS" or "CPUs".
const char* ParallelThreadsSource();

}  // namespace furn

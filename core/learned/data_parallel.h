// Data-parallel training's group (issue 70): the processes that train one
// vote network together, each on its part of every batch, joined through
// torch's own distributed package (c10d's ProcessGroupGloo over TCP, met
// through a FileStore on a file every rank can reach: a local directory,
// or a cluster's shared one). The group sums what its ranks hold; the
// optimiser (VoteNetOptimizer::JoinGroup) sums the batch's normalisers, the
// gradients and the reported loss with it, so that every rank takes the same
// step as one process on the whole batch would (batch normalisation aside:
// each rank normalises its own part).
//
//   DataParallelOptions options;
//   options.rank = 1; options.world = 2; options.store_path = "/shared/job/store";
//   DataParallelGroup group(options);   // returns when every rank has joined
//   group.SumDoubles(&values);
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace furn {

struct DataParallelOptions {
  int rank = 0;
  int world = 1;           // 1: no group (a plain training)
  std::string store_path;  // the rendezvous file (absent before rank 0 starts)
  // How long a rank waits for the others (joining, and at each sum) before
  // it gives up with an error naming the group: a rank that died does not
  // leave the others hanging.
  double timeout_s = 600;
  // Every rank on this machine (loopback); else each reaches the others by
  // its host name's address, or through the interface GLOO_SOCKET_IFNAME
  // names (as torch's own launchers do).
  bool local = true;
  // Throws InputError naming the value and the rule.
  void Check() const;
  bool Active() const { return world > 1; }
};

class DataParallelGroup {
 public:
  // Joins the group (blocks until every rank has). Throws InputError for bad
  // options, std::runtime_error when the group cannot be formed in time.
  explicit DataParallelGroup(const DataParallelOptions& options);
  ~DataParallelGroup();
  DataParallelGroup(const DataParallelGroup&) = delete;
  DataParallelGroup& operator=(const DataParallelGroup&) = delete;

  int rank() const { return options_.rank; }
  int world() const { return options_.world; }

  // Sums over the ranks, in place; every rank calls with as many values.
  void SumDoubles(std::vector<double>* values);
  void SumFloats(float* values, size_t count);
  // Rank 0's `value` under `key`, on every rank: rank 0 stores it and gets
  // it back, the others wait for it (within the timeout). What tells the
  // ranks of a Slurm job where rank 0 put the training rooms.
  std::string Broadcast(const std::string& key, const std::string& value);

 private:
  struct Impl;
  DataParallelOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn

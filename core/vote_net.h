// The learned vote map (issue 30): a small encoder-decoder CNN (U-Net, three
// halvings) from a bird's-eye-view image (bev_grid.h) to, per cell, a centre
// heat map per class (CenterNet: focal loss on Gaussian-splatted centres)
// and, at centres, the sub-cell offset, log footprint size and yaw. Built on
// libtorch (Debian's libtorch-dev, CPU); no torch header leaves vote_net.cc.
//
//   VoteNet net = VoteNet::Create(VoteNetOptions{}, /*seed=*/1);
//   net.TrainStep(batch);                    // training (vote_net_training.h)
//   const std::string bytes = net.Serialize();
//   VoteNet loaded = VoteNet::Deserialize(bytes, "model.fcm");
//   const BevOutput out = loaded.Predict(image);
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/bev_grid.h"

namespace furn {

struct VoteNetOptions {
  BevGridSpec grid;
  int width = 16;  // channels of the first level; doubled per halving, capped at 4x

  void Check() const;
};

// The network's output for one image: kBevOutputs x rows x cols, the heat
// channels through a sigmoid (0..1), the rest as regressed.
struct BevOutput {
  BevGridSpec spec;
  std::vector<float> values;
  float At(int channel, int row, int col) const {
    return values[(static_cast<size_t>(channel) * spec.rows + row) * spec.cols + col];
  }
};

// Loss terms of one step (means over the batch).
struct VoteNetLoss {
  double heat = 0, offset = 0, size = 0, yaw = 0;
  double Total() const { return heat + offset + size + yaw; }
  VoteNetLoss& operator+=(const VoteNetLoss& other) {
    heat += other.heat;
    offset += other.offset;
    size += other.size;
    yaw += other.yaw;
    return *this;
  }
  VoteNetLoss Scaled(double factor) const {
    return {heat * factor, offset * factor, size * factor, yaw * factor};
  }
};

class VoteNet {
 public:
  VoteNet();
  ~VoteNet();
  VoteNet(VoteNet&&) noexcept;
  VoteNet& operator=(VoteNet&&) noexcept;

  // Fresh weights from `seed` (torch's generator, seeded here).
  static VoteNet Create(const VoteNetOptions& options, uint64_t seed);
  // The bytes of Serialize; throws InputError naming `what` for bytes that are
  // not a vote network of this build's format (damaged, foreign, other sizes).
  static VoteNet Deserialize(const std::string& bytes, const std::string& what);
  std::string Serialize() const;

  bool empty() const { return impl_ == nullptr; }
  const VoteNetOptions& options() const;
  int64_t Parameters() const;

  // Inference (evaluation mode), on the calling thread's torch thread count.
  BevOutput Predict(const BevImage& image) const;

  // One optimiser step (Adam) on a batch of images and their targets; returns
  // the loss before the step. The learning rate is set per call.
  VoteNetLoss TrainStep(const std::vector<const BevImage*>& images,
                        const std::vector<const BevTargets*>& targets,
                        double learning_rate);
  // The loss of a batch without a step (evaluation mode).
  VoteNetLoss Loss(const std::vector<const BevImage*>& images,
                   const std::vector<const BevTargets*>& targets) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Torch's intra-op threads for this process (at::set_num_threads); 0 leaves
// the library's default.
void SetTorchThreads(int threads);
int TorchThreads();

}  // namespace furn

// The learned vote map (issues 30, 37): a small encoder-decoder CNN (U-Net,
// 2 to 5 halvings; 3 by default) from a bird's-eye-view image (bev_grid.h) to,
// per cell, the channels of bev_channels.h: a centre heat map per class, a
// dense vote (offset to its object's centre, footprint, yaw, membership) and,
// trained with edge votes, the distances to its object's sides. What the
// channels mean is the box coder's (bev_box_coder.h); the loss and the
// optimiser are vote_net_loss.h and vote_net_training.h. Built on libtorch
// (Debian's libtorch-dev, CPU); no torch header leaves the learned library's
// .cc files.
//
//   VoteNet net = VoteNet::Create(VoteNetOptions{}, /*seed=*/1);
//   VoteNetOptimizer optimizer(&net);        // training (vote_net_training.h)
//   const std::string bytes = net.Serialize();
//   VoteNet loaded = VoteNet::Deserialize(bytes, "model.fcm");
//   const BevOutput out = loaded.Predict(image);
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/learned/bev_box_coder.h"
#include "core/learned/bev_grid.h"
#include "core/util/enum_text.h"

namespace furn {

// The arithmetic of the network's passes (issue 70). kFloat32: float
// tensors in torch's default layout, the reference (a seed gives the same
// answers and the same trained bytes as before the option). kBfloat16:
// torch's CPU autocast to bfloat16 around the convolutions, with the
// activations channels-last (oneDNN's AMX kernels without a reorder per
// convolution; the weights and the answers stay float): 2.6 times faster
// predictions and 1.7 to 2.2 times faster training steps on a CPU with
// AMX-BF16, answers within bfloat16's rounding of float's
// (docs/learned-voting.md). kAuto is kBfloat16 on a CPU with AMX-BF16 and
// kFloat32 elsewhere (ResolvePrecision).
enum class NetworkPrecision { kAuto, kFloat32, kBfloat16 };
template <>
struct EnumText<NetworkPrecision> {
  static constexpr const char* kKind = "network precision";
  static constexpr EnumEntry<NetworkPrecision> kEntries[] = {
      {NetworkPrecision::kAuto, "auto"},
      {NetworkPrecision::kFloat32, "fp32"},
      {NetworkPrecision::kBfloat16, "bf16"},
  };
};

// Whether this CPU (and its operating system) runs AMX-BF16 tile
// instructions: what kAuto's bfloat16 needs to pay off.
bool CpuHasAmxBf16();
// Whether it has bfloat16 instructions at all (AVX512-BF16 or AMX-BF16),
// which an explicit kBfloat16 needs.
bool CpuHasBf16();
// kAuto resolved for this CPU; kFloat32 as asked; kBfloat16 as asked, or an
// InputError naming the CPU's lack when it has no bfloat16 instructions.
// FURN_NETWORK_PRECISION (auto, fp32 or bf16), when set, replaces kAuto
// (the test suite pins fp32 with it; a bad value is an InputError).
NetworkPrecision ResolvePrecision(NetworkPrecision requested);

// The most cells a vote network's grid may hold (the default holds 6912).
inline constexpr int64_t kMaxGridCells = 65536;

struct VoteNetOptions {
  BevGridSpec grid;
  int width = 16;  // channels of the first level; doubled per halving, capped at 4x
  // How its targets were encoded (stored with the weights: decoding follows
  // it, e.g. the votes' mean shift only where every cell's vote was trained).
  BevCoderOptions coder;
  // The scan's points within this distance of the sensor are rasterised, in
  // training and in detection alike (stored with the weights): the grid's
  // forward reach. At 3 m (networks before format 5) a quarter of the tables
  // within 3 m had their far end cut off (docs/learned-voting.md).
  double range_m = 3.6;
  // Halvings of the U-Net's encoder (stored with the weights; 3 before format
  // 6). Each one doubles the receptive field: at 3 the bottleneck's cells are
  // 40 cm, at 4 80 cm, enough context to see both ends of a 2 m table top.
  int levels = 3;

  void Check() const;
};

class VoteNet {
 public:
  VoteNet();
  ~VoteNet();
  VoteNet(VoteNet&&) noexcept;
  VoteNet& operator=(VoteNet&&) noexcept;

  // Fresh weights from `seed` (torch's generator, seeded here).
  static VoteNet Create(const VoteNetOptions& options, uint64_t seed);
  // An ensemble of the members (at least one, at most kMaxMembers, each a
  // single network of the same options; `what` names them in errors): Predict
  // averages their answers. Members of one training's rooms with their own
  // weights are VoteNetTrainingOptions::member's.
  static VoteNet Ensemble(std::vector<VoteNet> members, const std::string& what);
  static constexpr int kMaxMembers = 8;
  // The bytes of Serialize; throws InputError naming `what` for bytes that are
  // not a vote network of this build's format (damaged, foreign, other sizes).
  static VoteNet Deserialize(const std::string& bytes, const std::string& what);
  std::string Serialize() const;

  bool empty() const { return impl_ == nullptr; }
  const VoteNetOptions& options() const;
  int64_t Parameters() const;  // of every member
  int Members() const;         // 1 for a single network, 0 for an empty one

  // Inference (evaluation mode), on the calling thread's torch thread count.
  // mirror_average: the image and its mirror (BevImage::Mirrored) in one
  // batch, the mirror's heat, membership, offset and footprint turned back
  // and averaged with the image's (test-time augmentation; twice the work).
  // An ensemble of M members makes max(M, views) passes, pass k member
  // k mod M on view k mod views (views: the image, and with mirror_average
  // its mirror), and averages them the same way: two members with the mirror
  // cost what one network with it does, member 1 answering the mirror. The
  // yaw is always the first pass's (member 0 on the image).
  BevOutput Predict(const BevImage& image, bool mirror_average = false) const;

  // The arithmetic of Predict and of training steps (every member's):
  // ResolvePrecision(requested). kFloat32 until set.
  void SetPrecision(NetworkPrecision requested);
  NetworkPrecision precision() const;

  struct Impl;  // vote_net_module.h: torch's module, for the learned library's own files

 private:
  friend struct VoteNetAccess;
  std::unique_ptr<Impl> impl_;
};

// Torch's intra-op threads for this process (at::set_num_threads); 0 leaves
// the library's default.
void SetTorchThreads(int threads);
int TorchThreads();

}  // namespace furn

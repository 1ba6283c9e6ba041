// Private to the learned library's .cc files (it includes torch): the U-Net
// module behind VoteNet, and tensors made from BEV images and targets.
// Nothing outside core/learned/*.cc includes this header.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <vector>

#include "core/learned/bev_box_coder.h"
#include "core/learned/vote_net.h"

namespace furn {

// Two 3x3 convolutions, each with batch normalisation and ReLU.
struct ConvBlockImpl : torch::nn::Module {
  ConvBlockImpl(int in, int out);
  torch::Tensor forward(torch::Tensor x);
  torch::nn::Conv2d conv1;
  torch::nn::BatchNorm2d bn1;
  torch::nn::Conv2d conv2;
  torch::nn::BatchNorm2d bn2;
};
TORCH_MODULE(ConvBlock);

// Encoder (`levels` halvings), bottleneck, decoder with skip connections,
// 1x1 head with `out` outputs (BevCoderOptions::Channels). Level i (from 0) has
// w * min(2^i, 4) channels; the modules are named e1..eL, bottom, dL..d1,
// head, so three levels keep the names of the networks before the option.
struct UNetImpl : torch::nn::Module {
  UNetImpl(int in, int w, int out, int levels);
  // Float in and out whatever the precision: with `bf16`, the passes run in
  // torch's CPU autocast to bfloat16 on channels-last activations, and the
  // answer comes back as a float tensor in the default layout.
  torch::Tensor forward(const torch::Tensor& x);
  bool bf16 = false;                // VoteNet::SetPrecision's
  std::vector<ConvBlock> encoders;  // e1..eL
  ConvBlock bottom{nullptr};
  std::vector<ConvBlock> decoders;  // d1..dL (decoders[i] is d(i+1))
  torch::nn::Conv2d head{nullptr};

 private:
  torch::Tensor Layers(const torch::Tensor& x);
};
TORCH_MODULE(UNet);

struct VoteNet::Impl {
  VoteNetOptions options;
  UNet net{nullptr};  // the network training steps (an ensemble's first member)
  // An ensemble's further members (VoteNet::Ensemble), each of `options`;
  // empty for one network. Only Predict and the file use them.
  std::vector<UNet> partners;
  NetworkPrecision precision = NetworkPrecision::kFloat32;  // resolved: never kAuto
};

// The learned library's access to a network's module.
struct VoteNetAccess {
  static VoteNet::Impl& Of(VoteNet& net) { return *net.impl_; }
  static const VoteNet::Impl& Of(const VoteNet& net) { return *net.impl_; }
};

// The options a vote-network block's header declares (after its magic and
// `version`), checked; `at` moves past them.
VoteNetOptions ReadVoteNetHeader(const std::string& bytes,
                                 size_t* at,
                                 const std::string& what,
                                 uint32_t version);

// N x channels x rows x cols from N planes of channels x rows x cols each.
torch::Tensor StackPlanes(const std::vector<const std::vector<float>*>& planes,
                          int64_t channels,
                          const BevGridSpec& spec);
torch::Tensor ImageTensor(const std::vector<const BevImage*>& images, const BevGridSpec& spec);

// One image's answer (channels x rows x cols, a view of the network's
// output) with its heat and membership turned into probabilities, in place.
torch::Tensor ActivatedAnswer(torch::Tensor answer);
// An activated answer as the BevOutput of `image` (VoteNet::Predict's).
BevOutput BevOutputOf(const torch::Tensor& answer,
                      const BevImage& image,
                      const BevCoderOptions& coder);

// A batch's targets as tensors: values N x channels x rows x cols, votes,
// weight and (with edge votes; else undefined) edges N x rows x cols.
struct TargetTensors {
  torch::Tensor values, votes, weight, edges;
};
TargetTensors TargetTensorsOf(const std::vector<const BevTargets*>& targets,
                              const BevGridSpec& spec);

}  // namespace furn

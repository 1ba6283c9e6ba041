#include "core/learned/vote_net_training.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/learned/vote_net_loss_torch.h"

namespace furn {
namespace {

template <typename T>
std::vector<const T*> Pointers(const std::vector<T>& items) {
  std::vector<const T*> out;
  for (const T& item : items) out.push_back(&item);
  return out;
}

}  // namespace

BevSample MirroredSample(const BevSample& sample) {
  BevSample mirrored;
  mirrored.image = sample.image.Mirrored();
  for (const BevObject& object : sample.objects)
    mirrored.objects.push_back(MirroredObject(object, sample.image.frame));
  mirrored.visibility = sample.visibility;
  return mirrored;
}

TrainingBatch MakeTrainingBatch(const std::vector<BevSample>& samples,
                                const std::vector<size_t>& indices,
                                const std::vector<char>& mirror,
                                const BevCoderOptions& coder) {
  Require(mirror.empty() || mirror.size() == indices.size(),
          "a training batch needs one mirror flag per sample");
  TrainingBatch batch;
  for (size_t i = 0; i < indices.size(); ++i) {
    const BevSample& sample = samples.at(indices[i]);
    if (mirror.empty() || !mirror[i]) {
      batch.images.push_back(sample.image);
      batch.targets.push_back(EncodeBevTargets(sample.objects, sample.image, coder));
    } else {
      BevSample mirrored = MirroredSample(sample);
      batch.targets.push_back(EncodeBevTargets(mirrored.objects, mirrored.image, coder));
      batch.images.push_back(std::move(mirrored.image));
    }
  }
  return batch;
}

double CosineLearningRate(size_t step, size_t total_steps, double peak, double floor_share) {
  const double progress = total_steps > 0 ? static_cast<double>(step) / total_steps : 0;
  return peak * (floor_share + (1 - floor_share) * 0.5 * (1 + std::cos(M_PI * progress)));
}

struct VoteNetOptimizer::Impl {
  VoteNet::Impl* net = nullptr;
  VoteNetLossWeights weights;
  std::unique_ptr<torch::optim::Adam> adam;
};

VoteNetOptimizer::VoteNetOptimizer(VoteNet* net, const VoteNetLossWeights& weights)
    : impl_(std::make_unique<Impl>()) {
  Require(net != nullptr && !net->empty(), "an empty vote network cannot train");
  Require(net->Members() == 1,
          "an ensemble of vote networks cannot train: train its members (VoteNet::Ensemble)");
  weights.Check();
  impl_->net = &VoteNetAccess::Of(*net);
  impl_->weights = weights;
  impl_->adam = std::make_unique<torch::optim::Adam>(impl_->net->net->parameters(),
                                                     torch::optim::AdamOptions(1e-3));
}

VoteNetOptimizer::~VoteNetOptimizer() = default;

VoteNetLoss VoteNetOptimizer::Step(const TrainingBatch& batch, double learning_rate) {
  Require(!batch.images.empty() && batch.images.size() == batch.targets.size(),
          "a training batch needs one target per image");
  VoteNet::Impl& net = *impl_->net;
  for (auto& group : impl_->adam->param_groups())
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(learning_rate);
  net.net->train();
  const torch::Tensor input = ImageTensor(Pointers(batch.images), net.options.grid);
  const TargetTensors targets = TargetTensorsOf(Pointers(batch.targets), net.options.grid);
  impl_->adam->zero_grad();
  const torch::Tensor output = net.net->forward(input);
  torch::Tensor total;
  const VoteNetLoss loss = VoteNetLossOf(output, targets, impl_->weights, &total);
  total.backward();
  impl_->adam->step();
  net.net->eval();
  return loss;
}

VoteNetWeightAverage::VoteNetWeightAverage(const VoteNet& net, double decay)
    : average_(VoteNet::Deserialize(net.Serialize(), "the network's weights")), decay_(decay) {
  Require(decay >= 0 && decay < 1, "a weight average's decay must be in [0, 1)");
}

void VoteNetWeightAverage::Update(const VoteNet& net) {
  Require(!net.empty() && net.Parameters() == average_.Parameters(),
          "a weight average follows the network it was made from");
  ++updates_;
  const double decay = std::min(decay_, (1.0 + updates_) / (10.0 + updates_));
  torch::NoGradGuard no_grad;
  const auto average = VoteNetAccess::Of(average_).net->named_parameters();
  for (const auto& item : VoteNetAccess::Of(net).net->named_parameters())
    average[item.key()].mul_(decay).add_(item.value(), 1 - decay);
  const auto average_buffers = VoteNetAccess::Of(average_).net->named_buffers();
  for (const auto& item : VoteNetAccess::Of(net).net->named_buffers()) {
    torch::Tensor mine = average_buffers[item.key()];
    if (mine.is_floating_point())
      mine.mul_(decay).add_(item.value(), 1 - decay);
    else
      mine.copy_(item.value());  // batch norm's step count
  }
}

VoteNetLoss EvaluateVoteNetLoss(const VoteNet& net,
                                const TrainingBatch& batch,
                                const VoteNetLossWeights& weights) {
  Require(!net.empty(), "an empty vote network has no loss");
  const VoteNet::Impl& impl = VoteNetAccess::Of(net);
  torch::NoGradGuard no_grad;
  const torch::Tensor input = ImageTensor(Pointers(batch.images), impl.options.grid);
  const TargetTensors targets = TargetTensorsOf(Pointers(batch.targets), impl.options.grid);
  return VoteNetLossOf(impl.net.ptr()->forward(input), targets, weights, nullptr);
}

}  // namespace furn

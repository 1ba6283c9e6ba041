#include "core/vote_net.h"

#include <torch/torch.h>

#include <cstring>
#include <sstream>

#include "core/error.h"

namespace furn {
namespace {

constexpr char kMagic[8] = {'F', 'U', 'R', 'N', 'V', 'N', 'E', 'T'};
constexpr uint32_t kVersion = 1;

// Two 3x3 convolutions, each with batch normalisation and ReLU.
struct ConvBlockImpl : torch::nn::Module {
  ConvBlockImpl(int in, int out)
      : conv1(torch::nn::Conv2dOptions(in, out, 3).padding(1).bias(false)),
        bn1(out),
        conv2(torch::nn::Conv2dOptions(out, out, 3).padding(1).bias(false)),
        bn2(out) {
    register_module("conv1", conv1);
    register_module("bn1", bn1);
    register_module("conv2", conv2);
    register_module("bn2", bn2);
  }
  torch::Tensor forward(torch::Tensor x) {
    x = torch::relu(bn1(conv1(x)));
    return torch::relu(bn2(conv2(x)));
  }
  torch::nn::Conv2d conv1;
  torch::nn::BatchNorm2d bn1;
  torch::nn::Conv2d conv2;
  torch::nn::BatchNorm2d bn2;
};
TORCH_MODULE(ConvBlock);

// Encoder (3 halvings), bottleneck, decoder with skip connections, 1x1 head.
struct UNetImpl : torch::nn::Module {
  UNetImpl(int in, int w, int out)
      : e1(in, w),
        e2(w, 2 * w),
        e3(2 * w, 4 * w),
        bottom(4 * w, 4 * w),
        d3(8 * w, 4 * w),
        d2(6 * w, 2 * w),
        d1(3 * w, w),
        head(torch::nn::Conv2dOptions(w, out, 1)) {
    register_module("e1", e1);
    register_module("e2", e2);
    register_module("e3", e3);
    register_module("bottom", bottom);
    register_module("d3", d3);
    register_module("d2", d2);
    register_module("d1", d1);
    register_module("head", head);
    // CenterNet's heat bias: sigmoid(-2.19) = 0.1, so the first steps are
    // not swamped by the background.
    torch::NoGradGuard no_grad;
    head->bias.zero_();
    head->bias.slice(0, 0, kBevClasses).fill_(-2.19);
  }
  static torch::Tensor Up(const torch::Tensor& x, const torch::Tensor& like) {
    return torch::nn::functional::interpolate(
        x,
        torch::nn::functional::InterpolateFuncOptions()
            .size(std::vector<int64_t>{like.size(2), like.size(3)})
            .mode(torch::kNearest));
  }
  torch::Tensor forward(const torch::Tensor& x) {
    const torch::Tensor x1 = e1(x);
    const torch::Tensor x2 = e2(torch::max_pool2d(x1, 2));
    const torch::Tensor x3 = e3(torch::max_pool2d(x2, 2));
    torch::Tensor y = bottom(torch::max_pool2d(x3, 2));
    y = d3(torch::cat({Up(y, x3), x3}, 1));
    y = d2(torch::cat({Up(y, x2), x2}, 1));
    y = d1(torch::cat({Up(y, x1), x1}, 1));
    return head(y);
  }
  ConvBlock e1, e2, e3, bottom, d3, d2, d1;
  torch::nn::Conv2d head;
};
TORCH_MODULE(UNet);

torch::Tensor Stack(const std::vector<const std::vector<float>*>& planes,
                    int64_t channels,
                    const BevGridSpec& spec) {
  const int64_t n = static_cast<int64_t>(planes.size());
  torch::Tensor batch = torch::empty({n, channels, spec.rows, spec.cols}, torch::kFloat32);
  const size_t count = static_cast<size_t>(channels) * spec.rows * spec.cols;
  for (int64_t i = 0; i < n; ++i) {
    Require(planes[i]->size() == count, "a BEV batch item has the wrong size");
    std::memcpy(batch[i].data_ptr<float>(), planes[i]->data(), count * sizeof(float));
  }
  return batch;
}

// CenterNet's penalty-reduced focal loss (alpha 2, beta 4) on the heat
// logits, and L1 of the regressions at the centre cells.
VoteNetLoss LossTerms(const torch::Tensor& output,
                      const torch::Tensor& target,
                      const torch::Tensor& mask,
                      torch::Tensor* total) {
  const torch::Tensor logits = output.slice(1, 0, kBevClasses);
  const torch::Tensor heat = target.slice(1, 0, kBevClasses);
  const torch::Tensor p = torch::sigmoid(logits);
  const torch::Tensor positive = heat.ge(0.999).to(torch::kFloat32);
  const torch::Tensor positives = positive.sum().clamp_min(1.0);
  const torch::Tensor pos_loss = (torch::log_sigmoid(logits) * (1 - p).pow(2) * positive).sum();
  const torch::Tensor neg_loss =
      (torch::log_sigmoid(-logits) * p.pow(2) * (1 - heat).pow(4) * (1 - positive)).sum();
  const torch::Tensor heat_loss = -(pos_loss + neg_loss) / positives;
  const torch::Tensor m = mask.unsqueeze(1);
  const torch::Tensor cells = m.sum().clamp_min(1.0);
  auto l1 = [&](int64_t from, int64_t to) {
    return ((output.slice(1, from, to) - target.slice(1, from, to)).abs() * m).sum() /
           (cells * static_cast<double>(to - from));
  };
  const torch::Tensor offset = l1(kBevClasses, kBevClasses + 2);
  const torch::Tensor size = l1(kBevClasses + 2, kBevClasses + 4);
  const torch::Tensor yaw = l1(kBevClasses + 4, kBevClasses + 6);
  if (total != nullptr) *total = heat_loss + offset + size + yaw;
  return {heat_loss.item<double>(), offset.item<double>(), size.item<double>(), yaw.item<double>()};
}

template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <typename T>
T Take(const std::string& bytes, size_t* at, const std::string& what) {
  Require(*at + sizeof(T) <= bytes.size(), what + ": vote network is truncated");
  T value;
  std::memcpy(&value, bytes.data() + *at, sizeof(T));
  *at += sizeof(T);
  return value;
}

}  // namespace

void VoteNetOptions::Check() const {
  grid.Check();
  Require(width >= 4 && width <= 128,
          "vote network width " + std::to_string(width) + " must be in 4..128");
}

struct VoteNet::Impl {
  VoteNetOptions options;
  UNet net{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer;

  torch::Tensor Inputs(const std::vector<const BevImage*>& images) const {
    std::vector<const std::vector<float>*> planes;
    for (const BevImage* image : images) {
      Require(image->spec == options.grid,
              "a BEV image's grid differs from the vote network's (rasterise with its spec)");
      planes.push_back(&image->values);
    }
    return Stack(planes, kBevChannels, options.grid);
  }
  std::pair<torch::Tensor, torch::Tensor> Targets(
      const std::vector<const BevTargets*>& targets) const {
    std::vector<const std::vector<float>*> values, masks;
    for (const BevTargets* t : targets) {
      values.push_back(&t->values);
      masks.push_back(&t->mask);
    }
    return {Stack(values, kBevOutputs, options.grid), Stack(masks, 1, options.grid).squeeze(1)};
  }
};

VoteNet::VoteNet() = default;
VoteNet::~VoteNet() = default;
VoteNet::VoteNet(VoteNet&&) noexcept = default;
VoteNet& VoteNet::operator=(VoteNet&&) noexcept = default;

VoteNet VoteNet::Create(const VoteNetOptions& options, uint64_t seed) {
  options.Check();
  torch::manual_seed(seed);
  VoteNet net;
  net.impl_ = std::make_unique<Impl>();
  net.impl_->options = options;
  net.impl_->net = UNet(kBevChannels, options.width, kBevOutputs);
  net.impl_->net->eval();
  return net;
}

const VoteNetOptions& VoteNet::options() const {
  Require(impl_ != nullptr, "an empty vote network has no options");
  return impl_->options;
}

int64_t VoteNet::Parameters() const {
  if (impl_ == nullptr) return 0;
  int64_t count = 0;
  for (const torch::Tensor& p : impl_->net->parameters()) count += p.numel();
  return count;
}

std::string VoteNet::Serialize() const {
  Require(impl_ != nullptr, "an empty vote network cannot be saved");
  std::string out(kMagic, sizeof(kMagic));
  Put(&out, kVersion);
  const VoteNetOptions& o = impl_->options;
  Put(&out, o.grid.cell_m);
  Put(&out, static_cast<int32_t>(o.grid.rows));
  Put(&out, static_cast<int32_t>(o.grid.cols));
  Put(&out, o.grid.floor_band_m);
  Put(&out, static_cast<int32_t>(o.width));
  torch::serialize::OutputArchive archive;
  impl_->net->save(archive);
  std::ostringstream weights;
  archive.save_to(weights);
  const std::string blob = weights.str();
  Put(&out, static_cast<uint64_t>(blob.size()));
  out += blob;
  return out;
}

VoteNet VoteNet::Deserialize(const std::string& bytes, const std::string& what) {
  Require(bytes.size() >= sizeof(kMagic) && std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) == 0,
          what + ": not a vote network (no FURNVNET header)");
  size_t at = sizeof(kMagic);
  const uint32_t version = Take<uint32_t>(bytes, &at, what);
  Require(version == kVersion,
          what + ": vote network format " + std::to_string(version) + " is not this build's (" +
              std::to_string(kVersion) + ")");
  VoteNetOptions options;
  options.grid.cell_m = Take<double>(bytes, &at, what);
  options.grid.rows = Take<int32_t>(bytes, &at, what);
  options.grid.cols = Take<int32_t>(bytes, &at, what);
  options.grid.floor_band_m = Take<double>(bytes, &at, what);
  options.width = Take<int32_t>(bytes, &at, what);
  try {
    options.Check();
  } catch (const InputError& error) {
    throw InputError(what + ": vote network is corrupt (" + error.what() + ")");
  }
  const uint64_t blob_size = Take<uint64_t>(bytes, &at, what);
  Require(blob_size == bytes.size() - at,
          what + ": vote network is corrupt (its weights block has the wrong length)");
  VoteNet net = Create(options, 0);
  try {
    torch::serialize::InputArchive archive;
    std::istringstream in(bytes.substr(at));
    archive.load_from(in);
    net.impl_->net->load(archive);
  } catch (const c10::Error& error) {
    std::string reason = error.what_without_backtrace();
    reason = reason.substr(0, reason.find('\n'));
    throw InputError(what + ": vote network weights are unreadable (" + reason + ")");
  }
  net.impl_->net->eval();
  return net;
}

BevOutput VoteNet::Predict(const BevImage& image) const {
  Require(impl_ != nullptr, "an empty vote network cannot predict");
  torch::NoGradGuard no_grad;
  const torch::Tensor input = impl_->Inputs({&image});
  torch::Tensor output = impl_->net.ptr()->forward(input)[0];
  output.slice(0, 0, kBevClasses).sigmoid_();
  output = output.contiguous();
  BevOutput out;
  out.spec = image.spec;
  out.values.assign(output.data_ptr<float>(), output.data_ptr<float>() + output.numel());
  return out;
}

VoteNetLoss VoteNet::TrainStep(const std::vector<const BevImage*>& images,
                               const std::vector<const BevTargets*>& targets,
                               double learning_rate) {
  Require(impl_ != nullptr, "an empty vote network cannot train");
  Require(!images.empty() && images.size() == targets.size(),
          "a training batch needs one target per image");
  Impl& impl = *impl_;
  if (impl.optimizer == nullptr)
    impl.optimizer = std::make_unique<torch::optim::Adam>(impl.net->parameters(),
                                                          torch::optim::AdamOptions(1e-3));
  for (auto& group : impl.optimizer->param_groups())
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(learning_rate);
  impl.net->train();
  const torch::Tensor input = impl.Inputs(images);
  const auto [target, mask] = impl.Targets(targets);
  impl.optimizer->zero_grad();
  const torch::Tensor output = impl.net->forward(input);
  torch::Tensor total;
  const VoteNetLoss loss = LossTerms(output, target, mask, &total);
  total.backward();
  impl.optimizer->step();
  impl.net->eval();
  return loss;
}

VoteNetLoss VoteNet::Loss(const std::vector<const BevImage*>& images,
                          const std::vector<const BevTargets*>& targets) const {
  Require(impl_ != nullptr, "an empty vote network has no loss");
  torch::NoGradGuard no_grad;
  const torch::Tensor input = impl_->Inputs(images);
  const auto [target, mask] = impl_->Targets(targets);
  return LossTerms(impl_->net.ptr()->forward(input), target, mask, nullptr);
}

void SetTorchThreads(int threads) {
  if (threads > 0) at::set_num_threads(threads);
}

int TorchThreads() { return at::get_num_threads(); }

}  // namespace furn

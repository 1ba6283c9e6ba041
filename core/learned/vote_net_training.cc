#include "core/learned/vote_net_training.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>

#include "core/learned/vote_net_loss_torch.h"
#include "core/util/error.h"

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
  mirrored.background_known = sample.background_known;
  return mirrored;
}

namespace {

// The targets' cell weights kept only near the targets' footprints
// (BevSample::background_known false).
void KeepWeightNearTargets(const std::vector<BevObject>& objects,
                           const BevImage& image,
                           BevTargets* targets) {
  const BevGridSpec& spec = image.spec;
  std::vector<char> near(static_cast<size_t>(spec.rows) * spec.cols, 0);
  for (const BevObject& object : objects) {
    if (!object.target) continue;
    const Eigen::Vector2d cell = image.frame.CellOf(object.Centre(), spec);
    const double reach =
        0.5 * std::hypot(object.width, object.depth) / spec.cell_m + kUnknownBackgroundReachCells;
    for (int r = 0; r < spec.rows; ++r) {
      for (int c = 0; c < spec.cols; ++c) {
        if (std::hypot(r + 0.5 - cell.x(), c + 0.5 - cell.y()) <= reach)
          near[static_cast<size_t>(r) * spec.cols + c] = 1;
      }
    }
  }
  for (size_t i = 0; i < near.size(); ++i) {
    if (!near[i]) targets->weight[i] = 0;
  }
}

BevTargets SampleTargets(const BevSample& sample, const BevCoderOptions& coder) {
  BevTargets targets = EncodeBevTargets(sample.objects, sample.image, coder);
  if (!sample.background_known) KeepWeightNearTargets(sample.objects, sample.image, &targets);
  return targets;
}

}  // namespace

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
      batch.targets.push_back(SampleTargets(sample, coder));
    } else {
      BevSample mirrored = MirroredSample(sample);
      batch.targets.push_back(SampleTargets(mirrored, coder));
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
  VoteNetStepTimes times;
  DataParallelGroup* group = nullptr;
};

namespace {

// Seconds since `since`, and `since` moved to now.
double Lap(std::chrono::steady_clock::time_point* since) {
  const auto now = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(now - *since).count();
  *since = now;
  return seconds;
}

}  // namespace

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

namespace {

std::vector<double> NormaliserValues(const LossNormalisers& n) {
  return {n.positives, n.voting_cells, n.cells, n.edge_cells};
}

LossNormalisers NormalisersOf(const std::vector<double>& v) { return {v[0], v[1], v[2], v[3]}; }

std::vector<double> LossValues(const VoteNetLoss& loss) {
  return {loss.heat, loss.offset, loss.size, loss.yaw, loss.membership, loss.edges};
}

VoteNetLoss LossOf(const std::vector<double>& v) { return {v[0], v[1], v[2], v[3], v[4], v[5]}; }

// Every parameter's gradient summed over the group (a parameter this rank's
// part left without one counts as zero), in one flat all-reduce.
void SumGradients(torch::nn::Module& module, DataParallelGroup* group) {
  std::vector<torch::Tensor> parameters = module.parameters();
  std::vector<torch::Tensor> parts;
  for (const torch::Tensor& p : parameters)
    parts.push_back(p.grad().defined() ? p.grad().reshape(-1) : torch::zeros({p.numel()}));
  torch::Tensor flat = torch::cat(parts).contiguous();
  group->SumFloats(flat.data_ptr<float>(), static_cast<size_t>(flat.numel()));
  int64_t at = 0;
  for (torch::Tensor& p : parameters) {
    p.mutable_grad() = flat.slice(0, at, at + p.numel()).view_as(p).clone();
    at += p.numel();
  }
}

}  // namespace

VoteNetLoss VoteNetOptimizer::Step(const TrainingBatch& batch, double learning_rate) {
  DataParallelGroup* group = impl_->group;
  Require(batch.images.size() == batch.targets.size() && (group || !batch.images.empty()),
          "a training batch needs one target per image");
  VoteNet::Impl& net = *impl_->net;
  for (auto& param_group : impl_->adam->param_groups())
    static_cast<torch::optim::AdamOptions&>(param_group.options()).lr(learning_rate);
  net.net->train();
  VoteNetStepTimes& times = impl_->times;
  auto lap = std::chrono::steady_clock::now();
  impl_->adam->zero_grad();
  VoteNetLoss loss;
  if (!batch.images.empty()) {
    const torch::Tensor input = ImageTensor(Pointers(batch.images), net.options.grid);
    const TargetTensors targets = TargetTensorsOf(Pointers(batch.targets), net.options.grid);
    std::vector<double> normalisers = NormaliserValues(LossNormalisersOf(targets));
    if (group) group->SumDoubles(&normalisers);
    const LossNormalisers whole = NormalisersOf(normalisers);
    times.tensors_s += Lap(&lap);
    const torch::Tensor output = net.net->forward(input);
    torch::Tensor total;
    loss = VoteNetLossOf(output, targets, impl_->weights, &total, &whole);
    times.forward_s += Lap(&lap);
    total.backward();
  } else {  // this rank holds none of the batch: it adds nothing
    std::vector<double> normalisers(4, 0.0);
    group->SumDoubles(&normalisers);
  }
  if (group) {
    SumGradients(*net.net, group);
    std::vector<double> terms = LossValues(loss);
    group->SumDoubles(&terms);
    loss = LossOf(terms);
  }
  times.backward_s += Lap(&lap);
  impl_->adam->step();
  net.net->eval();
  times.update_s += Lap(&lap);
  ++times.steps;
  return loss;
}

void VoteNetOptimizer::JoinGroup(DataParallelGroup* group) {
  impl_->group = group != nullptr && group->world() > 1 ? group : nullptr;
}

void AverageBuffersOverGroup(VoteNet* net, DataParallelGroup* group) {
  if (group == nullptr || group->world() < 2) return;
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> buffers;
  // The step counts (integers; a rank whose part of a batch was empty did
  // not count it): rank 0's.
  std::vector<double> counts;
  for (const torch::Tensor& b : VoteNetAccess::Of(*net).net->buffers()) {
    if (b.is_floating_point())
      buffers.push_back(b);
    else
      counts.push_back(group->rank() == 0 ? static_cast<double>(b.item<int64_t>()) : 0.0);
  }
  group->SumDoubles(&counts);
  size_t count = 0;
  for (torch::Tensor b : VoteNetAccess::Of(*net).net->buffers()) {
    if (!b.is_floating_point()) b.fill_(static_cast<int64_t>(counts[count++]));
  }
  std::vector<torch::Tensor> parts;
  for (const torch::Tensor& b : buffers) parts.push_back(b.reshape(-1).to(torch::kFloat32));
  torch::Tensor flat = torch::cat(parts).contiguous();
  group->SumFloats(flat.data_ptr<float>(), static_cast<size_t>(flat.numel()));
  flat.div_(group->world());
  int64_t at = 0;
  for (torch::Tensor& b : buffers) {
    b.copy_(flat.slice(0, at, at + b.numel()).view_as(b));
    at += b.numel();
  }
}

const VoteNetStepTimes& VoteNetOptimizer::times() const { return impl_->times; }

namespace {

constexpr char kAdamMagic[8] = {'F', 'V', 'N', 'A', 'D', 'A', 'M', '1'};

void AppendTensor(std::string* out, const torch::Tensor& tensor) {
  const torch::Tensor flat = tensor.to(torch::kFloat32).contiguous();
  out->append(reinterpret_cast<const char*>(flat.data_ptr<float>()),
              static_cast<size_t>(flat.numel()) * sizeof(float));
}

// `like`'s shape filled from bytes[*at...], which must hold it whole.
torch::Tensor TakeTensor(const std::string& bytes,
                         size_t* at,
                         const torch::Tensor& like,
                         const std::string& what) {
  const size_t size = static_cast<size_t>(like.numel()) * sizeof(float);
  Require(bytes.size() - *at >= size, what + ": optimiser state is truncated");
  torch::Tensor tensor = torch::empty_like(like, torch::kFloat32);
  std::memcpy(tensor.data_ptr<float>(), bytes.data() + *at, size);
  *at += size;
  return tensor;
}

}  // namespace

std::string VoteNetOptimizer::SaveState() const {
  std::string out(kAdamMagic, sizeof(kAdamMagic));
  for (const auto& group : impl_->adam->param_groups()) {
    for (const torch::Tensor& p : group.params()) {
      const auto found = impl_->adam->state().find(c10::guts::to_string(p.unsafeGetTensorImpl()));
      const bool has = found != impl_->adam->state().end();
      out.push_back(has ? 1 : 0);
      if (!has) continue;
      const auto& state = static_cast<const torch::optim::AdamParamState&>(*found->second);
      const int64_t step = state.step();
      out.append(reinterpret_cast<const char*>(&step), sizeof(step));
      AppendTensor(&out, state.exp_avg());
      AppendTensor(&out, state.exp_avg_sq());
    }
  }
  return out;
}

namespace {

// `from`'s named tensors copied into `to`'s of the same names and shapes.
void CopyTensorsInPlace(const torch::OrderedDict<std::string, torch::Tensor>& from,
                        const torch::OrderedDict<std::string, torch::Tensor>& to,
                        const std::string& what) {
  Require(from.size() == to.size(), what + ": its weights are not this network's");
  for (const auto& item : to) {
    const torch::Tensor* source = from.find(item.key());
    Require(source != nullptr && source->sizes() == item.value().sizes(),
            what + ": its weight " + item.key() + " is not this network's");
    item.value().copy_(*source);
  }
}

}  // namespace

void VoteNetOptimizer::RestoreState(const VoteNet& weights,
                                    const std::string& bytes,
                                    const std::string& what) {
  Require(!weights.empty() && weights.Members() == 1, what + ": no single network to restore");
  {
    torch::NoGradGuard no_grad;
    const auto& from = *VoteNetAccess::Of(weights).net;
    CopyTensorsInPlace(from.named_parameters(), impl_->net->net->named_parameters(), what);
    CopyTensorsInPlace(from.named_buffers(), impl_->net->net->named_buffers(), what);
  }
  Require(bytes.size() >= sizeof(kAdamMagic) &&
              std::memcmp(bytes.data(), kAdamMagic, sizeof(kAdamMagic)) == 0,
          what + ": not a vote network optimiser state");
  size_t at = sizeof(kAdamMagic);
  for (const auto& group : impl_->adam->param_groups()) {
    for (const torch::Tensor& p : group.params()) {
      Require(at < bytes.size(), what + ": optimiser state is truncated");
      const std::string key = c10::guts::to_string(p.unsafeGetTensorImpl());
      if (bytes[at++] == 0) {
        impl_->adam->state().erase(key);
        continue;
      }
      int64_t step = 0;
      Require(bytes.size() - at >= sizeof(step), what + ": optimiser state is truncated");
      std::memcpy(&step, bytes.data() + at, sizeof(step));
      at += sizeof(step);
      auto state = std::make_unique<torch::optim::AdamParamState>();
      state->step(step);
      state->exp_avg(TakeTensor(bytes, &at, p, what));
      state->exp_avg_sq(TakeTensor(bytes, &at, p, what));
      impl_->adam->state()[key] = std::move(state);
    }
  }
  Require(at == bytes.size(), what + ": optimiser state has bytes after its last parameter");
}

VoteNetWeightAverage::VoteNetWeightAverage(const VoteNet& net, double decay)
    : average_(VoteNet::Deserialize(net.Serialize(), "the network's weights")), decay_(decay) {
  Require(decay >= 0 && decay < 1, "a weight average's decay must be in [0, 1)");
  average_.SetPrecision(net.precision());  // validated in the arithmetic it trains in
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

namespace {

std::vector<torch::nn::BatchNorm2dImpl*> BatchNorms(UNet net) {
  std::vector<torch::nn::BatchNorm2dImpl*> norms;
  for (const std::shared_ptr<torch::nn::Module>& module : net->modules(/*include_self=*/false))
    if (auto* norm = dynamic_cast<torch::nn::BatchNorm2dImpl*>(module.get())) norms.push_back(norm);
  return norms;
}

// One member's statistics re-estimated on `images`, blended with its own;
// adds each channel's |mean shift| / old sd and log variance ratio to the
// sums and returns the member's batch normalisations.
int AdaptMember(UNet net,
                const std::vector<const BevImage*>& images,
                const BevGridSpec& spec,
                int batch_size,
                double blend,
                double* shift_sum,
                double* log_ratio_sum,
                int64_t* channels) {
  const std::vector<torch::nn::BatchNorm2dImpl*> norms = BatchNorms(net);
  std::vector<torch::Tensor> old_mean, old_var, old_batches;
  // torch's optional (c10's, std's in newer releases): empty is the cumulative average.
  using Momentum = std::decay_t<decltype(torch::nn::BatchNormOptions(1).momentum())>;
  std::vector<Momentum> momentum;
  for (torch::nn::BatchNorm2dImpl* norm : norms) {
    old_mean.push_back(norm->running_mean.clone());
    old_var.push_back(norm->running_var.clone());
    old_batches.push_back(norm->num_batches_tracked.clone());
    momentum.push_back(norm->options.momentum());
    norm->reset_running_stats();
    norm->options.momentum(Momentum());
  }
  torch::NoGradGuard no_grad;
  net->train();
  for (size_t first = 0; first < images.size(); first += batch_size) {
    const size_t last = std::min(images.size(), first + batch_size);
    const std::vector<const BevImage*> batch(images.begin() + first, images.begin() + last);
    net->forward(ImageTensor(batch, spec));
  }
  net->eval();
  for (size_t i = 0; i < norms.size(); ++i) {
    torch::nn::BatchNorm2dImpl& norm = *norms[i];
    norm.running_mean.mul_(blend).add_(old_mean[i], 1 - blend);
    norm.running_var.mul_(blend).add_(old_var[i], 1 - blend);
    norm.options.momentum(momentum[i]);
    norm.num_batches_tracked.copy_(old_batches[i]);  // a count, not a statistic: kept
    const double eps = norm.options.eps();
    const torch::Tensor old_sd = (old_var[i] + eps).sqrt();
    *shift_sum += ((norm.running_mean - old_mean[i]).abs() / old_sd).sum().item<double>();
    *log_ratio_sum += ((norm.running_var + eps) / (old_var[i] + eps)).log().sum().item<double>();
    *channels += norm.running_mean.numel();
  }
  return static_cast<int>(norms.size());
}

}  // namespace

NormalisationShift AdaptNormalisation(VoteNet* net,
                                      const std::vector<const BevImage*>& images,
                                      int batch_size,
                                      double blend) {
  Require(net != nullptr && !net->empty(), "an empty vote network has no statistics to adapt");
  Require(!images.empty(), "adapting a vote network's statistics needs at least one image");
  Require(batch_size >= 2,
          "adapting a vote network's statistics needs batches of at least 2 images (got " +
              std::to_string(batch_size) + ")");
  Require(blend >= 0 && blend <= 1,
          "the blend of adapted statistics must be in [0, 1] (got " + std::to_string(blend) + ")");
  VoteNet::Impl& impl = VoteNetAccess::Of(*net);
  for (const BevImage* image : images)  // before any statistic is touched
    Require(image != nullptr && image->spec == impl.options.grid,
            "a BEV image's grid differs from the vote network's (rasterise with its spec)");
  std::vector<UNet> members{impl.net};
  members.insert(members.end(), impl.partners.begin(), impl.partners.end());
  NormalisationShift shift;
  shift.images = static_cast<int64_t>(images.size());
  double shift_sum = 0, log_ratio_sum = 0;
  int64_t channels = 0;
  for (UNet& member : members)
    shift.layers += AdaptMember(member,
                                images,
                                impl.options.grid,
                                batch_size,
                                blend,
                                &shift_sum,
                                &log_ratio_sum,
                                &channels);
  if (channels > 0) {
    shift.mean_shift_sd = shift_sum / channels;
    shift.variance_ratio = std::exp(log_ratio_sum / channels);
  }
  return shift;
}

VoteNetLoss EvaluateVoteNetLoss(const VoteNet& net,
                                const TrainingBatch& batch,
                                const VoteNetLossWeights& weights,
                                std::vector<BevOutput>* outputs) {
  Require(!net.empty(), "an empty vote network has no loss");
  Require(outputs == nullptr || net.Members() == 1,
          "a batch's outputs with its loss are a single network's, not an ensemble's");
  const VoteNet::Impl& impl = VoteNetAccess::Of(net);
  torch::NoGradGuard no_grad;
  const torch::Tensor input = ImageTensor(Pointers(batch.images), impl.options.grid);
  const TargetTensors targets = TargetTensorsOf(Pointers(batch.targets), impl.options.grid);
  const torch::Tensor output = impl.net.ptr()->forward(input);
  const VoteNetLoss loss = VoteNetLossOf(output, targets, weights, nullptr);
  for (size_t i = 0; outputs != nullptr && i < batch.images.size(); ++i) {
    outputs->push_back(BevOutputOf(ActivatedAnswer(output[static_cast<int64_t>(i)].clone()),
                                   batch.images[i],
                                   impl.options.coder));
  }
  return loss;
}

}  // namespace furn

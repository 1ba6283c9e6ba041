#include "core/learned/vote_net.h"

#include <ATen/autocast_mode.h>

#include "core/learned/vote_net_module.h"
#include "core/learned/vote_net_upgrade.h"

#include <cstdlib>
#include <cstring>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/util/error.h"

namespace furn {
namespace {

constexpr char kMagic[8] = {'F', 'U', 'R', 'N', 'V', 'N', 'E', 'T'};
// 4: the weights as plain tensor records (issue 39); 3: the coder's options
// in the header (issue 37); 2: dense votes and membership. Versions 2 and 3
// hold the weights as a TorchScript archive, whose loading can run code: not
// read (nor is 1, whose channels mean something else).
// 9: an ensemble's member count before the weight records (before: one
// network); 8: the centre cells' radius (before: the centre cell alone); 7:
// edge votes (before: none); 6: the U-Net's levels (before: 3); 5: the range
// (4: 3 m).
constexpr uint32_t kVersion = 9;
constexpr uint32_t kFirstEnsembleVersion = 9;
constexpr uint32_t kOldestVersion = 4;  // the first format of weight records
constexpr uint32_t kFirstArchiveVersion = 2;

// A tensor record's element type.
enum class RecordType : uint8_t { kFloat32 = 0, kInt64 = 1 };
constexpr uint32_t kMaxNameBytes = 256;
constexpr uint32_t kMaxDims = 4;

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

// A name read from a file, fit for a one-line message: printable ASCII only.
std::string Printable(const std::string& text) {
  std::string out;
  for (char c : text.substr(0, 64)) out += c >= 0x20 && c < 0x7f ? c : '?';
  return out;
}

// Every parameter and buffer of the network, named, in the module's order:
// what the weight records hold, one each, in that order.
std::vector<std::pair<std::string, torch::Tensor>> NamedTensors(const UNet& net) {
  std::vector<std::pair<std::string, torch::Tensor>> tensors;
  for (const auto& item : net->named_parameters()) tensors.emplace_back(item.key(), item.value());
  for (const auto& item : net->named_buffers()) tensors.emplace_back(item.key(), item.value());
  return tensors;
}

RecordType TypeOf(const torch::Tensor& tensor) {
  if (tensor.scalar_type() == torch::kFloat32) return RecordType::kFloat32;
  Require(tensor.scalar_type() == torch::kInt64, "a vote network tensor of an unexpected type");
  return RecordType::kInt64;
}

void PutTensor(std::string* out, const std::string& name, const torch::Tensor& tensor) {
  Put(out, static_cast<uint32_t>(name.size()));
  out->append(name);
  Put(out, static_cast<uint8_t>(TypeOf(tensor)));
  Put(out, static_cast<uint32_t>(tensor.dim()));
  for (int64_t d = 0; d < tensor.dim(); ++d) Put(out, static_cast<int64_t>(tensor.size(d)));
  const torch::Tensor data = tensor.detach().contiguous();
  out->append(static_cast<const char*>(data.data_ptr()), data.numel() * data.element_size());
}

// One record into `tensor` (the network built from the header): its name,
// type and shape must be the expected ones, checked before any data is read.
void TakeTensor(const std::string& bytes,
                size_t* at,
                const std::string& what,
                const std::string& name,
                torch::Tensor tensor) {
  const std::string corrupt = what + ": vote network is corrupt (";
  const uint32_t name_size = Take<uint32_t>(bytes, at, what);
  Require(name_size <= kMaxNameBytes, corrupt + "a weight record's name is too long)");
  Require(*at + name_size <= bytes.size(), what + ": vote network is truncated");
  const std::string stored = bytes.substr(*at, name_size);
  *at += name_size;
  Require(stored == name,
          corrupt + "weight record '" + Printable(stored) + "' where '" + name + "' belongs)");
  const uint8_t type = Take<uint8_t>(bytes, at, what);
  Require(type == static_cast<uint8_t>(TypeOf(tensor)),
          corrupt + "weight " + name + " has the wrong element type)");
  const uint32_t dims = Take<uint32_t>(bytes, at, what);
  Require(dims <= kMaxDims && dims == static_cast<uint32_t>(tensor.dim()),
          corrupt + "weight " + name + " has " + std::to_string(dims) + " dimensions, not " +
              std::to_string(tensor.dim()) + ")");
  for (uint32_t d = 0; d < dims; ++d) {
    const int64_t size = Take<int64_t>(bytes, at, what);
    Require(size == tensor.size(d),
            corrupt + "weight " + name + " is declared " + std::to_string(size) +
                " along dimension " + std::to_string(d) + ", the network's header makes it " +
                std::to_string(tensor.size(d)) + ")");
  }
  const size_t data_bytes = static_cast<size_t>(tensor.numel()) * tensor.element_size();
  Require(data_bytes <= bytes.size() - *at,
          what + ": vote network is truncated (weight " + name + ")");
  torch::NoGradGuard no_grad;
  Require(tensor.is_contiguous(), "a vote network tensor is not contiguous");
  std::memcpy(tensor.data_ptr(), bytes.data() + *at, data_bytes);
  *at += data_bytes;
}

// The options as this format's header stores them (after magic and version).
std::string HeaderBytes(const VoteNetOptions& o) {
  std::string out;
  Put(&out, o.grid.cell_m);
  Put(&out, static_cast<int32_t>(o.grid.rows));
  Put(&out, static_cast<int32_t>(o.grid.cols));
  Put(&out, o.grid.floor_band_m);
  Put(&out, static_cast<int32_t>(o.width));
  Put(&out, static_cast<int32_t>(o.coder.dense_votes ? 1 : 0));
  Put(&out, o.coder.heat_sigma_cells);
  Put(&out, o.coder.vote_margin_m);
  Put(&out, o.coder.ignore_radius_cells);
  Put(&out, o.range_m);
  Put(&out, static_cast<int32_t>(o.levels));
  Put(&out, static_cast<int32_t>(o.coder.edge_votes ? 1 : 0));
  Put(&out, o.coder.centre_radius_cells);
  return out;
}

// One member's weight records: their count, then each.
void PutMember(std::string* out, const UNet& net) {
  const auto tensors = NamedTensors(net);
  Put(out, static_cast<uint32_t>(tensors.size()));
  for (const auto& [name, tensor] : tensors) PutTensor(out, name, tensor);
}

// One member's weight records into `net` (built from the header), checked
// record by record before its data is read, and finite.
void TakeMember(const std::string& bytes, size_t* at, const std::string& what, const UNet& net) {
  const auto tensors = NamedTensors(net);
  const uint32_t count = Take<uint32_t>(bytes, at, what);
  Require(count == tensors.size(),
          what + ": vote network is corrupt (" + std::to_string(count) +
              " weight records; the network its header describes has " +
              std::to_string(tensors.size()) + ")");
  for (const auto& [name, tensor] : tensors) TakeTensor(bytes, at, what, name, tensor);
  for (const auto& [name, tensor] : tensors) {
    if (tensor.is_floating_point())
      Require(torch::isfinite(tensor).all().item<bool>(),
              what + ": vote network is corrupt (weight " + name + " is not finite)");
  }
}

// A mirrored image's answer in the image's frame: columns reversed, the
// column offset negated and, with edge votes, the column sides swapped.
// The yaw channels are left as they are (their mirror depends on the class).
torch::Tensor TurnedBack(const torch::Tensor& mirrored, bool edge_votes) {
  namespace ch = bev_channels;
  torch::Tensor back = mirrored.flip({2});
  back.select(0, ch::kOffset[1]).neg_();
  if (edge_votes) {
    const torch::Tensor col_min = back.select(0, ch::kEdges[2]).clone();
    back.select(0, ch::kEdges[2]).copy_(back.select(0, ch::kEdges[3]));
    back.select(0, ch::kEdges[3]).copy_(col_min);
  }
  return back;
}

// The U-Net `options` describe (fresh weights from torch's generator); every
// member of an ensemble is built by it.
UNet NetworkOf(const VoteNetOptions& options) {
  return UNet(kBevChannels, options.width, options.coder.Channels(), options.levels);
}

// The FURNVNET magic and the format version after it; `at` moves past both.
uint32_t ReadMagicAndVersion(const std::string& bytes, size_t* at, const std::string& what) {
  Require(bytes.size() >= sizeof(kMagic) && std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) == 0,
          what + ": not a vote network (no FURNVNET header)");
  *at = sizeof(kMagic);
  return Take<uint32_t>(bytes, at, what);
}

}  // namespace

VoteNetOptions ReadVoteNetHeader(const std::string& bytes,
                                 size_t* at,
                                 const std::string& what,
                                 uint32_t version) {
  VoteNetOptions options;
  options.grid.cell_m = Take<double>(bytes, at, what);
  options.grid.rows = Take<int32_t>(bytes, at, what);
  options.grid.cols = Take<int32_t>(bytes, at, what);
  options.grid.floor_band_m = Take<double>(bytes, at, what);
  options.width = Take<int32_t>(bytes, at, what);
  if (version == kFirstArchiveVersion) {  // dense votes only, the coder implied
    options.coder = BevCoderOptions::Dense();
  } else {
    const int32_t dense = Take<int32_t>(bytes, at, what);
    Require(dense == 0 || dense == 1, what + ": vote network is corrupt (dense votes flag)");
    options.coder.dense_votes = dense == 1;
    options.coder.heat_sigma_cells = Take<double>(bytes, at, what);
    options.coder.vote_margin_m = Take<double>(bytes, at, what);
    options.coder.ignore_radius_cells = Take<double>(bytes, at, what);
  }
  options.range_m = version >= 5 ? Take<double>(bytes, at, what) : 3.0;  // 4: trained on 3 m
  options.levels = version >= 6 ? Take<int32_t>(bytes, at, what) : 3;
  if (version >= 7) {
    const int32_t edges = Take<int32_t>(bytes, at, what);
    Require(edges == 0 || edges == 1, what + ": vote network is corrupt (edge votes flag)");
    options.coder.edge_votes = edges == 1;
  }
  // 8: the centre cells' radius (before: the centre cell alone).
  if (version >= 8) options.coder.centre_radius_cells = Take<double>(bytes, at, what);
  try {
    options.Check();  // bounds the network the header builds (width, grid, levels)
  } catch (const InputError& error) {
    throw InputError(what + ": vote network is corrupt (" + error.what() + ")");
  }
  return options;
}

std::string UpgradeTorchScriptVoteNet(const std::string& bytes, const std::string& what) {
  size_t at = 0;
  const uint32_t version = ReadMagicAndVersion(bytes, &at, what);
  // Current and plain-tensor formats go through the same checks as a load
  // (finite weights, bounded grid): an upgrade never writes what a load refuses.
  if (version >= kOldestVersion) return VoteNet::Deserialize(bytes, what).Serialize();
  Require(version == kFirstArchiveVersion || version == kFirstArchiveVersion + 1,
          what + ": vote network format " + std::to_string(version) + " cannot be upgraded");
  const VoteNetOptions options = ReadVoteNetHeader(bytes, &at, what, version);
  const uint64_t blob_size = Take<uint64_t>(bytes, &at, what);
  Require(blob_size == bytes.size() - at,
          what + ": vote network is corrupt (its weights block has the wrong length)");
  VoteNet net = VoteNet::Create(options, 0);
  try {
    torch::serialize::InputArchive archive;
    std::istringstream in(bytes.substr(at));
    archive.load_from(in);
    VoteNetAccess::Of(net).net->load(archive);
  } catch (const c10::Error& error) {
    std::string reason = error.what_without_backtrace();
    reason = reason.substr(0, reason.find('\n'));
    throw InputError(what + ": vote network weights are unreadable (" + reason + ")");
  }
  const std::string upgraded = net.Serialize();
  VoteNet::Deserialize(upgraded, what);  // the archive's weights checked as a load checks them
  return upgraded;
}

ConvBlockImpl::ConvBlockImpl(int in, int out)
    : conv1(torch::nn::Conv2dOptions(in, out, 3).padding(1).bias(false)),
      bn1(out),
      conv2(torch::nn::Conv2dOptions(out, out, 3).padding(1).bias(false)),
      bn2(out) {
  register_module("conv1", conv1);
  register_module("bn1", bn1);
  register_module("conv2", conv2);
  register_module("bn2", bn2);
}

torch::Tensor ConvBlockImpl::forward(torch::Tensor x) {
  x = torch::relu(bn1(conv1(x)));
  return torch::relu(bn2(conv2(x)));
}

UNetImpl::UNetImpl(int in, int w, int out, int levels) {
  const auto channels = [w](int level) { return w * std::min(1 << level, 4); };
  for (int i = 0; i < levels; ++i) {
    encoders.push_back(register_module("e" + std::to_string(i + 1),
                                       ConvBlock(i == 0 ? in : channels(i - 1), channels(i))));
  }
  bottom = register_module("bottom", ConvBlock(channels(levels - 1), channels(levels)));
  decoders.resize(levels, ConvBlock(nullptr));
  for (int i = levels - 1; i >= 0; --i) {
    // The level below's output (the bottleneck's for the deepest) and this
    // level's skip connection.
    decoders[i] = register_module("d" + std::to_string(i + 1),
                                  ConvBlock(channels(i + 1) + channels(i), channels(i)));
  }
  head = register_module("head", torch::nn::Conv2d(torch::nn::Conv2dOptions(w, out, 1)));
  // CenterNet's heat bias: sigmoid(-2.19) = 0.1, so the first steps are not
  // swamped by the background; the membership likewise.
  torch::NoGradGuard no_grad;
  head->bias.zero_();
  namespace ch = bev_channels;
  head->bias.slice(0, ch::kHeat.first, ch::kHeat.end()).fill_(-2.19);
  head->bias.slice(0, ch::kMembership.first, ch::kMembership.end()).fill_(-2.19);
}

namespace {

torch::Tensor Up(const torch::Tensor& x, const torch::Tensor& like) {
  return torch::nn::functional::interpolate(
      x,
      torch::nn::functional::InterpolateFuncOptions()
          .size(std::vector<int64_t>{like.size(2), like.size(3)})
          .mode(torch::kNearest));
}

}  // namespace

// Torch's CPU autocast to bfloat16 on this thread for the guard's life (the
// state is thread-local), restored after; the casts it caches are dropped
// when the outermost guard ends, as torch.autocast's exit does.
class Bf16Autocast {
 public:
  Bf16Autocast()
      : was_enabled_(at::autocast::is_cpu_enabled()),
        was_type_(at::autocast::get_autocast_cpu_dtype()) {
    at::autocast::set_autocast_cpu_dtype(at::kBFloat16);
    at::autocast::set_cpu_enabled(true);
    at::autocast::increment_nesting();
  }
  ~Bf16Autocast() {
    if (at::autocast::decrement_nesting() == 0) at::autocast::clear_cache();
    at::autocast::set_cpu_enabled(was_enabled_);
    at::autocast::set_autocast_cpu_dtype(was_type_);
  }
  Bf16Autocast(const Bf16Autocast&) = delete;
  Bf16Autocast& operator=(const Bf16Autocast&) = delete;

 private:
  bool was_enabled_;
  at::ScalarType was_type_;
};

torch::Tensor UNetImpl::forward(const torch::Tensor& x) {
  if (!bf16) return Layers(x);
  // Channels-last activations: oneDNN's bfloat16 convolutions take them as
  // they are (in torch's default layout each convolution reorders its input
  // and output, which cost more than the convolutions themselves).
  Bf16Autocast autocast;
  return Layers(x.contiguous(torch::MemoryFormat::ChannelsLast)).to(torch::kFloat32).contiguous();
}

torch::Tensor UNetImpl::Layers(const torch::Tensor& x) {
  std::vector<torch::Tensor> skips;
  torch::Tensor y = x;
  for (size_t i = 0; i < encoders.size(); ++i) {
    y = encoders[i]->forward(i == 0 ? y : torch::max_pool2d(y, 2));
    skips.push_back(y);
  }
  y = bottom->forward(torch::max_pool2d(y, 2));
  for (size_t i = decoders.size(); i-- > 0;)
    y = decoders[i]->forward(torch::cat({Up(y, skips[i]), skips[i]}, 1));
  return head(y);
}

torch::Tensor StackPlanes(const std::vector<const std::vector<float>*>& planes,
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

torch::Tensor ImageTensor(const std::vector<const BevImage*>& images, const BevGridSpec& spec) {
  std::vector<const std::vector<float>*> planes;
  for (const BevImage* image : images) {
    Require(image->spec == spec,
            "a BEV image's grid differs from the vote network's (rasterise with its spec)");
    planes.push_back(&image->values);
  }
  return StackPlanes(planes, kBevChannels, spec);
}

TargetTensors TargetTensorsOf(const std::vector<const BevTargets*>& targets,
                              const BevGridSpec& spec) {
  Require(!targets.empty(), "a training batch has no targets");
  const int channels = targets[0]->channels;
  const bool edges = !targets[0]->edges.empty();
  std::vector<const std::vector<float>*> values, votes, weight, edge_cells;
  for (const BevTargets* t : targets) {
    Require(t->channels == channels && t->edges.empty() != edges,
            "a training batch mixes targets of two encodings");
    values.push_back(&t->values);
    votes.push_back(&t->votes);
    weight.push_back(&t->weight);
    if (edges) edge_cells.push_back(&t->edges);
  }
  TargetTensors tensors{StackPlanes(values, channels, spec),
                        StackPlanes(votes, 1, spec).squeeze(1),
                        StackPlanes(weight, 1, spec).squeeze(1),
                        {}};
  if (edges) tensors.edges = StackPlanes(edge_cells, 1, spec).squeeze(1);
  return tensors;
}

void VoteNetOptions::Check() const {
  grid.Check();
  coder.Check();
  Require(range_m > 0 && range_m <= 20,
          "vote network range " + std::to_string(range_m) + " m must be in (0, 20]");
  Require(width >= 4 && width <= 128,
          "vote network width " + std::to_string(width) + " must be in 4..128");
  Require(levels >= 2 && levels <= 5,
          "vote network levels " + std::to_string(levels) + " must be in 2..5");
  Require((grid.rows >> levels) >= 1 && (grid.cols >> levels) >= 1,
          "a BEV grid of " + std::to_string(grid.rows) + " x " + std::to_string(grid.cols) +
              " cells cannot be halved " + std::to_string(levels) + " times");
  // The grid is what the range fills, no more: rows reach forward, columns
  // to both sides, with a metre of slack; a range below the default grid's
  // reach (72 x 96 cells of 5 cm: 3.6 x 4.8 m) keeps that grid. A network's
  // cost grows with its cells, so a file cannot ask for a grid its range
  // leaves empty.
  const double reach_m = std::max(range_m, 3.6);
  const double forward_m = grid.rows * grid.cell_m, lateral_m = grid.cols * grid.cell_m;
  Require(forward_m <= reach_m + 1 && lateral_m <= 2 * reach_m + 1 &&
              static_cast<int64_t>(grid.rows) * grid.cols <= kMaxGridCells,
          "a BEV grid of " + std::to_string(grid.rows) + " x " + std::to_string(grid.cols) +
              " cells of " + std::to_string(grid.cell_m) + " m must reach at most the range (" +
              std::to_string(range_m) +
              " m, at least 3.6) + 1 m forward, twice it + 1 m "
              "across, and hold at "
              "most " +
              std::to_string(kMaxGridCells) + " cells");
}

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
  net.impl_->net = NetworkOf(options);
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
  for (const UNet& partner : impl_->partners) {
    for (const torch::Tensor& p : partner->parameters()) count += p.numel();
  }
  return count;
}

std::string VoteNet::Serialize() const {
  Require(impl_ != nullptr, "an empty vote network cannot be saved");
  std::string out(kMagic, sizeof(kMagic));
  Put(&out, kVersion);
  out += HeaderBytes(impl_->options);
  Put(&out, static_cast<uint32_t>(Members()));
  PutMember(&out, impl_->net);
  for (const UNet& partner : impl_->partners) PutMember(&out, partner);
  return out;
}

VoteNet VoteNet::Deserialize(const std::string& bytes, const std::string& what) {
  size_t at = 0;
  const uint32_t version = ReadMagicAndVersion(bytes, &at, what);
  Require(version != kFirstArchiveVersion && version != kFirstArchiveVersion + 1,
          what + ": vote network format " + std::to_string(version) +
              " keeps its weights as a TorchScript archive, which this build does not load "
              "(loading one can run code): train the model again with this build");
  Require(version >= kOldestVersion && version <= kVersion,
          what + ": vote network format " + std::to_string(version) + " is not this build's (" +
              std::to_string(kVersion) + "): train the model again with this build");
  const VoteNetOptions options = ReadVoteNetHeader(bytes, &at, what, version);
  const uint32_t members = version >= kFirstEnsembleVersion ? Take<uint32_t>(bytes, &at, what) : 1;
  Require(members >= 1 && members <= static_cast<uint32_t>(kMaxMembers),
          what + ": vote network is corrupt (" + std::to_string(members) +
              " ensemble members; 1.." + std::to_string(kMaxMembers) + " are readable)");
  VoteNet net = Create(options, 0);
  TakeMember(bytes, &at, what, net.impl_->net);
  // Each further member is built only once the one before has been read
  // whole: a header's count alone allocates nothing.
  for (uint32_t m = 1; m < members; ++m) {
    Require(at < bytes.size(),
            what + ": vote network is truncated (member " + std::to_string(m + 1) + " of " +
                std::to_string(members) + ")");
    net.impl_->partners.push_back(NetworkOf(options));
    TakeMember(bytes, &at, what, net.impl_->partners.back());
    net.impl_->partners.back()->eval();
  }
  Require(at == bytes.size(), what + ": vote network is corrupt (bytes after its last weight)");
  net.impl_->net->eval();
  return net;
}

VoteNet VoteNet::Ensemble(std::vector<VoteNet> members, const std::string& what) {
  Require(!members.empty() && members.size() <= static_cast<size_t>(kMaxMembers),
          what + ": an ensemble has 1.." + std::to_string(kMaxMembers) + " members, not " +
              std::to_string(members.size()));
  for (size_t m = 0; m < members.size(); ++m) {
    Require(!members[m].empty() && members[m].Members() == 1,
            what + ": ensemble member " + std::to_string(m + 1) +
                " must be a single network (not empty, not an ensemble)");
    Require(HeaderBytes(members[m].options()) == HeaderBytes(members[0].options()),
            what + ": ensemble member " + std::to_string(m + 1) +
                " differs from member 1 in grid, width, levels, range or encoding");
  }
  VoteNet ensemble = std::move(members[0]);
  for (size_t m = 1; m < members.size(); ++m)
    ensemble.impl_->partners.push_back(members[m].impl_->net);
  ensemble.SetPrecision(ensemble.precision());  // every member in the first's arithmetic
  return ensemble;
}

int VoteNet::Members() const {
  return impl_ == nullptr ? 0 : 1 + static_cast<int>(impl_->partners.size());
}

BevOutput VoteNet::Predict(const BevImage& image, bool mirror_average) const {
  Require(impl_ != nullptr, "an empty vote network cannot predict");
  torch::NoGradGuard no_grad;
  namespace ch = bev_channels;
  const torch::Tensor input = ImageTensor({&image}, impl_->options.grid);  // 1 x C x rows x cols
  // The mirrored image: columns reversed, as BevImage::Mirrored.
  const torch::Tensor mirrored = mirror_average ? input.flip({3}) : torch::Tensor();
  const int members = Members();
  const int views = mirror_average ? 2 : 1;
  const int passes = std::max(members, views);
  // Pass k is member k mod M on view k mod views; a member's views go in one
  // batch (one network with the mirror: the image and its mirror together).
  std::vector<torch::Tensor> answers(passes);
  for (int m = 0; m < members; ++m) {
    std::vector<torch::Tensor> batch;
    for (int k = m; k < passes; k += members) batch.push_back(k % views == 0 ? input : mirrored);
    const UNet& net = m == 0 ? impl_->net : impl_->partners[m - 1];
    torch::Tensor out = net.ptr()->forward(batch.size() == 1 ? batch[0] : torch::cat(batch, 0));
    for (int k = m, i = 0; k < passes; k += members, ++i) answers[k] = ActivatedAnswer(out[i]);
  }
  // Heat, membership, offset and footprint (and edge distances) are
  // averaged over the passes, each mirror's answer turned back first; the
  // yaw stays the first pass's.
  torch::Tensor output = answers[0];
  if (passes > 1) {
    std::vector<BevSlice> averaged = {ch::kHeat, ch::kMembership, ch::kOffset, ch::kLogSize};
    if (impl_->options.coder.edge_votes) averaged.push_back(ch::kEdges);
    for (int k = 1; k < passes; ++k) {
      const torch::Tensor answer =
          k % views == 0 ? answers[k] : TurnedBack(answers[k], impl_->options.coder.edge_votes);
      for (const BevSlice& slice : averaged)
        output.slice(0, slice.first, slice.end()).add_(answer.slice(0, slice.first, slice.end()));
    }
    for (const BevSlice& slice : averaged)
      output.slice(0, slice.first, slice.end()).mul_(1.0 / passes);
  }
  return BevOutputOf(output, image, impl_->options.coder);
}

torch::Tensor ActivatedAnswer(torch::Tensor answer) {
  namespace ch = bev_channels;
  answer.slice(0, ch::kHeat.first, ch::kHeat.end()).sigmoid_();
  answer.slice(0, ch::kMembership.first, ch::kMembership.end()).sigmoid_();
  return answer;
}

BevOutput BevOutputOf(const torch::Tensor& answer,
                      const BevImage& image,
                      const BevCoderOptions& coder) {
  const torch::Tensor values = answer.contiguous();
  BevOutput out;
  out.spec = image.spec;
  out.dense_votes = coder.dense_votes;
  out.edge_votes = coder.edge_votes;
  out.values.assign(values.data_ptr<float>(), values.data_ptr<float>() + values.numel());
  return out;
}

void VoteNet::SetPrecision(NetworkPrecision requested) {
  Require(impl_ != nullptr, "an empty vote network has no precision");
  impl_->precision = ResolvePrecision(requested);
  const bool bf16 = impl_->precision == NetworkPrecision::kBfloat16;
  impl_->net->bf16 = bf16;
  for (UNet& partner : impl_->partners) partner->bf16 = bf16;
}

NetworkPrecision VoteNet::precision() const {
  return impl_ == nullptr ? NetworkPrecision::kFloat32 : impl_->precision;
}

// Whether oneDNN may use an instruction set whose DNNL_MAX_CPU_ISA name
// contains `marker`: no cap (or ALL), or a cap naming it (AVX512_CORE_AMX
// for AMX, AVX512_CORE_BF16 and above for bfloat16).
bool OneDnnMayUse(const char* marker) {
  for (const char* name : {"ONEDNN_MAX_CPU_ISA", "DNNL_MAX_CPU_ISA"}) {
    const char* cap = std::getenv(name);
    if (cap == nullptr || *cap == '\0') continue;
    const std::string text = cap;
    return text == "ALL" || text.find(marker) != std::string::npos;
  }
  return true;
}

bool CpuHasAmxBf16() {
  // GCC's test counts AMX only where the operating system saves the tile
  // state (XCR0); oneDNN asks Linux for the permission itself.
  __builtin_cpu_init();
  return __builtin_cpu_supports("amx-bf16") && __builtin_cpu_supports("amx-tile") &&
         OneDnnMayUse("AMX");
}

bool CpuHasBf16() {
  __builtin_cpu_init();
  return CpuHasAmxBf16() ||
         (__builtin_cpu_supports("avx512bf16") && (OneDnnMayUse("BF16") || OneDnnMayUse("AMX")));
}

NetworkPrecision ResolvePrecision(NetworkPrecision requested) {
  if (requested == NetworkPrecision::kAuto) {
    if (const char* text = std::getenv("FURN_NETWORK_PRECISION"); text != nullptr && *text) {
      const std::optional<NetworkPrecision> chosen = TryParseEnum<NetworkPrecision>(text);
      Require(chosen.has_value(),
              std::string("FURN_NETWORK_PRECISION='") + text + "' must be auto, fp32 or bf16");
      requested = *chosen;
    }
  }
  switch (requested) {
    case NetworkPrecision::kAuto:
      return CpuHasAmxBf16() ? NetworkPrecision::kBfloat16 : NetworkPrecision::kFloat32;
    case NetworkPrecision::kBfloat16:
      Require(CpuHasBf16(),
              "network precision bf16: this CPU has neither AMX-BF16 nor AVX512-BF16 "
              "instructions (use auto or fp32)");
      return requested;
    case NetworkPrecision::kFloat32:
      return requested;
  }
  return NetworkPrecision::kFloat32;
}

void SetTorchThreads(int threads) {
  if (threads > 0) at::set_num_threads(threads);
}

int TorchThreads() { return at::get_num_threads(); }

}  // namespace furn

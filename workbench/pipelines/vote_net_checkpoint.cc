#include "workbench/pipelines/vote_net_checkpoint.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <type_traits>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

constexpr char kMagic[8] = {'F', 'V', 'N', 'C', 'K', 'P', 'T', '1'};
constexpr uint64_t kMaxCheckpointBytes = uint64_t{1} << 32;  // 4 GiB
constexpr uint32_t kMaxEpochs = 100000;

template <typename T>
void Put(std::string* out, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}
void PutText(std::string* out, const std::string& text) {
  Put<uint64_t>(out, text.size());
  out->append(text);
}

// Reads fields of a checkpoint's bytes, each within them.
class Reader {
 public:
  Reader(const std::string& bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}
  template <typename T>
  T Take() {
    Need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::string Text() {
    const uint64_t size = Take<uint64_t>();
    Need(size);
    std::string text = bytes_.substr(at_, size);
    at_ += size;
    return text;
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  void Need(uint64_t size) const { Require(size <= bytes_.size() - at_, what_ + ": truncated"); }
  const std::string& bytes_;
  std::string what_;
  size_t at_ = 0;
};

void PutEpoch(std::string* out, const VoteNetEpoch& e) {
  Put<int32_t>(out, e.epoch);
  for (double v : {e.train_loss,
                   e.validation_loss,
                   e.validation_terms.heat,
                   e.validation_terms.offset,
                   e.validation_terms.size,
                   e.validation_terms.yaw,
                   e.validation_terms.membership,
                   e.validation_terms.edges,
                   e.validation_map,
                   e.last_weights_map,
                   e.seconds})
    Put<double>(out, v);
}

VoteNetEpoch TakeEpoch(Reader* in) {
  VoteNetEpoch e;
  e.epoch = in->Take<int32_t>();
  for (double* v : {&e.train_loss,
                    &e.validation_loss,
                    &e.validation_terms.heat,
                    &e.validation_terms.offset,
                    &e.validation_terms.size,
                    &e.validation_terms.yaw,
                    &e.validation_terms.membership,
                    &e.validation_terms.edges,
                    &e.validation_map,
                    &e.last_weights_map,
                    &e.seconds})
    *v = in->Take<double>();
  return e;
}

void HashSamples(const std::vector<BevSample>& samples, ContentHasher* hasher) {
  const uint64_t count = samples.size();
  hasher->Update(&count, sizeof(count));
  for (const BevSample& sample : samples) {
    hasher->Update(sample.image.values.data(), sample.image.values.size() * sizeof(float));
    for (const BevObject& object : sample.objects) {
      const double box[5] = {object.x, object.y, object.yaw, object.width, object.depth};
      const int32_t kind[2] = {static_cast<int32_t>(object.furniture_class), object.target};
      hasher->Update(box, sizeof(box));
      hasher->Update(kind, sizeof(kind));
    }
    hasher->Update(sample.visibility.data(), sample.visibility.size() * sizeof(double));
    const char known = sample.background_known;
    hasher->Update(&known, 1);
  }
}

}  // namespace

std::string TrainingFingerprint(const std::vector<BevSample>& training,
                                const std::vector<BevSample>& validation,
                                const VoteNetTrainingOptions& options,
                                const VoteNet& initial) {
  ContentHasher hasher;
  HashSamples(training, &hasher);
  HashSamples(validation, &hasher);
  const std::string net = initial.Serialize();
  hasher.Update(net.data(), net.size());
  const double loop[] = {static_cast<double>(options.epochs),
                         static_cast<double>(options.batch_size),
                         options.learning_rate,
                         options.weight_average,
                         static_cast<double>(options.keep_last_weights),
                         static_cast<double>(options.WeightSeed()),
                         options.loss.heat,
                         options.loss.offset,
                         options.loss.size,
                         options.loss.yaw,
                         options.loss.membership,
                         options.loss.edges};
  hasher.Update(loop, sizeof(loop));
  // A bfloat16 training resumes only in bfloat16 (float's fingerprint is
  // the one it had before the option).
  if (initial.precision() == NetworkPrecision::kBfloat16) hasher.Update("bf16", 4);
  return hasher.HexDigest();
}

void WriteCheckpoint(const std::string& path, const VoteNetCheckpoint& checkpoint) {
  std::string out(kMagic, sizeof(kMagic));
  PutText(&out, checkpoint.fingerprint);
  Put<int32_t>(&out, checkpoint.epochs_done);
  Put<uint64_t>(&out, checkpoint.steps_done);
  PutText(&out, checkpoint.generator);
  PutText(&out, checkpoint.net);
  PutText(&out, checkpoint.adam);
  PutText(&out, checkpoint.average);
  Put<int64_t>(&out, checkpoint.average_updates);
  Put<uint32_t>(&out, static_cast<uint32_t>(checkpoint.epochs.size()));
  for (const VoteNetEpoch& epoch : checkpoint.epochs) PutEpoch(&out, epoch);
  WriteFileAtomically(path, out);
}

std::optional<VoteNetCheckpoint> ReadCheckpoint(const std::string& path,
                                                const std::string& fingerprint,
                                                bool quiet) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  auto skip = [&](const std::string& why) -> std::optional<VoteNetCheckpoint> {
    if (!quiet)
      std::fprintf(
          stderr, "vote net: %s: %s; training from the start\n", path.c_str(), why.c_str());
    return std::nullopt;
  };
  if (!std::filesystem::is_regular_file(path, ec)) return skip("not a regular file");
  if (std::filesystem::file_size(path, ec) > kMaxCheckpointBytes) return skip("over 4 GiB");
  try {
    const std::string bytes = ReadFileBytes(path);
    Require(
        bytes.size() >= sizeof(kMagic) && std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) == 0,
        path + ": not a vote network checkpoint");
    const std::string body = bytes.substr(sizeof(kMagic));
    Reader in(body, path);
    VoteNetCheckpoint checkpoint;
    checkpoint.fingerprint = in.Text();
    if (checkpoint.fingerprint != fingerprint) return skip("another training's checkpoint");
    checkpoint.epochs_done = in.Take<int32_t>();
    checkpoint.steps_done = in.Take<uint64_t>();
    checkpoint.generator = in.Text();
    checkpoint.net = in.Text();
    checkpoint.adam = in.Text();
    checkpoint.average = in.Text();
    checkpoint.average_updates = in.Take<int64_t>();
    const uint32_t epochs = in.Take<uint32_t>();
    Require(epochs <= kMaxEpochs, path + ": " + std::to_string(epochs) + " epochs");
    for (uint32_t e = 0; e < epochs; ++e) checkpoint.epochs.push_back(TakeEpoch(&in));
    Require(in.done(), path + ": bytes after its last record");
    Require(checkpoint.epochs_done >= 1 &&
                static_cast<size_t>(checkpoint.epochs_done) == checkpoint.epochs.size(),
            path + ": its epoch count does not match its records");
    return checkpoint;
  } catch (const InputError& e) {
    return skip(e.what());
  }
}

std::string MemberCheckpointPath(const std::string& path, int member) {
  return member == 0 ? path : path + ".member" + std::to_string(member);
}

void RemoveCheckpoints(const VoteNetTrainingOptions& options) {
  if (options.checkpoint_path.empty()) return;
  std::error_code ec;
  for (int k = 0; k < options.member + options.ensemble; ++k)
    std::filesystem::remove(MemberCheckpointPath(options.checkpoint_path, k), ec);
}

}  // namespace furn

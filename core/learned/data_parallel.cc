#include "core/learned/data_parallel.h"

#include <torch/torch.h>
#include <torch/csrc/distributed/c10d/FileStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>

#include <chrono>
#include <cstdlib>
#include <stdexcept>

#include "core/util/error.h"

namespace furn {

struct DataParallelGroup::Impl {
  c10::intrusive_ptr<c10d::FileStore> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group;
};

void DataParallelOptions::Check() const {
  Require(world >= 1 && world <= 1024,
          "data-parallel workers must be in 1..1024 (got " + std::to_string(world) + ")");
  Require(
      rank >= 0 && rank < world,
      "data-parallel rank " + std::to_string(rank) + " must be in 0.." + std::to_string(world - 1));
  Require(world == 1 || !store_path.empty(), "data-parallel training needs a store file");
  Require(timeout_s > 0 && timeout_s <= 86400,
          "data-parallel timeout must be in (0, 86400] s (got " + std::to_string(timeout_s) + ")");
}

namespace {

// The group's errors name it and the rank.
[[noreturn]] void GroupFailed(const DataParallelOptions& options, const std::exception& e) {
  std::string what = e.what();
  what = what.substr(0, what.find('\n'));
  throw std::runtime_error("data-parallel rank " + std::to_string(options.rank) + " of " +
                           std::to_string(options.world) + " (store " + options.store_path +
                           "): " + what);
}

void Sum(c10d::ProcessGroupGloo* group, torch::Tensor tensor, const DataParallelOptions& options) {
  try {
    std::vector<torch::Tensor> tensors{std::move(tensor)};
    group->allreduce(tensors)->wait();
  } catch (const std::exception& e) {
    GroupFailed(options, e);
  }
}

std::shared_ptr<gloo::transport::Device> Device(const DataParallelOptions& options) {
  using Gloo = c10d::ProcessGroupGloo;
  if (options.local) return Gloo::createDeviceForHostname("127.0.0.1");
  if (const char* interface = std::getenv("GLOO_SOCKET_IFNAME"); interface && *interface)
    return Gloo::createDeviceForInterface(interface);
  return Gloo::createDefaultDevice();
}

}  // namespace

DataParallelGroup::DataParallelGroup(const DataParallelOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  options.Check();
  if (!options.Active()) return;
  try {
    impl_->store = c10::make_intrusive<c10d::FileStore>(options.store_path, options.world);
    const auto timeout = std::chrono::milliseconds(static_cast<int64_t>(options.timeout_s * 1000));
    impl_->store->setTimeout(timeout);
    auto gloo = c10d::ProcessGroupGloo::Options::create();
    gloo->timeout = timeout;
    gloo->devices.push_back(Device(options));
    impl_->group = c10::make_intrusive<c10d::ProcessGroupGloo>(
        impl_->store, options.rank, options.world, gloo);
  } catch (const std::exception& e) {
    GroupFailed(options, e);
  }
}

DataParallelGroup::~DataParallelGroup() = default;

void DataParallelGroup::SumDoubles(std::vector<double>* values) {
  if (!options_.Active() || values->empty()) return;
  torch::Tensor tensor = torch::from_blob(values->data(),
                                          {static_cast<int64_t>(values->size())},
                                          torch::TensorOptions().dtype(torch::kFloat64));
  Sum(impl_->group.get(), tensor, options_);
}

void DataParallelGroup::SumFloats(float* values, size_t count) {
  if (!options_.Active() || count == 0) return;
  Sum(impl_->group.get(),
      torch::from_blob(values, {static_cast<int64_t>(count)}, torch::kFloat32),
      options_);
}

std::string DataParallelGroup::Broadcast(const std::string& key, const std::string& value) {
  if (!options_.Active()) return value;
  const std::string stored = "furn/" + key;
  try {
    if (options_.rank == 0) {
      impl_->store->set(stored, std::vector<uint8_t>(value.begin(), value.end()));
      return value;
    }
    const std::vector<uint8_t> bytes = impl_->store->get(stored);
    return std::string(bytes.begin(), bytes.end());
  } catch (const std::exception& e) {
    GroupFailed(options_, e);
  }
}

}  // namespace furn

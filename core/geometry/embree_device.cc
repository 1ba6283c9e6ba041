#include "core/geometry/embree_device.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <stdexcept>

namespace furn {
namespace {

const char* EmbreeErrorName(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
    default:
      return "unknown error";
  }
}

// Embree silently ignores an ISA name it does not know (and runs on the CPU's
// best): a user forcing one must learn of a typo.
void CheckIsaNames(const std::string& config) {
  static const char* const kIsas[] = {
      "sse2", "sse4.2", "avx", "avx2", "avx512", "avx512knl", "avx512skx"};
  for (const char* key : {"isa=", "max_isa="}) {
    for (size_t at = config.find(key); at != std::string::npos; at = config.find(key, at + 1)) {
      if (at > 0 && config[at - 1] != ',' && config[at - 1] != ' ') continue;  // max_isa vs isa
      const size_t begin = at + std::strlen(key);
      const std::string name = config.substr(begin, config.find_first_of(", ", begin) - begin);
      if (std::find_if(std::begin(kIsas), std::end(kIsas), [&](const char* isa) {
            return name == isa;
          }) == std::end(kIsas)) {
        throw std::runtime_error(std::string(kEmbreeConfigVariable) + "='" + config + "': '" +
                                 name + "' is not an Embree ISA (sse2, sse4.2, avx, avx2, avx512)");
      }
    }
  }
}

RTCDevice NewDevice() {
  const std::string config = EmbreeDeviceConfig();
  CheckIsaNames(config);
  RTCDevice device = rtcNewDevice(config.empty() ? nullptr : config.c_str());
  if (device == nullptr) {
    const RTCError code = rtcGetDeviceError(nullptr);
    if (config.empty())
      throw std::runtime_error(std::string("Embree: cannot create a device (") +
                               EmbreeErrorName(code) + ")");
    throw std::runtime_error(std::string(kEmbreeConfigVariable) + "='" + config +
                             "': Embree refuses this device configuration (see rtcNewDevice; "
                             "e.g. isa=avx2 or threads=2)");
  }
  // Embree reports misuse through this callback, not through return values.
  rtcSetDeviceErrorFunction(
      device,
      [](void*, RTCError code, const char* message) {
        std::fprintf(stderr,
                     "Embree error: %s: %s\n",
                     EmbreeErrorName(code),
                     message != nullptr ? message : "");
      },
      nullptr);
  return device;
}

}  // namespace

std::string EmbreeDeviceConfig() {
  const char* config = std::getenv(kEmbreeConfigVariable);
  return config != nullptr ? config : "";
}

RTCDevice SharedEmbreeDevice() {
  static RTCDevice device = NewDevice();
  return device;
}

void RequireEmbreeDevice() { SharedEmbreeDevice(); }

unsigned AttachTriangles(const TriangleMesh& mesh,
                         const Eigen::Isometry3f& world_from_object,
                         RTCScene scene) {
  RTCGeometry geometry = rtcNewGeometry(SharedEmbreeDevice(), RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry,
                                                               RTC_BUFFER_TYPE_VERTEX,
                                                               0,
                                                               RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float),
                                                               mesh.vertices.size()));
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    Eigen::Map<Eigen::Vector3f>(vertices + 3 * i) = world_from_object * mesh.vertices[i];
  }
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry,
                                                                 RTC_BUFFER_TYPE_INDEX,
                                                                 0,
                                                                 RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned),
                                                                 mesh.triangles.size()));
  std::memcpy(indices, mesh.triangles.data(), mesh.triangles.size() * 3 * sizeof(unsigned));
  rtcCommitGeometry(geometry);
  const unsigned geometry_id = rtcAttachGeometry(scene, geometry);
  rtcReleaseGeometry(geometry);
  return geometry_id;
}

}  // namespace furn

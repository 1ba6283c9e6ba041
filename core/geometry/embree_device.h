// The process's one Intel Embree 3 device, shared by the depth renderer
// (renderers/embree_caster.h) and render-and-compare verification
// (core/geometry/render_compare.h). Devices are thread-safe, and creating one per user
// would cost more than the small scenes they serve.
//
//   RTCScene scene = rtcNewScene(SharedEmbreeDevice());
#pragma once

#include <embree3/rtcore.h>

#include <Eigen/Geometry>
#include <string>

#include "core/geometry/mesh.h"

namespace furn {

// The device's configuration string (rtcNewDevice) comes from this
// environment variable, e.g. FURN_EMBREE_CONFIG=isa=sse4.2 or isa=avx2 to force
// a narrower instruction set than the CPU's best (tests use it to exercise the
// code paths of other CPUs). Empty or unset: Embree's defaults.
constexpr const char* kEmbreeConfigVariable = "FURN_EMBREE_CONFIG";
std::string EmbreeDeviceConfig();

// The device, created at the first call. Throws std::runtime_error when
// Embree cannot create it (an unsupported CPU, or a bad FURN_EMBREE_CONFIG,
// including an ISA name Embree does not know).
RTCDevice SharedEmbreeDevice();

// Creates the device now if it does not exist yet (throws as above).
void RequireEmbreeDevice();

// Adds `mesh`, moved by `world_from_object`, to `scene` as one committed
// triangle geometry of the shared device; returns its geometry id.
unsigned AttachTriangles(const TriangleMesh& mesh,
                         const Eigen::Isometry3f& world_from_object,
                         RTCScene scene);

}  // namespace furn

#include "renderers/osmesa_renderer.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include <map>
#include <stdexcept>

#include "core/error.h"

namespace furn {
namespace {

// Near and far clip planes (m). Depth is written from the interpolated
// camera-space z, so these bound the visible range but do not limit precision;
// the 32-bit float depth buffer only orders surfaces.
constexpr float kNearM = 0.02f;
constexpr float kFarM = 200.0f;

constexpr char kVertexShader[] = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 camera_from_object;
uniform mat4 projection;
out vec3 point_in_camera;
void main() {
  vec4 p = camera_from_object * vec4(position, 1.0);
  point_in_camera = p.xyz;
  gl_Position = projection * p;
}
)";

// Normal from screen-space derivatives of the camera-space position: both lie
// in the triangle's plane (helper pixels extrapolate the same plane), so the
// cross product is the exact geometric normal. Octahedral encoding packs it in
// two floats.
constexpr char kFragmentShader[] = R"(#version 330 core
in vec3 point_in_camera;
uniform float instance_id;
layout(location = 0) out vec4 result;
vec2 OctahedralEncode(vec3 n) {
  n /= abs(n.x) + abs(n.y) + abs(n.z);
  vec2 e = n.xy;
  if (n.z < 0.0) {
    e = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
  }
  return e;
}
void main() {
  vec3 n = cross(dFdx(point_in_camera), dFdy(point_in_camera));
  float len = length(n);
  n = len > 1e-30 ? n / len : -normalize(point_in_camera);
  if (dot(n, point_in_camera) > 0.0) n = -n;
  result = vec4(point_in_camera.z, instance_id, OctahedralEncode(n));
}
)";

Eigen::Vector3f OctahedralDecode(float x, float y) {
  Eigen::Vector3f n(x, y, 1.0f - std::abs(x) - std::abs(y));
  if (n.z() < 0) {
    const float old_x = n.x();
    n.x() = (1.0f - std::abs(n.y())) * (old_x >= 0 ? 1.0f : -1.0f);
    n.y() = (1.0f - std::abs(old_x)) * (n.y() >= 0 ? 1.0f : -1.0f);
  }
  return n.normalized();
}

// OpenGL projection for a pinhole camera with optical axes (x right, y down, z
// forward). Window x = u + 0.5 and window y = v + 0.5, so glReadPixels returns
// image row v = 0 first and pixel centres sit where the intrinsics put them.
Eigen::Matrix4f ProjectionMatrix(const CameraIntrinsics& camera) {
  const float w = static_cast<float>(camera.width),
              h = static_cast<float>(camera.height);
  Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
  p(0, 0) = static_cast<float>(2 * camera.fx / w);
  p(0, 2) = static_cast<float>(2 * (camera.cx + 0.5) / w - 1);
  p(1, 1) = static_cast<float>(2 * camera.fy / h);
  p(1, 2) = static_cast<float>(2 * (camera.cy + 0.5) / h - 1);
  p(2, 2) = (kFarM + kNearM) / (kFarM - kNearM);
  p(2, 3) = -2 * kFarM * kNearM / (kFarM - kNearM);
  p(3, 2) = 1;
  return p;
}

GLuint CompileShader(GLenum type, const char* source) {
  const GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(shader, sizeof(log), nullptr, log);
    throw std::runtime_error(std::string("OSMesa: shader does not compile: ") +
                             log);
  }
  return shader;
}

struct GpuMesh {
  std::shared_ptr<const TriangleMesh> keep_alive;  // the cache key stays valid
  GLuint vertex_array = 0, vertex_buffer = 0, index_buffer = 0;
  GLsizei index_count = 0;
};

}  // namespace

struct OsMesaRenderer::Impl {
  OSMesaContext context = nullptr;
  unsigned char dummy_buffer[4 * 4 * 4] = {};
  GLuint program = 0;
  GLint camera_from_object_location = -1, projection_location = -1,
        instance_id_location = -1;
  GLuint framebuffer = 0, colour_buffer = 0, depth_buffer = 0;
  int target_width = 0, target_height = 0;
  std::map<const TriangleMesh*, GpuMesh> meshes;
  std::vector<float> pixels;

  void MakeCurrent() {
    if (!OSMesaMakeCurrent(context, dummy_buffer, GL_UNSIGNED_BYTE, 4, 4)) {
      throw std::runtime_error("OSMesa: cannot make the context current");
    }
  }

  void EnsureTarget(int width, int height) {
    if (width == target_width && height == target_height) return;
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
    Require(width <= max_size && height <= max_size,
            "image " + std::to_string(width) + "x" + std::to_string(height) +
                " exceeds OSMesa's largest render target " +
                std::to_string(max_size));
    if (framebuffer == 0) {
      glGenFramebuffers(1, &framebuffer);
      glGenRenderbuffers(1, &colour_buffer);
      glGenRenderbuffers(1, &depth_buffer);
    }
    glBindRenderbuffer(GL_RENDERBUFFER, colour_buffer);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA32F, width, height);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_buffer);
    glRenderbufferStorage(
        GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glFramebufferRenderbuffer(
        GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_buffer);
    glFramebufferRenderbuffer(
        GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_buffer);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw std::runtime_error("OSMesa: float render target is not supported");
    }
    target_width = width;
    target_height = height;
  }

  const GpuMesh& Upload(const std::shared_ptr<const TriangleMesh>& mesh) {
    auto it = meshes.find(mesh.get());
    if (it != meshes.end()) return it->second;
    if (meshes.size() > 4096) ReleaseMeshes();
    GpuMesh gpu;
    gpu.keep_alive = mesh;
    glGenVertexArrays(1, &gpu.vertex_array);
    glBindVertexArray(gpu.vertex_array);
    glGenBuffers(1, &gpu.vertex_buffer);
    glBindBuffer(GL_ARRAY_BUFFER, gpu.vertex_buffer);
    glBufferData(GL_ARRAY_BUFFER,
                 mesh->vertices.size() * sizeof(Eigen::Vector3f),
                 mesh->vertices.data(),
                 GL_STATIC_DRAW);
    glVertexAttribPointer(
        0, 3, GL_FLOAT, GL_FALSE, sizeof(Eigen::Vector3f), nullptr);
    glEnableVertexAttribArray(0);
    glGenBuffers(1, &gpu.index_buffer);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.index_buffer);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 mesh->triangles.size() * sizeof(Eigen::Vector3i),
                 mesh->triangles.data(),
                 GL_STATIC_DRAW);
    gpu.index_count = static_cast<GLsizei>(3 * mesh->triangles.size());
    glBindVertexArray(0);
    return meshes.emplace(mesh.get(), std::move(gpu)).first->second;
  }

  void ReleaseMeshes() {
    for (auto& [key, gpu] : meshes) {
      glDeleteBuffers(1, &gpu.vertex_buffer);
      glDeleteBuffers(1, &gpu.index_buffer);
      glDeleteVertexArrays(1, &gpu.vertex_array);
    }
    meshes.clear();
  }
};

OsMesaRenderer::OsMesaRenderer() : impl_(std::make_unique<Impl>()) {
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            0,
                            OSMESA_PROFILE,
                            OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            3,
                            0};
  impl_->context = OSMesaCreateContextAttribs(attributes, nullptr);
  if (impl_->context == nullptr) {
    throw std::runtime_error(
        "OSMesa: cannot create an OpenGL 3.3 core context");
  }
  impl_->MakeCurrent();
  const GLuint vertex = CompileShader(GL_VERTEX_SHADER, kVertexShader);
  const GLuint fragment = CompileShader(GL_FRAGMENT_SHADER, kFragmentShader);
  impl_->program = glCreateProgram();
  glAttachShader(impl_->program, vertex);
  glAttachShader(impl_->program, fragment);
  glLinkProgram(impl_->program);
  glDeleteShader(vertex);
  glDeleteShader(fragment);
  GLint linked = 0;
  glGetProgramiv(impl_->program, GL_LINK_STATUS, &linked);
  if (!linked) throw std::runtime_error("OSMesa: shader program does not link");
  impl_->camera_from_object_location =
      glGetUniformLocation(impl_->program, "camera_from_object");
  impl_->projection_location =
      glGetUniformLocation(impl_->program, "projection");
  impl_->instance_id_location =
      glGetUniformLocation(impl_->program, "instance_id");
}

OsMesaRenderer::~OsMesaRenderer() {
  if (impl_->context != nullptr) {
    impl_->MakeCurrent();
    impl_->ReleaseMeshes();
    glDeleteProgram(impl_->program);
    if (impl_->framebuffer != 0) {
      glDeleteFramebuffers(1, &impl_->framebuffer);
      glDeleteRenderbuffers(1, &impl_->colour_buffer);
      glDeleteRenderbuffers(1, &impl_->depth_buffer);
    }
    OSMesaDestroyContext(impl_->context);
  }
}

DepthFrame OsMesaRenderer::Render(const Scene& scene,
                                  const CameraIntrinsics& camera,
                                  const Eigen::Isometry3d& world_from_camera) {
  CheckRenderRequest(scene, camera, world_from_camera);
  impl_->MakeCurrent();
  impl_->EnsureTarget(camera.width, camera.height);
  glBindFramebuffer(GL_FRAMEBUFFER, impl_->framebuffer);
  glViewport(0, 0, camera.width, camera.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  glClearColor(0, 0, 0, 0);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glUseProgram(impl_->program);
  const Eigen::Matrix4f projection = ProjectionMatrix(camera);
  glUniformMatrix4fv(
      impl_->projection_location, 1, GL_FALSE, projection.data());
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  for (const SceneObject& object : scene.objects) {
    if (object.mesh->Empty()) continue;
    const GpuMesh& gpu = impl_->Upload(object.mesh);
    const Eigen::Matrix4f camera_from_object =
        (camera_from_world * object.world_from_object).matrix().cast<float>();
    glUniformMatrix4fv(impl_->camera_from_object_location,
                       1,
                       GL_FALSE,
                       camera_from_object.data());
    glUniform1f(impl_->instance_id_location,
                static_cast<float>(object.instance_id));
    glBindVertexArray(gpu.vertex_array);
    glDrawElements(GL_TRIANGLES, gpu.index_count, GL_UNSIGNED_INT, nullptr);
  }
  glBindVertexArray(0);
  const size_t count = static_cast<size_t>(camera.width) * camera.height;
  impl_->pixels.resize(4 * count);
  glReadPixels(0,
               0,
               camera.width,
               camera.height,
               GL_RGBA,
               GL_FLOAT,
               impl_->pixels.data());

  DepthFrame frame;
  frame.Resize(camera.width, camera.height);
  const float* pixel = impl_->pixels.data();
  for (size_t i = 0; i < count; ++i, pixel += 4) {
    if (pixel[0] <= 0) continue;
    frame.depth[i] = pixel[0];
    frame.instance_ids[i] = static_cast<uint16_t>(pixel[1] + 0.5f);
    frame.normals[i] = OctahedralDecode(pixel[2], pixel[3]);
  }
  return frame;
}

}  // namespace furn

#include "renderers/osmesa_renderer.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <stdexcept>

#include "core/util/error.h"
#include "core/util/parallel.h"

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
out float depth_in_camera;
void main() {
  vec4 p = camera_from_object * vec4(position, 1.0);
  depth_in_camera = p.z;
  gl_Position = projection * p;
}
)";

// The fragment writes only what interpolation must provide: the camera-space
// depth (perspective-correct, so exact on planes), and which triangle is seen.
// Ids and exact face normals are filled in on the CPU.
// Two 32-bit integers per pixel: the depth's float bits, and the scene-wide
// index of the triangle (first triangle of the object + gl_PrimitiveID).
constexpr char kFragmentShader[] = R"(#version 330 core
in float depth_in_camera;
uniform uint first_triangle;
layout(location = 0) out uvec2 result;
void main() {
  result = uvec2(floatBitsToUint(depth_in_camera), first_triangle + uint(gl_PrimitiveID));
}
)";

// OpenGL projection for a pinhole camera with optical axes (x right, y down, z
// forward). Window x = u + 0.5 and window y = v + 0.5, so glReadPixels returns
// image row v = 0 first and pixel centres sit where the intrinsics put them.
Eigen::Matrix4f ProjectionMatrix(const CameraIntrinsics& camera) {
  const float w = static_cast<float>(camera.width), h = static_cast<float>(camera.height);
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
    throw std::runtime_error(std::string("OSMesa: shader does not compile: ") + log);
  }
  return shader;
}

std::vector<Eigen::Vector3f> FaceNormals(const TriangleMesh& mesh) {
  std::vector<Eigen::Vector3f> normals(mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Eigen::Vector3i& t = mesh.triangles[i];
    const Eigen::Vector3f n = (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                                  .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    const float length = n.norm();
    normals[i] = length > 0 ? Eigen::Vector3f(n / length) : Eigen::Vector3f::Zero();
  }
  return normals;
}

struct GpuMesh {
  std::shared_ptr<const TriangleMesh> keep_alive;  // the cache key stays valid
  GLuint vertex_array = 0, vertex_buffer = 0, index_buffer = 0;
  GLsizei index_count = 0;
  std::vector<Eigen::Vector3f> face_normals;  // object frame, unit (zero if degenerate)
};

}  // namespace

struct OsMesaRenderer::Impl {
  OSMesaContext context = nullptr;
  unsigned char dummy_buffer[4 * 4 * 4] = {};
  GLuint program = 0;
  GLint camera_from_object_location = -1, projection_location = -1, first_triangle_location = -1;
  GLuint framebuffer = 0, colour_buffer = 0, depth_buffer = 0;
  int target_width = 0, target_height = 0;
  std::map<const TriangleMesh*, GpuMesh> meshes;
  MeshBoundsCache bounds_cache;
  std::vector<uint32_t> pixels;

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
                " exceeds OSMesa's largest render target " + std::to_string(max_size));
    if (framebuffer == 0) {
      glGenFramebuffers(1, &framebuffer);
      glGenRenderbuffers(1, &colour_buffer);
      glGenRenderbuffers(1, &depth_buffer);
    }
    glBindRenderbuffer(GL_RENDERBUFFER, colour_buffer);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RG32UI, width, height);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_buffer);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_buffer);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_buffer);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw std::runtime_error("OSMesa: RG32UI render target is not supported");
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
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Eigen::Vector3f), nullptr);
    glEnableVertexAttribArray(0);
    glGenBuffers(1, &gpu.index_buffer);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.index_buffer);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 mesh->triangles.size() * sizeof(Eigen::Vector3i),
                 mesh->triangles.data(),
                 GL_STATIC_DRAW);
    gpu.index_count = static_cast<GLsizei>(3 * mesh->triangles.size());
    gpu.face_normals = FaceNormals(*mesh);
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
    throw std::runtime_error("OSMesa: cannot create an OpenGL 3.3 core context");
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
  impl_->camera_from_object_location = glGetUniformLocation(impl_->program, "camera_from_object");
  impl_->projection_location = glGetUniformLocation(impl_->program, "projection");
  impl_->first_triangle_location = glGetUniformLocation(impl_->program, "first_triangle");
}

OsMesaRenderer::~OsMesaRenderer() {
  if (impl_->context == nullptr) return;
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

void OsMesaRenderer::RenderInto(const Scene& scene,
                                const CameraIntrinsics& camera,
                                const Eigen::Isometry3d& world_from_camera,
                                DepthFrame* out) {
  CheckRenderRequest(scene, camera, world_from_camera, &impl_->bounds_cache);
  impl_->MakeCurrent();
  impl_->EnsureTarget(camera.width, camera.height);
  glBindFramebuffer(GL_FRAMEBUFFER, impl_->framebuffer);
  glViewport(0, 0, camera.width, camera.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  const GLuint clear_value[4] = {0, 0, 0, 0};  // depth bits 0 = no return
  glClearBufferuiv(GL_COLOR, 0, clear_value);
  glClearDepth(1.0);
  glClear(GL_DEPTH_BUFFER_BIT);
  glUseProgram(impl_->program);
  const Eigen::Matrix4f projection = ProjectionMatrix(camera);
  glUniformMatrix4fv(impl_->projection_location, 1, GL_FALSE, projection.data());

  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  std::vector<const GpuMesh*> drawn(scene.objects.size(), nullptr);
  std::vector<uint32_t> first_triangle(scene.objects.size() + 1, 0);  // prefix sums
  std::vector<Eigen::Matrix3f> camera_from_object_rotation(scene.objects.size());
  for (size_t k = 0; k < scene.objects.size(); ++k) {
    const SceneObject& object = scene.objects[k];
    first_triangle[k + 1] = first_triangle[k] + static_cast<uint32_t>(object.mesh->NumTriangles());
    if (object.mesh->Empty()) continue;
    const GpuMesh& gpu = impl_->Upload(object.mesh);
    drawn[k] = &gpu;
    const Eigen::Isometry3d camera_from_object = camera_from_world * object.world_from_object;
    camera_from_object_rotation[k] = camera_from_object.linear().cast<float>();
    const Eigen::Matrix4f matrix = camera_from_object.matrix().cast<float>();
    glUniformMatrix4fv(impl_->camera_from_object_location, 1, GL_FALSE, matrix.data());
    glUniform1ui(impl_->first_triangle_location, first_triangle[k]);
    glBindVertexArray(gpu.vertex_array);
    glDrawElements(GL_TRIANGLES, gpu.index_count, GL_UNSIGNED_INT, nullptr);
  }
  glBindVertexArray(0);
  const size_t count = static_cast<size_t>(camera.width) * camera.height;
  impl_->pixels.resize(2 * count);
  glReadPixels(
      0, 0, camera.width, camera.height, GL_RG_INTEGER, GL_UNSIGNED_INT, impl_->pixels.data());

  DepthFrame& frame = *out;
  frame.Reshape(camera.width, camera.height);  // every pixel is written below
  if (!compute_normals()) frame.normals.clear();
  const bool normals = compute_normals();
  const uint32_t* pixels = impl_->pixels.data();
  std::vector<float> ray_x(camera.width), ray_y(camera.height);
  for (int u = 0; u < camera.width; ++u) ray_x[u] = camera.RayThroughPixel(u, 0).x();
  for (int v = 0; v < camera.height; ++v) ray_y[v] = camera.RayThroughPixel(0, v).y();
  ParallelFor(0, camera.height, [&](int v) {
    size_t object = 0;
    for (int u = 0; u < camera.width; ++u) {
      const size_t i = static_cast<size_t>(v) * camera.width + u;
      const uint32_t* pixel = pixels + 2 * i;
      float depth;
      std::memcpy(&depth, &pixel[0], sizeof(depth));
      if (!(depth > 0)) {
        frame.depth[i] = 0;
        frame.instance_ids[i] = kNoObjectId;
        if (normals) frame.normals[i].setZero();
        continue;
      }
      // The object whose triangle range holds the scene-wide triangle index:
      // usually the previous pixel's, else a binary search.
      if (pixel[1] < first_triangle[object] || pixel[1] >= first_triangle[object + 1]) {
        object = std::upper_bound(first_triangle.begin(), first_triangle.end(), pixel[1]) -
                 first_triangle.begin() - 1;
      }
      const size_t triangle = pixel[1] - first_triangle[object];
      frame.depth[i] = depth;
      frame.instance_ids[i] = scene.objects[object].instance_id;
      if (!normals) continue;
      Eigen::Vector3f normal =
          camera_from_object_rotation[object] * drawn[object]->face_normals[triangle];
      if (normal.dot(Eigen::Vector3f(ray_x[u], ray_y[v], 1.0f)) > 0) normal = -normal;
      frame.normals[i] = normal;
    }
  });
}

}  // namespace furn

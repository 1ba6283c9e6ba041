#include "scenes/mesh_io.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Exporter.hpp>
#include <assimp/IOStream.hpp>
#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "scenes/vtk_mesh.h"
#include "scenes/zip_archive.h"

namespace furn {
namespace {

constexpr unsigned kImportSteps = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                  aiProcess_PreTransformVertices | aiProcess_SortByPType;

// An assimp stream over bytes held in memory.
class MemoryStream : public Assimp::IOStream {
 public:
  explicit MemoryStream(std::string bytes) : bytes_(std::move(bytes)) {}
  size_t Read(void* buffer, size_t size, size_t count) override {
    if (size == 0) return 0;
    const size_t items = std::min(count, (bytes_.size() - position_) / size);
    std::memcpy(buffer, bytes_.data() + position_, items * size);
    position_ += items * size;
    return items;
  }
  size_t Write(const void*, size_t, size_t) override { return 0; }
  aiReturn Seek(size_t offset, aiOrigin origin) override {
    size_t target = offset;
    if (origin == aiOrigin_CUR) target = position_ + offset;
    if (origin == aiOrigin_END) target = bytes_.size() + offset;
    if (target > bytes_.size()) return aiReturn_FAILURE;
    position_ = target;
    return aiReturn_SUCCESS;
  }
  size_t Tell() const override { return position_; }
  size_t FileSize() const override { return bytes_.size(); }
  void Flush() override {}

 private:
  std::string bytes_;
  size_t position_ = 0;
};

}  // namespace

std::string SanitizeMtl(const std::string& bytes) {
  // assimp 5.2's MTL parser dereferences the current material for every
  // statement: one before the first newmtl crashes it. Such statements belong
  // to no material and mean nothing, so they are dropped.
  std::string out;
  out.reserve(bytes.size());
  bool in_material = false;
  size_t at = 0;
  while (at < bytes.size()) {
    size_t end = bytes.find('\n', at);
    if (end == std::string::npos) end = bytes.size();
    const std::string line = bytes.substr(at, end - at + (end < bytes.size() ? 1 : 0));
    const size_t first = line.find_first_not_of(" \t\r\n");
    const bool blank_or_comment = first == std::string::npos || line[first] == '#';
    if (!blank_or_comment && line.compare(first, 6, "newmtl") == 0) in_material = true;
    if (in_material || blank_or_comment) out += line;
    at = end + 1;
  }
  return out;
}

namespace {

// Faces of more vertices than this are refused: assimp triangulates a
// polygon in quadratic time (a 200,000-vertex face took 133 s).
constexpr size_t kMaxFaceVertices = 1024;

// Throws InputError naming `name` and the line of an OBJ face with more than
// kMaxFaceVertices vertices.
void CheckObjFaces(const std::string& name, const std::string& bytes) {
  size_t at = 0;
  int line = 1;
  while (at < bytes.size()) {
    size_t end = bytes.find('\n', at);
    if (end == std::string::npos) end = bytes.size();
    if (end - at > 2 && bytes[at] == 'f' && (bytes[at + 1] == ' ' || bytes[at + 1] == '\t')) {
      size_t vertices = 0;
      bool in_token = false;
      for (size_t i = at + 1; i < end; ++i) {
        const bool space = bytes[i] == ' ' || bytes[i] == '\t' || bytes[i] == '\r';
        vertices += !space && !in_token;
        in_token = !space;
      }
      Require(vertices <= kMaxFaceVertices,
              name + ":" + std::to_string(line) + ": a face of " + std::to_string(vertices) +
                  " vertices (at most " + std::to_string(kMaxFaceVertices) + ")");
    }
    at = end + 1;
    ++line;
  }
}

// Counts a mesh header declares must fit the file: assimp allocates them
// before reading a vertex (an OFF header of 10^7 faces in 50 bytes aborted
// it; an ASCII PLY of 10^7 faces took 830 MB).
constexpr uint64_t kMaxMeshElements = uint64_t{1} << 26;

void RequireCountsFit(const std::string& name,
                      const char* what,
                      uint64_t count,
                      uint64_t min_bytes_each,
                      uint64_t bytes_left) {
  Require(count <= kMaxMeshElements,
          name + ": declares " + std::to_string(count) + " " + what + " (at most 2^26)");
  Require(count * min_bytes_each <= bytes_left,
          name + ": declares " + std::to_string(count) + " " + what + ", more than its " +
              std::to_string(bytes_left) + " bytes can hold");
}

// The whitespace-separated words of the lines from `at`, comments (#) skipped,
// until `count` words are found; `at` moves past the line of the last one.
std::vector<std::string> NextWords(const std::string& bytes, size_t* at, size_t count) {
  std::vector<std::string> words;
  while (*at < bytes.size() && words.size() < count) {
    size_t end = bytes.find('\n', *at);
    if (end == std::string::npos) end = bytes.size();
    std::istringstream line(bytes.substr(*at, std::min<size_t>(end - *at, 4096)));
    *at = end + 1;
    for (std::string word; line >> word && word[0] != '#';) words.push_back(word);
  }
  return words;
}

std::optional<uint64_t> WholeNumber(const std::string& word) {
  if (word.empty() || word.size() > 12 || word.find_first_not_of("0123456789") != std::string::npos)
    return std::nullopt;
  return std::stoull(word);
}

// OFF: "OFF" (or COFF, NOFF, ...) then vertex, face and edge counts; ASCII
// vertices take at least 6 bytes, faces 8; binary ones 12 and 16.
void CheckOffCounts(const std::string& name, const std::string& bytes) {
  size_t at = 0;
  std::vector<std::string> words = NextWords(bytes, &at, 1);
  Require(!words.empty() && words[0].size() >= 3 &&
              words[0].compare(words[0].size() - 3, 3, "OFF") == 0,
          name + ": not an OFF file (no OFF line)");
  const bool binary = words.size() > 1 && words[1] == "BINARY";
  words.erase(words.begin(), words.begin() + (binary ? 2 : 1));
  if (words.size() < 3) {
    const std::vector<std::string> more = NextWords(bytes, &at, 3 - words.size());
    words.insert(words.end(), more.begin(), more.end());
  }
  Require(words.size() >= 3, name + ": its OFF header lacks the vertex, face and edge counts");
  const std::optional<uint64_t> vertices = WholeNumber(words[0]), faces = WholeNumber(words[1]);
  Require(vertices && faces, name + ": OFF counts must be whole numbers");
  const uint64_t left = at <= bytes.size() ? bytes.size() - at : 0;
  RequireCountsFit(name, "vertices", *vertices, binary ? 12 : 6, left);
  RequireCountsFit(name, "faces", *faces, binary ? 16 : 8, left - *vertices * (binary ? 12 : 6));
}

// PLY meshes: every element's count against the body (ASCII: 2 bytes per
// property and row at least; binary: each property's size, lists their
// count's).
void CheckPlyMeshCounts(const std::string& name, const std::string& bytes) {
  const size_t end = bytes.find("end_header");
  Require(bytes.compare(0, 3, "ply") == 0 && end != std::string::npos && end < 65536,
          name + ": not a PLY file (no 'ply' line or no end_header)");
  static const std::map<std::string, uint64_t> kSizes = {{"char", 1},
                                                         {"uchar", 1},
                                                         {"int8", 1},
                                                         {"uint8", 1},
                                                         {"short", 2},
                                                         {"ushort", 2},
                                                         {"int16", 2},
                                                         {"uint16", 2},
                                                         {"int", 4},
                                                         {"uint", 4},
                                                         {"int32", 4},
                                                         {"uint32", 4},
                                                         {"float", 4},
                                                         {"float32", 4},
                                                         {"double", 8},
                                                         {"float64", 8}};
  std::istringstream header(bytes.substr(0, end));
  bool ascii = false;
  std::vector<std::pair<uint64_t, uint64_t>> elements;  // count, min bytes per row
  for (std::string line; std::getline(header, line);) {
    std::istringstream words(line);
    std::string keyword, a, b, c;
    words >> keyword >> a >> b >> c;
    if (keyword == "format") ascii = a == "ascii";
    if (keyword == "element") {
      const std::optional<uint64_t> count = WholeNumber(b);
      Require(count.has_value(), name + ": PLY element " + a + " has no whole-number count");
      elements.push_back({*count, 0});
    }
    if (keyword == "property" && !elements.empty()) {
      const std::string& type = a == "list" ? b : a;
      const auto size = kSizes.find(type);
      Require(size != kSizes.end(), name + ": PLY property type '" + type + "' is unknown");
      elements.back().second += ascii ? 2 : size->second;
    }
  }
  uint64_t left = bytes.size() - end;
  for (const auto& [count, row] : elements) {
    RequireCountsFit(name, "PLY rows", count, std::max<uint64_t>(row, 1), left);
    left -= count * std::max<uint64_t>(row, 1);
  }
}

// Binary STL: an 80-byte header, a triangle count, 50 bytes per triangle.
void CheckStlCounts(const std::string& name, const std::string& bytes) {
  if (bytes.compare(0, 5, "solid") == 0 && bytes.find("facet", 0) != std::string::npos) return;
  Require(bytes.size() >= 84, name + ": not an STL file (shorter than a binary STL header)");
  uint32_t triangles = 0;
  std::memcpy(&triangles, bytes.data() + 80, 4);
  RequireCountsFit(name, "triangles", triangles, 50, bytes.size() - 84);
}

// The bytes assimp gets for a file: MTL files sanitised (SanitizeMtl), OBJ
// faces checked (CheckObjFaces), the counts of OFF, PLY and STL headers
// against the file.
std::string ForAssimp(const std::string& name, std::string bytes) {
  const std::string extension = FileExtension(name);
  if (extension == "obj") CheckObjFaces(name, bytes);
  if (extension == "off") CheckOffCounts(name, bytes);
  if (extension == "ply") CheckPlyMeshCounts(name, bytes);
  if (extension == "stl") CheckStlCounts(name, bytes);
  return extension == "mtl" ? SanitizeMtl(bytes) : bytes;
}

// An assimp IO system that serves whole files through ForAssimp and keeps
// the first reason a file could not be served (assimp swallows exceptions).
class CheckingIoSystem : public Assimp::IOSystem {
 public:
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char* path, const char* mode) override {
    if (mode != nullptr && std::strchr(mode, 'w') != nullptr) return nullptr;
    const std::string name = Name(path);
    if (!Exists(path)) return nullptr;
    try {
      return new MemoryStream(ForAssimp(name, ReadWhole(name)));
    } catch (const InputError& error) {
      if (first_error_.empty()) first_error_ = error.what();
      return nullptr;
    }
  }
  void Close(Assimp::IOStream* stream) override { delete stream; }
  const std::string& first_error() const { return first_error_; }

 protected:
  virtual std::string Name(const std::string& path) const { return path; }
  virtual std::string ReadWhole(const std::string& name) const = 0;

 private:
  std::string first_error_;
};

// Files from disk.
class DiskIoSystem : public CheckingIoSystem {
 public:
  bool Exists(const char* path) const override {
    std::error_code ec;
    return std::filesystem::is_regular_file(path, ec);
  }

 protected:
  std::string ReadWhole(const std::string& name) const override { return ReadFileBytes(name); }
};

// Lets assimp open the model and its MTL (or other side files) inside a zip.
class ZipIoSystem : public CheckingIoSystem {
 public:
  explicit ZipIoSystem(const ZipArchive& archive) : archive_(archive) {}
  bool Exists(const char* path) const override { return archive_.Contains(Name(path)); }

 protected:
  // Zip entry names have no leading '/', and OBJ files may say "./x.mtl".
  std::string Name(const std::string& path) const override {
    std::string p = std::filesystem::path(path).lexically_normal().generic_string();
    while (!p.empty() && p[0] == '/') p.erase(0, 1);
    return p;
  }
  std::string ReadWhole(const std::string& name) const override { return archive_.Read(name); }

 private:
  const ZipArchive& archive_;
};

TriangleMesh CollectTriangles(const aiScene& scene) {
  TriangleMesh mesh;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& part = *scene.mMeshes[m];
    if (!(part.mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const int offset = static_cast<int>(mesh.vertices.size());
    for (unsigned v = 0; v < part.mNumVertices; ++v) {
      const aiVector3D& p = part.mVertices[v];
      mesh.vertices.emplace_back(p.x, p.y, p.z);
    }
    for (unsigned f = 0; f < part.mNumFaces; ++f) {
      const aiFace& face = part.mFaces[f];
      if (face.mNumIndices != 3) continue;
      mesh.triangles.emplace_back(offset + static_cast<int>(face.mIndices[0]),
                                  offset + static_cast<int>(face.mIndices[1]),
                                  offset + static_cast<int>(face.mIndices[2]));
    }
  }
  return mesh;
}

// Imports with `importer` (whose IO handler is already set) and checks faces.
TriangleMesh ImportTriangles(Assimp::Importer* importer,
                             const std::string& path_in_io,
                             const std::string& where) {
  importer->SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                               aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = importer->ReadFile(path_in_io, kImportSteps);
  if (scene == nullptr) {
    const std::string reason = importer->GetErrorString();
    // assimp reports a file with vertices but no faces as having no meshes.
    if (reason.find("meshes") != std::string::npos || reason.find("faces") != std::string::npos) {
      throw InputError(where + ": mesh has no faces (a model needs at least one triangle)");
    }
    throw InputError(where + ": cannot import (" + reason + ")");
  }
  TriangleMesh mesh = CollectTriangles(*scene);
  CheckMeshValid(mesh, where);
  return mesh;
}

bool IsYUpByDefault(const std::string& extension) {
  static const std::set<std::string> kYUp = {"obj", "gltf", "glb", "dae", "fbx", "3ds"};
  return kYUp.count(extension) > 0;
}

}  // namespace

bool LoadsYUpByDefault(const std::string& extension) { return IsYUpByDefault(extension); }

void CheckFurnitureExtent(const TriangleMesh& mesh, const std::string& what) {
  const Eigen::Vector3f size = BoundingBox(mesh).Size();
  char text[160];
  std::snprintf(text,
                sizeof(text),
                ": the mesh spans %g x %g x %g m; a model must be finite, at most 1 km, and span "
                "two axes (its units?)",
                size.x(),
                size.y(),
                size.z());
  int spanned = 0;
  for (int axis = 0; axis < 3; ++axis) spanned += size[axis] > 1e-7f;
  Require(size.allFinite() && (size.array() <= 1000.f).all() && spanned >= 2, what + text);
}

bool MeshLoadOptions::Check() const {
  if (!(metres_per_unit > 0 && std::isfinite(metres_per_unit))) return false;
  if (size_m && !(size_m->allFinite() && (size_m->array() > 0).all())) return false;
  return !engine_from_file ||
         (engine_from_file->allFinite() &&
          (*engine_from_file * engine_from_file->transpose() - Eigen::Matrix3f::Identity()).norm() <
              1e-4f);
}

Eigen::Vector3f ParseAxis(const std::string& text, const std::string& what) {
  std::string axis = text;
  float sign = 1;
  if (!axis.empty() && (axis[0] == '+' || axis[0] == '-')) {
    sign = axis[0] == '-' ? -1.f : 1.f;
    axis.erase(0, 1);
  }
  const std::string letters = "xyz";
  const size_t index = axis.size() == 1 ? letters.find(axis[0]) : std::string::npos;
  Require(index != std::string::npos,
          what + " '" + text + "' is not an axis (x, y, z with an optional + or -)");
  return sign * Eigen::Vector3f::Unit(static_cast<Eigen::Index>(index));
}

Eigen::Matrix3f AxesFromUpAndFront(const Eigen::Vector3f& up,
                                   const Eigen::Vector3f& front,
                                   const std::string& what) {
  Require(std::abs(up.dot(front)) < 1e-6f,
          what + ": the front must be perpendicular to the up axis");
  // Rows are the engine's axes in file coordinates: x = y cross z.
  const Eigen::Vector3f z = up.normalized(), y = -front.normalized();
  Eigen::Matrix3f engine_from_file;
  engine_from_file.row(0) = y.cross(z).transpose();
  engine_from_file.row(1) = y.transpose();
  engine_from_file.row(2) = z.transpose();
  return engine_from_file;
}

Eigen::Vector3f DefaultFront(const Eigen::Vector3f& up) {
  for (const Eigen::Vector3f& front :
       {Eigen::Vector3f(0, -1, 0), Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(-1, 0, 0)}) {
    if (std::abs(front.dot(up)) < 1e-6f) return front;
  }
  return Eigen::Vector3f(0, -1, 0);  // not reached for a unit axis
}

double ParseUnits(const std::string& text, const std::string& what) {
  static const std::pair<const char*, double> kNamed[] = {
      {"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}, {"ft", 0.3048}};
  for (const auto& [name, metres] : kNamed) {
    if (text == name) return metres;
  }
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  Require(!text.empty() && end == text.c_str() + text.size() && std::isfinite(value) && value > 0,
          what + " '" + text +
              "' is not a unit (m, cm, mm, in, ft, or metres per unit as a "
              "positive number)");
  return value;
}

Eigen::Matrix3f ZUpFromYUp() {
  Eigen::Matrix3f rotation;
  rotation << 1, 0, 0,  //
      0, 0, -1,         //
      0, 1, 0;
  return rotation;
}

std::vector<std::string> SupportedImportExtensions() {
  Assimp::Importer importer;
  std::string list;  // "*.3ds;*.obj;..."
  importer.GetExtensionList(list);
  std::vector<std::string> extensions;
  std::stringstream stream(list);
  std::string item;
  while (std::getline(stream, item, ';')) {
    if (item.rfind("*.", 0) == 0) extensions.push_back(item.substr(2));
  }
  std::sort(extensions.begin(), extensions.end());
  return extensions;
}

CadModel LoadMeshFile(const std::string& path, const MeshLoadOptions& options) {
  Require(options.Check(),
          path +
              ": load options: metres per unit must be a finite number > 0, a size three "
              "positive lengths, the axes a rotation");
  RequireRegularFile(path);
  std::error_code ec;
  Require(std::filesystem::is_regular_file(path, ec), path + ": file does not exist");
  const std::string extension = FileExtension(path);
  TriangleMesh mesh;
  if (extension == "vtk") {
    mesh = ReadVtkPolyData(path);
  } else {
    Assimp::Importer importer;
    if (extension.empty() || !importer.IsExtensionSupported("." + extension)) {
      throw InputError(path + ": unknown format '" + extension +
                       "' (supported: obj, ply, stl, off, gltf, glb, dae, 3ds, fbx, vtk and "
                       "other assimp formats)");
    }
    auto* io = new DiskIoSystem;
    importer.SetIOHandler(io);  // the importer owns it
    try {
      mesh = ImportTriangles(&importer, path, path);
    } catch (const InputError&) {
      if (!io->first_error().empty()) throw InputError(io->first_error());
      throw;
    }
  }
  const bool y_up = options.up_axis == UpAxis::kY ||
                    (options.up_axis == UpAxis::kFormatDefault && IsYUpByDefault(extension));
  const Eigen::Matrix3f axes = options.engine_from_file ? *options.engine_from_file
                               : y_up                   ? ZUpFromYUp()
                                                        : Eigen::Matrix3f::Identity();
  TransformMesh(static_cast<float>(options.metres_per_unit) * axes, Eigen::Vector3f::Zero(), &mesh);
  CheckFurnitureExtent(mesh, path);
  if (options.size_m) {
    const Eigen::Vector3f size = BoundingBox(mesh).Size();
    Require((size.array() > 0).all(),
            path + ": the mesh is flat along an axis and cannot be scaled to a size");
    TransformMesh(options.size_m->cwiseQuotient(size).asDiagonal().toDenseMatrix(),
                  Eigen::Vector3f::Zero(),
                  &mesh);
  }
  PlaceOnFloorCentred(&mesh);
  CadModel model;
  model.id = std::filesystem::path(path).stem().string();
  model.name = model.id;
  model.source_path = path;
  model.content_hash = HashMesh(mesh);
  model.mesh = std::move(mesh);
  return model;
}

TriangleMesh ImportMeshFromZip(const ZipArchive& archive, const std::string& entry) {
  const std::string where = archive.path() + "!/" + entry;
  Require(archive.Contains(entry), where + ": no such entry in the archive");
  Assimp::Importer importer;
  auto* io = new ZipIoSystem(archive);
  importer.SetIOHandler(io);  // the importer owns it
  try {
    return ImportTriangles(&importer, entry, where);
  } catch (const InputError&) {
    if (!io->first_error().empty()) throw InputError(io->first_error());
    throw;
  }
}

void ExportMesh(const TriangleMesh& mesh, const std::string& path) {
  CheckMeshValid(mesh, path);
  const std::string extension = FileExtension(path);
  std::string format_id;
  if (extension == "ply") format_id = "plyb";
  if (extension == "obj") format_id = "objnomtl";
  if (extension == "stl") format_id = "stlb";
  if (extension == "glb") format_id = "glb2";
  Require(!format_id.empty(),
          path + ": cannot export format '" + extension + "' (allowed: ply, obj, stl, glb)");
  const Eigen::Matrix3f file_from_world = IsYUpByDefault(extension)
                                              ? Eigen::Matrix3f(ZUpFromYUp().transpose())
                                              : Eigen::Matrix3f::Identity();

  // aiScene's destructor frees everything allocated below.
  aiScene scene;
  scene.mRootNode = new aiNode();
  scene.mRootNode->mNumMeshes = 1;
  scene.mRootNode->mMeshes = new unsigned[1]{0};
  scene.mNumMaterials = 1;
  scene.mMaterials = new aiMaterial* [1] { new aiMaterial() };
  scene.mNumMeshes = 1;
  scene.mMeshes = new aiMesh* [1] { new aiMesh() };
  aiMesh& out = *scene.mMeshes[0];
  out.mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  out.mMaterialIndex = 0;
  out.mNumVertices = static_cast<unsigned>(mesh.vertices.size());
  out.mVertices = new aiVector3D[out.mNumVertices];
  for (unsigned v = 0; v < out.mNumVertices; ++v) {
    const Eigen::Vector3f p = file_from_world * mesh.vertices[v];
    out.mVertices[v] = aiVector3D(p.x(), p.y(), p.z());
  }
  out.mNumFaces = static_cast<unsigned>(mesh.triangles.size());
  out.mFaces = new aiFace[out.mNumFaces];
  for (unsigned f = 0; f < out.mNumFaces; ++f) {
    out.mFaces[f].mNumIndices = 3;
    out.mFaces[f].mIndices = new unsigned[3];
    for (int k = 0; k < 3; ++k) {
      out.mFaces[f].mIndices[k] = static_cast<unsigned>(mesh.triangles[f][k]);
    }
  }

  AtomicFile file(path);
  Assimp::Exporter exporter;
  if (exporter.Export(&scene, format_id, file.TempPath()) != aiReturn_SUCCESS) {
    throw InputError(path + ": cannot write (" + exporter.GetErrorString() + ")");
  }
  file.Commit();
}

}  // namespace furn

#include "tests/scenes/fixtures.h"

#include <gtest/gtest.h>
#include <zip.h>

#include <cstring>
#include <sstream>
#include <vector>

namespace furn::testing {

TriangleMesh MarkerMesh() {
  TriangleMesh mesh = MakeBox({0, 0, 0}, {0.4f, 0.6f, 0.5f});
  AppendMesh(MakeBox({0.3f, 0.5f, 0.5f}, {0.4f, 0.6f, 1.0f}), &mesh);
  return mesh;
}

void ExpectMarkerPose(const TriangleMesh& mesh, const Eigen::Vector3f& size, float tolerance) {
  const Box3 box = BoundingBox(mesh);
  EXPECT_NEAR(box.Size().x(), size.x(), tolerance);
  EXPECT_NEAR(box.Size().y(), size.y(), tolerance);
  EXPECT_NEAR(box.Size().z(), size.z(), tolerance);
  EXPECT_NEAR(box.min.z(), 0, tolerance);
  EXPECT_NEAR(box.Center().x(), 0, tolerance);
  EXPECT_NEAR(box.Center().y(), 0, tolerance);
  Eigen::Vector3f top = mesh.vertices[0];
  for (const Eigen::Vector3f& p : mesh.vertices) {
    if (p.z() > top.z()) top = p;
  }
  EXPECT_GT(top.x(), 0) << "post should stand at +x";
  EXPECT_GT(top.y(), 0) << "post should stand at +y";
}

Eigen::Matrix3f YUpFromZUp() {
  Eigen::Matrix3f m;
  m << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return m;
}

std::string ObjText(const TriangleMesh& mesh,
                    const Eigen::Matrix3f& file_from_engine,
                    const std::string& mtllib) {
  std::ostringstream out;
  if (!mtllib.empty()) out << "mtllib " << mtllib << "\nusemtl wood\n";
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const Eigen::Vector3f p = file_from_engine * v;
    out << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out << "f " << t[0] + 1 << " " << t[1] + 1 << " " << t[2] + 1 << "\n";
  }
  return out.str();
}

std::string PlyAsciiText(const TriangleMesh& mesh) {
  std::ostringstream out;
  out << "ply\nformat ascii 1.0\nelement vertex " << mesh.vertices.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
      << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Eigen::Vector3f& v : mesh.vertices)
    out << v.x() << " " << v.y() << " " << v.z() << "\n";
  for (const Eigen::Vector3i& t : mesh.triangles)
    out << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
  return out.str();
}

std::string StlAsciiText(const TriangleMesh& mesh) {
  std::ostringstream out;
  out << "solid marker\n";
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out << " facet normal 0 0 0\n  outer loop\n";
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& v = mesh.vertices[t[k]];
      out << "   vertex " << v.x() << " " << v.y() << " " << v.z() << "\n";
    }
    out << "  endloop\n endfacet\n";
  }
  out << "endsolid marker\n";
  return out.str();
}

std::string OffText(const TriangleMesh& mesh) {
  std::ostringstream out;
  out << "OFF\n" << mesh.vertices.size() << " " << mesh.triangles.size() << " 0\n";
  for (const Eigen::Vector3f& v : mesh.vertices)
    out << v.x() << " " << v.y() << " " << v.z() << "\n";
  for (const Eigen::Vector3i& t : mesh.triangles)
    out << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
  return out.str();
}

namespace {

std::string Base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n =
        (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out.push_back(kAlphabet[(n >> s) & 63]);
  }
  if (i < bytes.size()) {
    uint32_t n = uint8_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= uint8_t(bytes[i + 1]) << 8;
    out.push_back(kAlphabet[(n >> 18) & 63]);
    out.push_back(kAlphabet[(n >> 12) & 63]);
    out.push_back(i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

}  // namespace

std::string GltfEmbeddedText(const TriangleMesh& mesh) {
  std::string buffer;
  Eigen::Vector3f low(1e9f, 1e9f, 1e9f), high(-1e9f, -1e9f, -1e9f);
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const Eigen::Vector3f p = YUpFromZUp() * v;
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
    buffer.append(reinterpret_cast<const char*>(p.data()), 12);
  }
  const size_t index_offset = buffer.size();
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t index = static_cast<uint32_t>(t[k]);
      buffer.append(reinterpret_cast<const char*>(&index), 4);
    }
  }
  std::ostringstream out;
  out << R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
      << R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":4}]}],)"
      << R"("buffers":[{"byteLength":)" << buffer.size()
      << R"(,"uri":"data:application/octet-stream;base64,)" << Base64(buffer) << R"("}],)"
      << R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)" << index_offset
      << R"(,"target":34962},{"buffer":0,"byteOffset":)" << index_offset << R"(,"byteLength":)"
      << buffer.size() - index_offset << R"(,"target":34963}],)"
      << R"("accessors":[{"bufferView":0,"componentType":5126,"count":)" << mesh.vertices.size()
      << R"(,"type":"VEC3","min":[)" << low.x() << "," << low.y() << "," << low.z()
      << R"(],"max":[)" << high.x() << "," << high.y() << "," << high.z() << R"(]},)"
      << R"({"bufferView":1,"componentType":5125,"count":)" << 3 * mesh.triangles.size()
      << R"(,"type":"SCALAR"}]})";
  return out.str();
}

std::string ColladaZUpText(const TriangleMesh& mesh) {
  std::ostringstream positions, indices;
  for (const Eigen::Vector3f& v : mesh.vertices)
    positions << v.x() << " " << v.y() << " " << v.z() << " ";
  for (const Eigen::Vector3i& t : mesh.triangles)
    indices << t[0] << " " << t[1] << " " << t[2] << " ";
  std::ostringstream out;
  out << R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
 <asset><unit name="meter" meter="1"/><up_axis>Z_UP</up_axis></asset>
 <library_geometries><geometry id="m" name="m"><mesh>
  <source id="m-pos"><float_array id="m-pos-array" count=")"
      << 3 * mesh.vertices.size() << R"(">)" << positions.str() << R"(</float_array>
   <technique_common><accessor source="#m-pos-array" count=")"
      << mesh.vertices.size() << R"(" stride="3">
    <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
   </accessor></technique_common></source>
  <vertices id="m-vtx"><input semantic="POSITION" source="#m-pos"/></vertices>
  <triangles count=")"
      << mesh.triangles.size() << R"("><input semantic="VERTEX" source="#m-vtx" offset="0"/><p>)"
      << indices.str() << R"(</p></triangles>
 </mesh></geometry></library_geometries>
 <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#m"/></node></visual_scene></library_visual_scenes>
 <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";
  return out.str();
}

void WriteZip(const std::string& path,
              const std::map<std::string, std::string>& files,
              const std::set<std::string>& stored) {
  int error = 0;
  zip_t* zip = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &error);
  ASSERT_NE(zip, nullptr) << "cannot create " << path;
  for (const auto& [name, bytes] : files) {
    zip_source_t* source = zip_source_buffer(zip, bytes.data(), bytes.size(), 0);
    ASSERT_NE(source, nullptr);
    const zip_int64_t index = zip_file_add(zip, name.c_str(), source, ZIP_FL_OVERWRITE);
    ASSERT_GE(index, 0) << zip_strerror(zip);
    if (stored.count(name)) zip_set_file_compression(zip, index, ZIP_CM_STORE, 0);
  }
  ASSERT_EQ(zip_close(zip), 0) << "cannot write " << path;
}

}  // namespace furn::testing

namespace furn::testing {

std::string WriteTestSh3f(const std::string& dir, const std::string& file_name) {
  const std::string stem = file_name.substr(0, file_name.rfind('.'));
  // ISO-8859-1 bytes (0xA9 = copyright sign) as in Debian's catalogs.
  const std::string properties =
      "# Test catalog \xA9 furnidet\n"
      "id=Test#Catalog\n"
      "name=Test catalog\n\n"
      "id#1=" +
      stem +
      "#marker\n"
      "name#1=Chaise \\u00e9l\\u00e9gante\n"
      "category#1=Living room\n"
      "model#1=/marker/marker.obj\n"
      "width#1=40\n"
      "depth#1 = 60\n"
      "height#1:100\n"
      "elevation#1=0\n"
      "creator#1=Tests\n\n"
      "id#2=" +
      stem +
      "#rotated\n"
      "name#2=Rotated \\\n"
      "    marker\n"
      "model#2=/rotated/rotated.obj\n"
      "modelRotation#2=1 0 0 0 0 1 0 -1 0\n"
      "width#2=80\ndepth#2=120\nheight#2=200\n\n"
      "id#3=" +
      stem +
      "#missing\n"
      "name#3=Missing\n"
      "model#3=/missing/missing.obj\n"
      "width#3=10\ndepth#3=10\nheight#3=10\n\n"
      "id#4=" +
      stem +
      "#badwidth\n"
      "model#4=/marker/marker.obj\n"
      "width#4=abc\ndepth#4=10\nheight#4=10\n";
  const std::string path = dir + "/" + file_name;
  WriteZip(path,
           {{"PluginFurnitureCatalog.properties", properties},
            {"marker/marker.obj", ObjText(MarkerMesh(), 37.0f * YUpFromZUp(), "marker.mtl")},
            {"marker/marker.mtl", "newmtl wood\nKd 0.6 0.4 0.2\n"},
            {"rotated/rotated.obj", ObjText(MarkerMesh(), 50.0f * Eigen::Matrix3f::Identity())}},
           {"marker/marker.obj"});
  return path;
}

}  // namespace furn::testing

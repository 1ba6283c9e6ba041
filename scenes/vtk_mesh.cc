#include "scenes/vtk_mesh.h"

#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/vtk_lib_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <fstream>

#include "core/error.h"
#include "core/file_util.h"

namespace furn {

TriangleMesh ReadVtkPolyData(const std::string& path) {
  RequireRegularFile(path);
  // Only legacy polydata goes to VTK: its header says so in the first lines.
  std::string head(1024, '\0');
  {
    std::ifstream in(path, std::ios::binary);
    Require(in.good(), path + ": cannot read");
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<size_t>(in.gcount()));
  }
  Require(head.rfind("# vtk DataFile", 0) == 0,
          path + ": not a VTK legacy file (it must start with \"# vtk DataFile\")");
  Require(head.find("POLYDATA") != std::string::npos,
          path + ": not VTK polydata (DATASET POLYDATA is needed for a mesh)");
  pcl::PolygonMesh polygons;
  Require(pcl::io::loadPolygonFileVTK(path, polygons) > 0 && !polygons.polygons.empty(),
          path + ": mesh has no faces (a model needs at least one triangle)");
  pcl::PointCloud<pcl::PointXYZ> points;
  pcl::fromPCLPointCloud2(polygons.cloud, points);
  TriangleMesh mesh;
  mesh.vertices.reserve(points.size());
  for (const pcl::PointXYZ& p : points) {
    Require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z),
            path + ": a point is not a finite number");
    mesh.vertices.emplace_back(p.x, p.y, p.z);
  }
  const auto count = static_cast<int64_t>(mesh.vertices.size());
  for (const pcl::Vertices& polygon : polygons.polygons) {
    const auto& corners = polygon.vertices;
    for (const auto corner : corners)
      Require(corner >= 0 && static_cast<int64_t>(corner) < count,
              path + ": a polygon names a point that does not exist");
    for (size_t k = 2; k < corners.size(); ++k) {  // a fan over the polygon
      mesh.triangles.emplace_back(static_cast<int>(corners[0]),
                                  static_cast<int>(corners[k - 1]),
                                  static_cast<int>(corners[k]));
    }
  }
  Require(!mesh.triangles.empty(),
          path + ": mesh has no faces (a model needs at least one triangle)");
  return mesh;
}

}  // namespace furn

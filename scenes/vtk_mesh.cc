#include "scenes/vtk_mesh.h"

#include <vtkCellArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkTriangleFilter.h>

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
  // VTK's own reader (PCL's loadPolygonFileVTK keeps polygons only and
  // drops triangle strips, which the paper's models are made of); the
  // triangle filter turns polygons and strips into triangles.
  vtkNew<vtkPolyDataReader> reader;
  reader->SetFileName(path.c_str());
  reader->ReadAllScalarsOff();
  reader->ReadAllVectorsOff();
  vtkNew<vtkTriangleFilter> triangles;
  triangles->SetInputConnection(reader->GetOutputPort());
  triangles->PassLinesOff();
  triangles->PassVertsOff();
  triangles->Update();
  vtkPolyData* data = triangles->GetOutput();
  Require(data != nullptr && data->GetPoints() != nullptr && data->GetNumberOfPolys() > 0,
          path + ": mesh has no faces (a model needs at least one triangle)");
  TriangleMesh mesh;
  const vtkIdType count = data->GetNumberOfPoints();
  mesh.vertices.reserve(static_cast<size_t>(count));
  for (vtkIdType i = 0; i < count; ++i) {
    double p[3];
    data->GetPoint(i, p);
    Require(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]),
            path + ": a point is not a finite number");
    mesh.vertices.emplace_back(
        static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2]));
  }
  vtkCellArray* polys = data->GetPolys();
  vtkNew<vtkIdList> corners;
  for (polys->InitTraversal(); polys->GetNextCell(corners);) {
    if (corners->GetNumberOfIds() != 3) continue;
    for (vtkIdType k = 0; k < 3; ++k)
      Require(corners->GetId(k) >= 0 && corners->GetId(k) < count,
              path + ": a polygon names a point that does not exist");
    mesh.triangles.emplace_back(static_cast<int>(corners->GetId(0)),
                                static_cast<int>(corners->GetId(1)),
                                static_cast<int>(corners->GetId(2)));
  }
  Require(!mesh.triangles.empty(),
          path + ": mesh has no faces (a model needs at least one triangle)");
  return mesh;
}

}  // namespace furn

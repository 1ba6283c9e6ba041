// VTK legacy polydata (.vtk), the format of the paper's own CAD models, read
// by VTK (which PCL brings) into triangles: polygons and triangle strips are
// triangulated (vtkTriangleFilter), lines and vertices dropped. Kept apart
// from mesh_io.cc so that only this file sees VTK's headers.
//
//   TriangleMesh mesh = ReadVtkPolyData("chair1.vtk");   // file units and axes
#pragma once

#include <string>

#include "core/geometry/mesh.h"

namespace furn {

// Throws InputError naming the file: unreadable, not polydata, no faces,
// non-finite points or indices out of range.
TriangleMesh ReadVtkPolyData(const std::string& path);

}  // namespace furn

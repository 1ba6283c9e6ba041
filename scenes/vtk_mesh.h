// VTK legacy polydata (.vtk), the format of the paper's own CAD models, read
// through PCL's VTK reader (pcl::io::loadPolygonFileVTK) into triangles.
// Polygons of more than three corners are fanned; lines and vertices are
// dropped. Kept apart from mesh_io.cc so that only this file sees VTK's
// headers.
//
//   TriangleMesh mesh = ReadVtkPolyData("chair1.vtk");   // file units and axes
#pragma once

#include <string>

#include "core/mesh.h"

namespace furn {

// Throws InputError naming the file: unreadable, not polydata, no faces,
// non-finite points or indices out of range.
TriangleMesh ReadVtkPolyData(const std::string& path);

}  // namespace furn

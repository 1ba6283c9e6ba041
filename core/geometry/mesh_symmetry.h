// The rotational symmetry of a mesh about a vertical axis (z through a given
// point): none, discrete (a turn by 360°/n maps it onto itself: a
// rectangular table n = 2, a square one n = 4) or continuous (every turn: a
// round table). What pose metrics with symmetric objects need (BOP's MSSD
// and MSPD take models_info.json's symmetries_discrete and
// symmetries_continuous).
//
// Decided on the surface: area-weighted samples (fixed seeds) turned about
// the axis must land within a tolerance (1.5 % of the mesh's largest side,
// at least 5 mm and twice the samples' spacing) of a second set of surface
// samples as often, but for 3 % of them, as they do unturned.
//
//   const MeshSymmetry symmetry = FindVerticalSymmetry(mesh, box.Center());
//   if (symmetry.continuous) ...; else if (symmetry.order > 1) ...
#pragma once

#include <Eigen/Core>

#include "core/geometry/mesh.h"
#include "core/util/error.h"  // InputError

namespace furn {

struct MeshSymmetry {
  bool continuous = false;  // every turn about the axis
  int order = 1;            // else: turns by 360° / order (1: none; 2 or 4)
};

// Throws InputError for a mesh without area.
MeshSymmetry FindVerticalSymmetry(const TriangleMesh& mesh, const Eigen::Vector3f& axis_point);

}  // namespace furn

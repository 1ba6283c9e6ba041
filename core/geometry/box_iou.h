// Overlap of gravity-aligned oriented boxes (a yaw about z, sides parallel to
// the floor or upright), as indoor 3-D detection benchmarks score boxes
// (SUN RGB-D, ScanNet; mmdetection3d's axis-aligned-in-z rotated IoU): the
// bird's-eye footprints' intersection is the overlap of two rotated
// rectangles, clipped as convex polygons (Sutherland-Hodgman), and the 3-D
// intersection that area times the overlap of the boxes' z spans.
//
//   const double bev = BevIou(a, b);   // footprints only
//   const double iou = Iou3d(a, b);    // volumes
#pragma once

#include "core/geometry/conventions.h"

namespace furn {

// Area of the intersection of the two boxes' footprints (m^2).
double FootprintIntersectionArea(const OrientedBox& a, const OrientedBox& b);

// Intersection over union of the footprints (0..1; 0 when either is empty).
double BevIou(const OrientedBox& a, const OrientedBox& b);

// Intersection over union of the volumes (0..1; 0 when either is empty).
double Iou3d(const OrientedBox& a, const OrientedBox& b);

}  // namespace furn

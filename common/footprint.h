// Oriented footprints: the horizontal outline of an object's oriented box in a z-up frame g (the
// map's, or the query's gravity frame). An object's axis-aligned box is as wide as its oriented
// box turned by the map's yaw (a keyboard 45 deg to the map's axes covers a square around it;
// a desk piece 40 deg to them, the books beside it), so things side by side would overlap by
// their boxes without overlapping at all. Polygons are convex and counter-clockwise, in metres
// (x_g, y_g). Used by the query's relations and the map's table loads.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/map_object.h"

namespace loci {

using Footprint = std::vector<Eigen::Vector2d>;

// Convex hull of the points, counter-clockwise (Andrew's monotone chain); fewer than 3 points
// when they are collinear or fewer than 3 are distinct.
Footprint ConvexHull(std::vector<Eigen::Vector2d> points);
// Area of a convex polygon, m^2 (0 for fewer than 3 vertices).
double PolygonArea(const Footprint& polygon);
// Area of the intersection of two convex counter-clockwise polygons, m^2 (Sutherland-Hodgman).
double ConvexOverlapArea(const Footprint& a, const Footprint& b);
// Shortest distance between two convex polygons, m: 0 when they touch or overlap.
double ConvexDistanceM(const Footprint& a, const Footprint& b);

// The outline in g of the object's oriented box: its 8 corners turned into g by R_g_map,
// projected on the horizontal plane, their convex hull. Empty when the object has no oriented
// box.
Footprint OrientedFootprint(const MapObject& o,
                            const Eigen::Matrix3d& R_g_map = Eigen::Matrix3d::Identity());

}  // namespace loci

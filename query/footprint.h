// Oriented footprints: the horizontal outline of an object's oriented box in the gravity frame g.
// An object's axis-aligned box in g is as wide as its oriented box turned by the map's yaw (a
// keyboard 45 deg to the map's axes covers a square around it), so side-by-side things at two
// heights (a keyboard in front of a monitor) would overlap by their boxes without overlapping at
// all. Polygons are convex and counter-clockwise, in metres (x_g, y_g).
#pragma once

#include <Eigen/Core>
#include <vector>

namespace loci::query {

using Footprint = std::vector<Eigen::Vector2d>;

// Convex hull of the points, counter-clockwise (Andrew's monotone chain); fewer than 3 points
// when they are collinear or fewer than 3 are distinct.
Footprint ConvexHull(std::vector<Eigen::Vector2d> points);
// Area of a convex polygon, m^2 (0 for fewer than 3 vertices).
double PolygonArea(const Footprint& polygon);
// Area of the intersection of two convex counter-clockwise polygons, m^2 (Sutherland-Hodgman).
double ConvexOverlapArea(const Footprint& a, const Footprint& b);

}  // namespace loci::query

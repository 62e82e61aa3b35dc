// Connected parts of an object's points, for a centroid that a stray cluster cannot move.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace loci::server {

// The points of every part that holds at least min_fraction of them, plus the largest part.
// Parts are the connected components of the occupied cell_m grid cells (26-neighbourhood):
// a table's top and legs are one part; depth bleeding onto the wall behind a cup, split from
// it by an empty gap, is another. min_fraction 0 keeps every point.
std::vector<Eigen::Vector3d> MainParts(const std::vector<Eigen::Vector3d>& pts_m, double cell_m,
                                       double min_fraction);

}  // namespace loci::server

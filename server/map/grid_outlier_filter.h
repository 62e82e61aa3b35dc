// Statistical outlier removal (paper 000 eq. 18) with an exact K-nearest-neighbour search on a
// uniform grid instead of a k-d tree. Voxel-filtered clouds hold about one point per cell of the
// voxel edge, so the K nearest neighbours of almost every point lie in the 3x3x3 or 5x5x5 cells
// around it: a hash lookup per cell is several times cheaper than building and querying a tree.
// The result equals pcl::StatisticalOutlierRemoval's (same mean / stddev rule).
#pragma once

#include <pcl/point_cloud.h>

#include <cstdint>
#include <vector>

namespace loci::server {

// Mean distance (m) of every point to its mean_k nearest other points, exact. cell_m: grid edge,
// best the voxel edge the cloud was filtered with (any positive value gives the same result,
// only slower). Points with fewer than mean_k others get the mean over those there are.
template <typename PointT>
std::vector<float> MeanNeighbourDistances(const pcl::PointCloud<PointT>& cloud, int mean_k,
                                          double cell_m);

// Keeps the points whose mean neighbour distance d satisfies d <= max(m + stddev_mul * s,
// min_threshold_m) (m, s: mean and sample standard deviation of d over the cloud). The floor
// keeps the rim of a clean surface: on a voxelised surface most points are interior, so m + s
// falls below the distances of every edge point and eq. 18 alone trims one voxel off every
// border in every view. mean_k <= 0, cell_m <= 0 or at most mean_k points: the cloud unchanged.
template <typename PointT>
pcl::PointCloud<PointT> RemoveOutliersOnGrid(const pcl::PointCloud<PointT>& cloud, int mean_k,
                                             double stddev_mul, double cell_m,
                                             double min_threshold_m = 0.0);

}  // namespace loci::server

// Voxel-grid filter in one hashing pass (no copy of the input, no sort): one point per occupied
// voxel of edge voxel_m (grid aligned at 0 in the cloud's frame) with the mean position and
// colour of its points, and for labelled points the most frequent label (ties: the smallest).
// The same points as pcl::VoxelGrid / pcl::VoxelGridLabel, in the order of each voxel's first
// point, at a fraction of their cost on keyframe-sized clouds.
#pragma once

#include <pcl/point_cloud.h>

namespace loci::server {

// voxel_m <= 0 or an empty cloud: the cloud unchanged.
template <typename PointT>
pcl::PointCloud<PointT> VoxelAverage(const pcl::PointCloud<PointT>& cloud, double voxel_m);

}  // namespace loci::server

// Integer voxel keys for hashing points of the map frame: 21 bits per axis (+-1,048,576 voxels,
// about +-10 km at 1 cm), packed into one uint64.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>

namespace loci::server {

using VoxelKey = uint64_t;

inline VoxelKey KeyOf(const Eigen::Vector3d& p_m, double voxel_m) {
  auto axis = [voxel_m](double v) {
    const int64_t i = static_cast<int64_t>(std::floor(v / voxel_m)) + (int64_t{1} << 20);
    return static_cast<uint64_t>(i) & ((uint64_t{1} << 21) - 1);
  };
  return (axis(p_m.x()) << 42) | (axis(p_m.y()) << 21) | axis(p_m.z());
}

// Centre of a voxel in metres.
inline Eigen::Vector3d CenterOf(VoxelKey key, double voxel_m) {
  auto axis = [voxel_m](uint64_t bits) {
    return (static_cast<double>(static_cast<int64_t>(bits & ((uint64_t{1} << 21) - 1)) -
                                (int64_t{1} << 20)) +
            0.5) *
           voxel_m;
  };
  return {axis(key >> 42), axis(key >> 21), axis(key)};
}

}  // namespace loci::server

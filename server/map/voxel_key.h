// Integer voxel keys for hashing points of the map frame: 21 bits per axis (+-1,048,576 voxels,
// about +-10 km at 1 cm), packed into one uint64.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>

namespace loci::server {

using VoxelKey = uint64_t;

// Integer voxel (or grid cell) coordinates, each in [-2^20, 2^20), packed into one key.
inline VoxelKey PackVoxel(int64_t ix, int64_t iy, int64_t iz) {
  constexpr int64_t kOff = int64_t{1} << 20;
  constexpr uint64_t kMask = (uint64_t{1} << 21) - 1;
  return ((static_cast<uint64_t>(ix + kOff) & kMask) << 42) |
         ((static_cast<uint64_t>(iy + kOff) & kMask) << 21) |
         (static_cast<uint64_t>(iz + kOff) & kMask);
}

inline VoxelKey KeyOf(const Eigen::Vector3d& p_m, double voxel_m) {
  auto cell = [voxel_m](double v) { return static_cast<int64_t>(std::floor(v / voxel_m)); };
  return PackVoxel(cell(p_m.x()), cell(p_m.y()), cell(p_m.z()));
}

// Bucket hash of a key for open-addressing tables (murmur3 finaliser, first half).
inline size_t HashVoxelKey(VoxelKey k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdULL;
  k ^= k >> 33;
  return static_cast<size_t>(k);
}

// Voxel tables. std::unordered_map on purpose: absl's Swiss tables salt each table's probe
// sequence with its address, so their iteration order (the order of rays into the OctoMap, of
// sums in a centroid) would change from run to run, and the map with it.
template <class V>
using VoxelMap = std::unordered_map<VoxelKey, V>;
using VoxelSet = std::unordered_set<VoxelKey>;

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

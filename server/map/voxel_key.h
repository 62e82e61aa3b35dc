// Integer voxel keys for hashing points of the map frame: 21 bits per axis (+-1,048,576 voxels,
// about +-10 km at 1 cm), packed into one uint64.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include <sparsehash/dense_hash_map>
#include <sparsehash/dense_hash_set>

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

struct VoxelKeyHash {
  size_t operator()(VoxelKey k) const { return HashVoxelKey(k); }
};

// Voxel tables: sparsehash's open-addressing dense_hash_map/set, with the murmur finaliser
// above. Open addressing keeps a lookup to about one cache line (std::unordered_map chases a
// node per lookup, which was 75 % of moving keyframes). The iteration order (the order of rays
// into the OctoMap, of sums in a centroid) depends only on the table's history, so the same
// input gives the same map on every run; absl's Swiss tables salt each table's probe sequence
// with its address and would not. Packed keys use 63 bits, so the two all-ones keys are free
// to mark empty and erased slots.
inline constexpr VoxelKey kEmptyVoxelKey = ~VoxelKey{0};
inline constexpr VoxelKey kErasedVoxelKey = ~VoxelKey{0} - 1;

template <class V>
class VoxelMap : public google::dense_hash_map<VoxelKey, V, VoxelKeyHash> {
 public:
  VoxelMap() {
    this->set_empty_key(kEmptyVoxelKey);
    this->set_deleted_key(kErasedVoxelKey);
  }
  void reserve(size_t n) { this->resize(n); }
  // As std::unordered_map::at.
  const V& at(VoxelKey key) const {
    const auto it = this->find(key);
    if (it == this->end()) throw std::out_of_range("VoxelMap::at: no such voxel");
    return it->second;
  }
};

class VoxelSet : public google::dense_hash_set<VoxelKey, VoxelKeyHash> {
 public:
  VoxelSet() {
    set_empty_key(kEmptyVoxelKey);
    set_deleted_key(kErasedVoxelKey);
  }
  void reserve(size_t n) { resize(n); }
};

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

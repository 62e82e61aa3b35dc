// The global dense semantic cloud in the map frame: one point per voxel (mean position and
// colour) with the majority object id of the points that fell into it (0 = background).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "server/map/fused_object.h"
#include "server/map/voxel_key.h"

namespace loci::store::v1 {
class SemanticCloudState;
}  // namespace loci::store::v1

namespace loci::server {

struct SemanticPoint {
  Eigen::Vector3f p_m = Eigen::Vector3f::Zero();
  uint32_t rgb = 0;       // 0xRRGGBB
  int64_t object_id = 0;  // 0 = background
};

// A SemanticCloud voxel (at namespace scope for the same reason as FusedObjectVoxel).
struct SemanticCloudVoxel {
  Eigen::Vector3f sum_m = Eigen::Vector3f::Zero();
  Eigen::Vector3f rgb_sum = Eigen::Vector3f::Zero();
  uint32_t count = 0;
  int64_t object_id = 0;  // Boyer-Moore majority candidate over the points' ids
  int32_t votes = 0;
};

class SemanticCloud {
 public:
  explicit SemanticCloud(double voxel_m) : voxel_m_(voxel_m) {}

  // Adds points already in the map frame.
  void Add(const std::vector<SemanticPoint>& points_m);
  // Takes out points added earlier (the same values; a keyframe that moves). A voxel's majority
  // object id is a running vote: a removed point of the leading id takes one vote back, others
  // leave it as it is.
  void Remove(const std::vector<SemanticPoint>& points_m);
  // Points downsampled to voxel_m (<= the cloud's voxel: every voxel as is); object ids mapped
  // through `resolve` (merged objects); `keep` filters by resolved object id.
  std::vector<SemanticPoint> Points(double voxel_m, const std::function<int64_t(int64_t)>& resolve,
                                    const std::function<bool(int64_t)>& keep) const;
  size_t size() const { return voxels_.size(); }
  double voxel_m() const { return voxel_m_; }

  // Checkpoint state (map_checkpoint.cc); LoadState replaces every voxel.
  void SaveState(loci::store::v1::SemanticCloudState* out) const;
  Status LoadState(const loci::store::v1::SemanticCloudState& in);

 private:
  using Voxel = SemanticCloudVoxel;
  double voxel_m_;
  VoxelMap<Voxel> voxels_;
};

}  // namespace loci::server

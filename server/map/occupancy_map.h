// OctoMap occupancy of the static scene (paper 002 3.3): each keyframe's static cloud is inserted
// with ray casting from the camera origin, so free space is carved along every ray.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "server/map/map_options.h"

namespace octomap {
class OcTree;
}

namespace loci::server {

class OccupancyMap {
 public:
  explicit OccupancyMap(const OctomapOptions& options);
  ~OccupancyMap();

  // Inserts points (map frame, m) seen from `origin_m` (camera centre, map frame).
  void Insert(const std::vector<Eigen::Vector3f>& points_m, const Eigen::Vector3d& origin_m);
  // Full-probability tree data (octomap writeData) for checkpoints, and back.
  std::string SerializeState() const;
  Status LoadState(const std::string& bytes);
  // The tree as an octomap .bt stream.
  std::string SerializeBt() const;
  // Occupancy probability at a point; -1 when unknown.
  double OccupancyAt(const Eigen::Vector3d& p_m) const;
  // Centres of occupied leaves, map frame.
  std::vector<Eigen::Vector3d> OccupiedCenters() const;
  uint64_t node_count() const;
  double resolution_m() const { return options_.resolution_m; }

 private:
  // Splits points into one ray per ray voxel and the remaining end points (occupied only).
  void SplitRays(const std::vector<Eigen::Vector3f>& points_m, std::vector<Eigen::Vector3f>* rays,
                 std::vector<Eigen::Vector3f>* rest) const;
  bool InRange(const Eigen::Vector3f& p, const Eigen::Vector3d& origin_m) const;

  OctomapOptions options_;
  std::unique_ptr<octomap::OcTree> tree_;
};

}  // namespace loci::server

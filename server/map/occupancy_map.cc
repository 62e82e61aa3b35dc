#include "server/map/occupancy_map.h"

#include <octomap/OcTree.h>

#include <sstream>

namespace loci::server {

OccupancyMap::OccupancyMap(const OctomapOptions& options)
    : options_(options), tree_(std::make_unique<octomap::OcTree>(options.resolution_m)) {}

OccupancyMap::~OccupancyMap() = default;

void OccupancyMap::Insert(const std::vector<Eigen::Vector3f>& points_m,
                          const Eigen::Vector3d& origin_m) {
  if (points_m.empty()) return;
  octomap::Pointcloud cloud;
  cloud.reserve(points_m.size());
  for (const auto& p : points_m) cloud.push_back(p.x(), p.y(), p.z());
  // discretize = true: one ray per end voxel, the same map for a fraction of the cost.
  tree_->insertPointCloud(cloud, octomap::point3d(origin_m.x(), origin_m.y(), origin_m.z()),
                          options_.max_range_m, /*lazy_eval=*/false, /*discretize=*/true);
}

std::string OccupancyMap::SerializeBt() const {
  std::ostringstream os;
  tree_->writeBinaryConst(os);
  return os.str();
}

double OccupancyMap::OccupancyAt(const Eigen::Vector3d& p) const {
  const octomap::OcTreeNode* n = tree_->search(p.x(), p.y(), p.z());
  return n ? n->getOccupancy() : -1.0;
}

std::vector<Eigen::Vector3d> OccupancyMap::OccupiedCenters() const {
  std::vector<Eigen::Vector3d> out;
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    if (tree_->isNodeOccupied(*it)) out.emplace_back(it.getX(), it.getY(), it.getZ());
  }
  return out;
}

uint64_t OccupancyMap::node_count() const { return tree_->size(); }

}  // namespace loci::server

#include "server/map/occupancy_map.h"

#include <octomap/OcTree.h>

#include <limits>
#include <sstream>

#include "server/map/voxel_key.h"

namespace loci::server {

OccupancyMap::OccupancyMap(const OctomapOptions& options)
    : options_(options), tree_(std::make_unique<octomap::OcTree>(options.resolution_m)) {}

OccupancyMap::~OccupancyMap() = default;

void OccupancyMap::SplitRays(const std::vector<Eigen::Vector3f>& points_m,
                             std::vector<Eigen::Vector3f>* rays,
                             std::vector<Eigen::Vector3f>* rest) const {
  // One ray per ray voxel (free space + its end point), the remaining end points occupied only.
  const bool thin = options_.ray_voxel_m > options_.resolution_m;
  VoxelSet ray_voxels;
  for (const auto& p : points_m) {
    if (!thin || ray_voxels.insert(KeyOf(p.cast<double>(), options_.ray_voxel_m)).second) {
      rays->push_back(p);
    } else {
      rest->push_back(p);
    }
  }
}

bool OccupancyMap::InRange(const Eigen::Vector3f& p, const Eigen::Vector3d& origin_m) const {
  return options_.max_range_m <= 0 ||
         (p.cast<double>() - origin_m).squaredNorm() <= options_.max_range_m * options_.max_range_m;
}

namespace {

octomap::Pointcloud ToOctomap(const std::vector<Eigen::Vector3f>& points_m) {
  octomap::Pointcloud cloud;
  cloud.reserve(points_m.size());
  for (const auto& p : points_m) cloud.push_back(p.x(), p.y(), p.z());
  return cloud;
}

}  // namespace

void OccupancyMap::Insert(const std::vector<Eigen::Vector3f>& points_m,
                          const Eigen::Vector3d& origin_m) {
  if (points_m.empty()) return;
  std::vector<Eigen::Vector3f> rays, rest;
  SplitRays(points_m, &rays, &rest);
  // discretize = true: one ray per end leaf, the same map for a fraction of the cost.
  tree_->insertPointCloud(ToOctomap(rays), octomap::point3d(origin_m.x(), origin_m.y(), origin_m.z()),
                          options_.max_range_m, /*lazy_eval=*/false, /*discretize=*/true);
  for (const auto& p : rest) {
    if (InRange(p, origin_m)) tree_->updateNode(p.x(), p.y(), p.z(), /*occupied=*/true, false);
  }
}

std::string OccupancyMap::SerializeBt() const {
  std::ostringstream os;
  tree_->writeBinaryConst(os);
  return os.str();
}

std::string OccupancyMap::SerializeState() const {
  std::ostringstream os;
  tree_->writeData(os);
  return os.str();
}

Status OccupancyMap::LoadState(const std::string& bytes) {
  tree_->clear();
  std::istringstream in(bytes);
  if (!tree_->readData(in)) return absl::DataLossError("checkpoint: the OctoMap does not parse");
  return absl::OkStatus();
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

#include "server/map/up_estimate.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/filters/extract_indices.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <memory>
#include <unordered_set>

#include "server/map/voxel_key.h"

namespace loci::server {

std::optional<Vec3d> EstimateUpFromPlanes(const std::vector<Eigen::Vector3f>& points,
                                          const Vec3d& prior_up, const PlaneUpOptions& options) {
  if (points.size() < 100 || prior_up.norm() < 1e-9) return std::nullopt;
  const Vec3d prior = prior_up.normalized();
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  VoxelSet seen;  // one point per voxel_m cell
  for (const auto& p : points) {
    if (!p.allFinite() || !seen.insert(KeyOf(p.cast<double>(), options.voxel_m)).second) continue;
    cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  if (cloud->size() < 100) return std::nullopt;
  const size_t total = cloud->size();
  const double min_inliers = options.min_plane_fraction * static_cast<double>(total);
  struct Plane {
    Vec3d normal;
    double inliers;
  };
  std::vector<Plane> horizontal;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setOptimizeCoefficients(true);
  seg.setModelType(pcl::SACMODEL_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setDistanceThreshold(options.plane_distance_m);
  seg.setMaxIterations(200);
  const double cos_tilt = std::cos(options.max_tilt_deg * M_PI / 180.0);
  for (int k = 0; k < options.max_planes && cloud->size() >= 100; ++k) {
    pcl::ModelCoefficients coeffs;
    pcl::PointIndices inliers;
    seg.setInputCloud(cloud);
    seg.segment(inliers, coeffs);
    if (inliers.indices.size() < std::max(min_inliers, 50.0) || coeffs.values.size() < 4) break;
    Vec3d n(coeffs.values[0], coeffs.values[1], coeffs.values[2]);
    if (n.allFinite() && n.norm() > 1e-6) {
      n.normalize();
      if (n.dot(prior) < 0) n = -n;
      if (n.dot(prior) >= cos_tilt) {
        horizontal.push_back({n, static_cast<double>(inliers.indices.size())});
      }
    }
    // Remove this plane's points and look for the next one.
    pcl::ExtractIndices<pcl::PointXYZ> extract;
    extract.setInputCloud(cloud);
    extract.setIndices(std::make_shared<pcl::PointIndices>(inliers));
    extract.setNegative(true);
    auto rest = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    extract.filter(*rest);
    cloud = rest;
  }
  if (horizontal.empty()) return std::nullopt;
  // The normal that the largest supports agree on: group normals within up_cluster_deg.
  const double cos_cluster = std::cos(options.cluster_deg * M_PI / 180.0);
  double best_support = -1;
  Vec3d best = prior;
  for (const Plane& seed : horizontal) {
    Vec3d sum = Vec3d::Zero();
    double support = 0;
    for (const Plane& p : horizontal) {
      if (p.normal.dot(seed.normal) >= cos_cluster) {
        sum += p.inliers * p.normal;
        support += p.inliers;
      }
    }
    if (support > best_support && sum.norm() > 1e-9) {
      best_support = support;
      best = sum.normalized();
    }
  }
  return best;
}

}  // namespace loci::server

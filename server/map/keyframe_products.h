// Per-keyframe map products, all in the keyframe (camera) frame: the labelled static cloud and
// the object observations (paper 000 3.2-3.3, paper 002 3.3). World products are derived later
// with T_map_kf.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"
#include "common/time.h"  // ThreadCpuMs for the stage times
#include "server/map/map_options.h"

namespace loci::server {

// Pixel labels: kBackground, kExcluded (dynamic or invalid), or 1 + detection index.
constexpr int16_t kBackgroundLabel = 0;
constexpr int16_t kExcludedLabel = -1;

// One detected object's points in one keyframe.
struct ObjectObservation {
  int detection_index = 0;
  std::string class_name;
  float score = 0;
  int64_t track_id = 0;
  pcl::PointCloud<pcl::PointXYZRGB> cloud_kf;  // voxel + outlier filtered, kf frame, m
};

struct KeyframeProducts {
  // Static points (dynamic classes removed), voxel + outlier filtered; label 0 = background,
  // 1 + i = observations[i].
  pcl::PointCloud<pcl::PointXYZRGBL> static_cloud_kf;
  std::vector<ObjectObservation> observations;
  uint64_t excluded_pixels = 0;  // pixels of dynamic classes left out
  // For negative evidence (visibility.h): every depth_stride-th depth pixel (CV_32FC1, m) and
  // every detection of the keyframe, boxes only (masks dropped).
  cv::Mat visibility_depth_m;
  int depth_stride = 1;
  std::vector<Detection2D> detection_boxes;
  // Thread CPU milliseconds of the sub-stages (robust to other load on the machine).
  double labels_ms = 0, objects_ms = 0, backproject_ms = 0, voxel_ms = 0, outlier_ms = 0;
};

// Label image (CV_16SC1) of a keyframe: object pixels from the detections' masks, else from
// detection::SegmentObjectDepth on the box (with camera and gravity when known); dynamic classes
// kExcludedLabel over their whole mask or box. Smaller boxes win over larger ones they overlap
// (a book on a table). depth_m is CV_32FC1 metres, 0 = invalid.
cv::Mat LabelPixels(const cv::Mat& depth_m, const std::vector<Detection2D>& detections,
                    const MapOptions& options, const PinholeCamera& camera,
                    const std::optional<Vec3d>& gravity_cam);

// Back-projects pixels with valid depth in [min, max] (every `stride`-th pixel) into the cam
// frame; labels from `labels` (excluded pixels skipped). Colours from bgr (CV_8UC3).
pcl::PointCloud<pcl::PointXYZRGBL> BackProject(const cv::Mat& bgr, const cv::Mat& depth_m,
                                               const cv::Mat& labels, const PinholeCamera& camera,
                                               int stride, double min_depth_m, double max_depth_m);

// Voxel filter keeping the majority label per voxel (as pcl::VoxelGridLabel; VoxelAverage).
pcl::PointCloud<pcl::PointXYZRGBL> VoxelFilterLabelled(
    const pcl::PointCloud<pcl::PointXYZRGBL>& cloud, double voxel_m);
// Statistical outlier removal, eq. 18: drop points whose mean distance to their K nearest
// neighbours exceeds m + k * s. K = 0 or fewer than K + 1 points: unchanged.
template <typename PointT>
pcl::PointCloud<PointT> RemoveOutliers(const pcl::PointCloud<PointT>& cloud, int mean_k,
                                       double stddev_mul);

// Builds every product of one keyframe.
KeyframeProducts BuildKeyframeProducts(const cv::Mat& bgr, const cv::Mat& depth_m,
                                       const PinholeCamera& camera,
                                       const std::vector<Detection2D>& detections,
                                       const MapOptions& options,
                                       const std::optional<Vec3d>& gravity_cam = std::nullopt);

}  // namespace loci::server

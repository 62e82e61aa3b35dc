#include "server/map/keyframe_products.h"

#include <pcl/filters/statistical_outlier_removal.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <map>
#include <numeric>
#include <opencv2/imgproc.hpp>

#include "common/task_pool.h"
#include "detection/depth_mask.h"
#include "server/map/grid_outlier_filter.h"
#include "server/map/mask_cover.h"
#include "server/map/visibility.h"
#include "server/map/voxel_filter.h"

namespace loci::server {

cv::Mat LabelPixels(const cv::Mat& depth_m, const std::vector<Detection2D>& detections,
                    const MapOptions& options, const PinholeCamera& camera,
                    const std::optional<Vec3d>& gravity_cam) {
  cv::Mat labels(depth_m.size(), CV_16SC1, cv::Scalar(kBackgroundLabel));
  std::vector<int> objects, dynamic;
  for (int i = 0; i < static_cast<int>(detections.size()); ++i) {
    const Detection2D& d = detections[i];
    if (options.IsDynamic(d.class_name)) {
      dynamic.push_back(i);  // dynamic regions are removed whatever their score (paper 004)
    } else if (d.score >= options.observation.min_score && options.IsMapped(d.class_name)) {
      objects.push_back(i);
    }
  }
  auto rect_of = [&](int i) { return MaskRect(detections[i].box_px, depth_m.cols, depth_m.rows); };
  // Larger boxes first so that smaller objects standing on or in front of them keep their pixels.
  std::stable_sort(objects.begin(), objects.end(),
                   [&](int a, int b) { return rect_of(a).area() > rect_of(b).area(); });
  auto paint = [&](int i, int16_t label, bool use_cluster) {
    const cv::Rect r = rect_of(i);
    if (r.area() <= 0) return;
    cv::Mat mask;
    const Detection2D& d = detections[i];
    if (!d.mask.empty()) {
      mask = d.mask;
      if (mask.size() != r.size()) cv::resize(mask, mask, r.size(), 0, 0, cv::INTER_NEAREST);
    } else if (use_cluster) {
      const detection::MaskContext context{d.class_name, camera, gravity_cam};
      mask = detection::SegmentObjectDepth(depth_m, d.box_px, options.observation.mask, context);
      if (mask.size() != r.size()) return;
    } else {
      mask = cv::Mat(r.size(), CV_8UC1, cv::Scalar(255));  // no mask: drop the whole box
    }
    labels(r).setTo(cv::Scalar(label), mask);
  };
  for (int i : objects) paint(i, static_cast<int16_t>(i + 1), true);
  for (int i : dynamic) paint(i, kExcludedLabel, false);
  return labels;
}

pcl::PointCloud<pcl::PointXYZRGBL> BackProject(const cv::Mat& bgr, const cv::Mat& depth_m,
                                               const cv::Mat& labels, const PinholeCamera& cam,
                                               int stride, double min_depth_m, double max_depth_m) {
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  cloud.reserve((depth_m.rows / stride + 1) * (depth_m.cols / stride + 1));
  const float inv_fx = 1.0f / cam.fx, inv_fy = 1.0f / cam.fy;
  for (int v = 0; v < depth_m.rows; v += stride) {
    const float* drow = depth_m.ptr<float>(v);
    const cv::Vec3b* crow = bgr.ptr<cv::Vec3b>(v);
    const int16_t* lrow = labels.ptr<int16_t>(v);
    for (int u = 0; u < depth_m.cols; u += stride) {
      const float d = drow[u];
      if (!(d >= min_depth_m && d <= max_depth_m) || lrow[u] < 0) continue;
      pcl::PointXYZRGBL p;
      p.x = (u - static_cast<float>(cam.cx)) * d * inv_fx;
      p.y = (v - static_cast<float>(cam.cy)) * d * inv_fy;
      p.z = d;
      p.b = crow[u][0];
      p.g = crow[u][1];
      p.r = crow[u][2];
      p.label = static_cast<uint32_t>(lrow[u]);
      cloud.push_back(p);
    }
  }
  return cloud;
}

pcl::PointCloud<pcl::PointXYZRGBL> VoxelFilterLabelled(
    const pcl::PointCloud<pcl::PointXYZRGBL>& cloud, double voxel_m) {
  return VoxelAverage(cloud, voxel_m);
}

template <typename PointT>
pcl::PointCloud<PointT> RemoveOutliers(const pcl::PointCloud<PointT>& cloud, int mean_k,
                                       double stddev_mul) {
  if (mean_k <= 0 || static_cast<int>(cloud.size()) <= mean_k) return cloud;
  pcl::PointCloud<PointT> out;
  pcl::StatisticalOutlierRemoval<PointT> sor;
  sor.setInputCloud(cloud.makeShared());
  sor.setMeanK(mean_k);
  sor.setStddevMulThresh(stddev_mul);
  sor.filter(out);
  return out;
}
template pcl::PointCloud<pcl::PointXYZRGBL> RemoveOutliers(
    const pcl::PointCloud<pcl::PointXYZRGBL>&, int, double);
template pcl::PointCloud<pcl::PointXYZRGB> RemoveOutliers(const pcl::PointCloud<pcl::PointXYZRGB>&,
                                                          int, double);

namespace {

pcl::PointCloud<pcl::PointXYZRGB> ObjectCloud(const cv::Mat& bgr, const cv::Mat& depth_m,
                                              const cv::Mat& labels, int16_t label,
                                              const cv::Rect& rect, const PinholeCamera& cam,
                                              const MapOptions& options) {
  const ObservationOptions& o = options.observation;
  // Visible surface area (sum of pixel footprints) decides the voxel edge, and the voxel edge
  // the pixel stride: no need to back-project several pixels per voxel.
  double area_m2 = 0;
  int pixels = 0;
  for (int v = rect.y; v < rect.y + rect.height; ++v) {
    const float* drow = depth_m.ptr<float>(v);
    const int16_t* lrow = labels.ptr<int16_t>(v);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      const float d = drow[u];
      if (lrow[u] != label || !(d >= options.cloud.min_depth_m && d <= options.cloud.max_depth_m)) {
        continue;
      }
      area_m2 += static_cast<double>(d) * d;
      ++pixels;
    }
  }
  pcl::PointCloud<pcl::PointXYZRGB> raw;
  if (pixels == 0) return raw;
  area_m2 /= cam.fx * cam.fy;
  const double voxel_m = std::max(o.voxel_m, std::sqrt(area_m2 / o.max_points));
  const double footprint_m = std::sqrt(area_m2 / pixels);
  const int stride = std::max(1, static_cast<int>(0.5 * voxel_m / footprint_m));
  for (int v = rect.y; v < rect.y + rect.height; v += stride) {
    const float* drow = depth_m.ptr<float>(v);
    const int16_t* lrow = labels.ptr<int16_t>(v);
    const cv::Vec3b* crow = bgr.ptr<cv::Vec3b>(v);
    for (int u = rect.x; u < rect.x + rect.width; u += stride) {
      const float d = drow[u];
      if (lrow[u] != label || !(d >= options.cloud.min_depth_m && d <= options.cloud.max_depth_m)) {
        continue;
      }
      const Eigen::Vector3d p = cam.BackProject(u, v, d);
      pcl::PointXYZRGB q(crow[u][2], crow[u][1], crow[u][0]);
      q.x = static_cast<float>(p.x());
      q.y = static_cast<float>(p.y());
      q.z = static_cast<float>(p.z());
      raw.push_back(q);
    }
  }
  const pcl::PointCloud<pcl::PointXYZRGB> voxelised = VoxelAverage(raw, voxel_m);
  return RemoveOutliersOnGrid(voxelised, o.sor_mean_k, o.sor_stddev_mul, voxel_m,
                              o.sor_min_voxels * voxel_m);
}

// Median z (depth) of a camera-frame cloud.
double MedianDepthM(const pcl::PointCloud<pcl::PointXYZRGB>& cloud) {
  if (cloud.empty()) return 0;
  std::vector<float> z(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) z[i] = cloud[i].z;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

// 5-95 % span of the points along a unit direction, m (a few stray points do not count).
double RobustSpanAlongM(const pcl::PointCloud<pcl::PointXYZRGB>& cloud, const Vec3d& dir) {
  if (cloud.size() < 2) return 0;
  std::vector<double> s(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    s[i] = dir.dot(cloud[i].getVector3fMap().cast<double>());
  }
  const size_t lo = s.size() / 20, hi = s.size() - 1 - s.size() / 20;
  std::nth_element(s.begin(), s.begin() + lo, s.end());
  const double a = s[lo];
  std::nth_element(s.begin(), s.begin() + hi, s.end());
  return s[hi] - a;
}

// Longest side of the points' 5-95 % box (camera axes).
double RobustExtentM(const pcl::PointCloud<pcl::PointXYZRGB>& cloud) {
  return std::max({RobustSpanAlongM(cloud, Vec3d::UnitX()),
                   RobustSpanAlongM(cloud, Vec3d::UnitY()),
                   RobustSpanAlongM(cloud, Vec3d::UnitZ())});
}

// The pieces of one detection's cloud seen with gravity: one per top surface of furniture with
// a top (and without what lies outside the tops); otherwise the whole cloud. *tops is set when
// the cloud was split.
std::vector<pcl::PointCloud<pcl::PointXYZRGB>> Pieces(pcl::PointCloud<pcl::PointXYZRGB> cloud,
                                                      const std::string& class_name,
                                                      const MapOptions& options,
                                                      const std::optional<Vec3d>& gravity_cam,
                                                      std::optional<SupportTops>* tops) {
  std::vector<pcl::PointCloud<pcl::PointXYZRGB>> pieces;
  const ObservationOptions& o = options.observation;
  if (!gravity_cam || !o.support_tops.enabled || !o.mask.IsFlatTopClass(class_name)) {
    pieces.push_back(std::move(cloud));
    return pieces;
  }
  std::vector<Eigen::Vector3d> points_kf;
  points_kf.reserve(cloud.size());
  for (const auto& p : cloud) points_kf.push_back(p.getVector3fMap().cast<double>());
  tops->emplace(points_kf, -gravity_cam->normalized(), o.support_tops, o.mask);
  // No top in view (furniture seen from below, or too little of it).
  if ((*tops)->size() == 0) {
    tops->reset();
    pieces.push_back(std::move(cloud));
    return pieces;
  }
  pieces.resize((*tops)->size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const int t = (*tops)->TopOf(points_kf[i]);
    if (t >= 0) pieces[t].push_back(cloud[i]);
  }
  return pieces;
}

// Whether one piece of a detection is worth fusing (ObservationOptions, the class size priors).
bool Fusable(const pcl::PointCloud<pcl::PointXYZRGB>& cloud, const std::string& class_name,
             const MapOptions& options, const std::optional<Vec3d>& gravity_cam) {
  return static_cast<int>(cloud.size()) >= options.observation.min_points &&
         RobustExtentM(cloud) <= options.MaxSizeM(class_name) &&
         (!gravity_cam ||
          RobustSpanAlongM(cloud, -gravity_cam->normalized()) <= options.MaxHeightM(class_name)) &&
         MedianDepthM(cloud) <= options.observation.max_object_depth_m;
}

// Pixel label (1 + detection index) -> observation (1 + index, 0 = none) of the dense cloud's
// points; a detection split by its tops sends each point to its top's observation.
struct LabelToObservation {
  std::vector<uint32_t> whole;
  std::map<uint32_t, std::pair<SupportTops, std::vector<uint32_t>>> split;

  uint32_t Of(const pcl::PointXYZRGBL& p) const {
    auto it = split.find(p.label);
    if (it == split.end()) return p.label < whole.size() ? whole[p.label] : 0;
    const int t = it->second.first.TopOf(p.getVector3fMap().cast<double>());
    return t >= 0 ? it->second.second[t] : 0;
  }
};

// The object observations of the detections (appended to products->observations).
LabelToObservation AddObservations(const cv::Mat& bgr, const cv::Mat& depth_m,
                                   const cv::Mat& labels, const PinholeCamera& camera,
                                   const std::vector<Detection2D>& detections,
                                   const MapOptions& options,
                                   const std::optional<Vec3d>& gravity_cam,
                                   KeyframeProducts* products) {
  LabelToObservation to_obs;
  to_obs.whole.assign(detections.size() + 1, 0);
  for (int i = 0; i < static_cast<int>(detections.size()); ++i) {
    const Detection2D& d = detections[i];
    if (options.IsDynamic(d.class_name) || d.score < options.observation.min_score ||
        !options.IsMapped(d.class_name) ||
        std::min(d.box_px.width, d.box_px.height) < options.observation.min_box_px) {
      continue;
    }
    const cv::Rect rect = MaskRect(d.box_px, depth_m.cols, depth_m.rows);
    if (!options.observation.mask.IsFlatTopClass(d.class_name) &&
        IsHollow(CoverOf(labels, rect, static_cast<int16_t>(i + 1), kBackgroundLabel),
                 options.observation.min_centre_cover)) {
      continue;
    }
    std::optional<SupportTops> tops;
    std::vector<pcl::PointCloud<pcl::PointXYZRGB>> pieces = Pieces(
        ObjectCloud(bgr, depth_m, labels, static_cast<int16_t>(i + 1), rect, camera, options),
        d.class_name, options, gravity_cam, &tops);
    std::vector<uint32_t> observation_of_piece(pieces.size(), 0);
    for (size_t k = 0; k < pieces.size(); ++k) {
      if (!Fusable(pieces[k], d.class_name, options, gravity_cam)) continue;
      ObjectObservation obs;
      obs.detection_index = i;
      obs.class_name = d.class_name;
      obs.score = d.score;
      // A track follows the box; a box split into several pieces of furniture names none.
      obs.track_id = pieces.size() == 1 ? d.track_id : 0;
      obs.cloud_kf = std::move(pieces[k]);
      products->observations.push_back(std::move(obs));
      observation_of_piece[k] = static_cast<uint32_t>(products->observations.size());
    }
    if (tops) {
      to_obs.split.emplace(static_cast<uint32_t>(i + 1),
                           std::make_pair(std::move(*tops), std::move(observation_of_piece)));
    } else {
      to_obs.whole[i + 1] = observation_of_piece[0];
    }
  }
  return to_obs;
}

}  // namespace

KeyframeProducts BuildKeyframeProducts(const cv::Mat& bgr, const cv::Mat& depth_m,
                                       const PinholeCamera& camera,
                                       const std::vector<Detection2D>& detections,
                                       const MapOptions& options,
                                       const std::optional<Vec3d>& gravity_cam) {
  KeyframeProducts products;
  double t = ThreadCpuMs();
  const cv::Mat labels = LabelPixels(depth_m, detections, options, camera, gravity_cam);
  products.excluded_pixels = static_cast<uint64_t>(cv::countNonZero(labels < 0));
  products.labels_ms = ThreadCpuMs() - t;

  // The dense cloud (labels = 1 + detection index for now) runs on a pool thread while this
  // thread builds the object observations.
  struct Dense {
    pcl::PointCloud<pcl::PointXYZRGBL> cloud;
    double backproject_ms = 0, voxel_ms = 0, outlier_ms = 0;
  };
  std::future<Dense> dense_future = TaskPool::Shared().Submit([&] {
    Dense d;
    double t0 = ThreadCpuMs();
    d.cloud = BackProject(bgr, depth_m, labels, camera, options.cloud.pixel_stride,
                          options.cloud.min_depth_m, options.cloud.max_depth_m);
    double t1 = ThreadCpuMs();
    d.backproject_ms = t1 - t0;
    d.cloud = VoxelFilterLabelled(d.cloud, options.cloud.voxel_m);
    t0 = ThreadCpuMs();
    d.voxel_ms = t0 - t1;
    d.cloud = RemoveOutliersOnGrid(d.cloud, options.cloud.sor_mean_k, options.cloud.sor_stddev_mul,
                                   options.cloud.voxel_m);
    d.outlier_ms = ThreadCpuMs() - t0;
    return d;
  });

  t = ThreadCpuMs();
  const LabelToObservation to_observation =
      AddObservations(bgr, depth_m, labels, camera, detections, options, gravity_cam, &products);
  products.objects_ms = ThreadCpuMs() - t;

  Dense dense = dense_future.get();
  for (auto& p : dense.cloud) p.label = to_observation.Of(p);
  products.static_cloud_kf = std::move(dense.cloud);
  products.backproject_ms = dense.backproject_ms;
  products.voxel_ms = dense.voxel_ms;
  products.outlier_ms = dense.outlier_ms;
  products.depth_stride = options.fusion.visibility.depth_stride;
  // Millimetres, as stored (product_codec.h), so a stored product maps exactly as a fresh one.
  cv::Mat depth_mm;
  SubsampleDepth(depth_m, products.depth_stride).convertTo(depth_mm, CV_16UC1, 1000.0);
  depth_mm.convertTo(products.visibility_depth_m, CV_32FC1, 1e-3);
  products.detection_boxes = detections;
  for (Detection2D& d : products.detection_boxes) d.mask.release();
  return products;
}

}  // namespace loci::server

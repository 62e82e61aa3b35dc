#include "server/map/upright_box.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace loci::server {
namespace {

constexpr double kTrim = 0.02;

// The points' box along the axes of R (columns): corners lo, hi in box coordinates. Along the
// first two axes (horizontal) each side leaves out the trim fraction of the points beyond it.
void BoxAlong(const std::vector<Eigen::Vector3d>& pts_m, const Eigen::Matrix3d& R, double trim,
              Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  lo->setConstant(std::numeric_limits<double>::max());
  *hi = -*lo;
  std::vector<double> u, v;
  u.reserve(pts_m.size());
  v.reserve(pts_m.size());
  for (const Eigen::Vector3d& p : pts_m) {
    const Eigen::Vector3d q = R.transpose() * p;
    *lo = lo->cwiseMin(q);
    *hi = hi->cwiseMax(q);
    u.push_back(q.x());
    v.push_back(q.y());
  }
  const size_t k = static_cast<size_t>(trim * static_cast<double>(pts_m.size() - 1));
  if (k == 0) return;
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<double>& w = axis == 0 ? u : v;
    std::nth_element(w.begin(), w.begin() + k, w.end());
    (*lo)(axis) = w[k];
    std::nth_element(w.begin(), w.end() - 1 - k, w.end());
    (*hi)(axis) = w[w.size() - 1 - k];
  }
}

// Yaw of one side of the smallest-area rectangle around the points' footprint, rad. Points are
// taken relative to their first one: floats keep mm far from the map's origin.
double FootprintYawRad(const std::vector<Eigen::Vector3d>& pts_m) {
  std::vector<cv::Point2f> xy;
  xy.reserve(pts_m.size());
  for (const Eigen::Vector3d& p : pts_m) {
    const Eigen::Vector3d d = p - pts_m.front();
    xy.emplace_back(static_cast<float>(d.x()), static_cast<float>(d.y()));
  }
  if (xy.size() < 3) return 0.0;
  return cv::minAreaRect(xy).angle * M_PI / 180.0;
}

}  // namespace

UprightBox FitUprightBox(const std::vector<Eigen::Vector3d>& pts_m) {
  Eigen::Matrix3d R =
      Eigen::AngleAxisd(FootprintYawRad(pts_m), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Vector3d lo, hi;
  BoxAlong(pts_m, R, kTrim, &lo, &hi);
  if (hi.y() - lo.y() > hi.x() - lo.x()) {  // x along the longer side
    R = Eigen::Matrix3d(R * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
    BoxAlong(pts_m, R, kTrim, &lo, &hi);
  }
  UprightBox box;
  box.R_map_box = R;
  box.center_m = R * (0.5 * (lo + hi));
  box.half_extent_m = 0.5 * (hi - lo);
  return box;
}

Eigen::Vector3d BoxCentreAlong(const std::vector<Eigen::Vector3d>& pts_m,
                               const Eigen::Matrix3d& R_map_box) {
  Eigen::Vector3d lo, hi;
  BoxAlong(pts_m, R_map_box, kTrim, &lo, &hi);
  return R_map_box * (0.5 * (lo + hi));
}

}  // namespace loci::server

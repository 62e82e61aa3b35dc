#include "client/tracking/local_ba.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <array>
#include <unordered_map>

namespace loci {
namespace {

struct Reprojection {
  Reprojection(const PinholeCamera& cam, double u_px, double v_px, double ur_px, double bf_px_m,
               double weight)
      : fx(cam.fx),
        fy(cam.fy),
        cx(cam.cx),
        cy(cam.cy),
        u(u_px),
        v(v_px),
        ur(ur_px),
        bf(bf_px_m),
        w(weight) {}
  template <typename T>
  bool operator()(const T* pose, const T* point, T* r) const {
    T p[3];
    ceres::AngleAxisRotatePoint(pose, point, p);
    p[0] += pose[3];
    p[1] += pose[4];
    p[2] += pose[5];
    if (p[2] < T(1e-3)) {
      r[0] = r[1] = r[2] = T(0);
      return true;
    }
    const T iz = T(1) / p[2];
    const T pu = T(fx) * p[0] * iz + T(cx);
    r[0] = T(w) * (pu - T(u));
    r[1] = T(w) * (T(fy) * p[1] * iz + T(cy) - T(v));
    r[2] = ur >= 0 ? T(w) * (pu - T(bf) * iz - T(ur)) : T(0);
    return true;
  }
  double fx, fy, cx, cy, u, v, ur, bf, w;
};

std::array<double, 6> ToParams(const SE3d& T_cw) {
  Eigen::AngleAxisd aa(T_cw.linear());
  const Vec3d r = aa.axis() * aa.angle();
  return {
      r.x(), r.y(), r.z(), T_cw.translation().x(), T_cw.translation().y(), T_cw.translation().z()};
}

SE3d FromParams(const std::array<double, 6>& p) {
  const Vec3d r(p[0], p[1], p[2]);
  SE3d T = SE3d::Identity();
  const double angle = r.norm();
  if (angle > 1e-12) T.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
  T.translation() = Vec3d(p[3], p[4], p[5]);
  return T;
}

}  // namespace

bool LocalBundleAdjust(const PinholeCamera& cam, const LocalBaOptions& opt,
                       const std::vector<float>& level_inv_sigma2, LocalMap* map) {
  auto& kfs = map->mutable_keyframes();
  if (kfs.size() < 2) return false;
  const size_t n = kfs.size();
  const size_t first_opt = n > static_cast<size_t>(opt.num_optimised_keyframes)
                               ? n - static_cast<size_t>(opt.num_optimised_keyframes)
                               : 1;  // the oldest keyframe anchors the gauge
  std::unordered_map<int64_t, std::array<double, 3>> points;
  for (size_t k = first_opt; k < n; ++k) {
    for (int64_t id : kfs[k]->point_ids) {
      if (const MapPoint* p = map->Point(id)) {
        points.try_emplace(id,
                           std::array<double, 3>{p->p_world.x(), p->p_world.y(), p->p_world.z()});
      }
    }
  }
  if (points.empty()) return false;
  std::vector<std::array<double, 6>> poses(n);
  ceres::Problem problem;
  ceres::LossFunction* huber = new ceres::HuberLoss(std::sqrt(7.815));
  int residuals = 0;
  for (size_t k = 0; k < n; ++k) {
    const KeyframeRecord& kf = *kfs[k];
    poses[k] = ToParams(kf.T_world_cam.inverse());
    bool used = false;
    for (size_t j = 0; j < kf.point_ids.size(); ++j) {
      auto it = points.find(kf.point_ids[j]);
      if (it == points.end()) continue;
      const cv::KeyPoint& kp = kf.frame.keypoints[kf.point_kp[j]];
      const float z = kf.frame.depth_m[kf.point_kp[j]];
      const double ur = z > 0 ? kp.pt.x - opt.bf_px / z : -1.0;
      const int level = std::clamp(kp.octave, 0, static_cast<int>(level_inv_sigma2.size()) - 1);
      const double w = std::sqrt(level_inv_sigma2[level]);
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Reprojection, 3, 6, 3>(
                                   new Reprojection(cam, kp.pt.x, kp.pt.y, ur, opt.bf_px, w)),
                               huber, poses[k].data(), it->second.data());
      used = true;
      ++residuals;
    }
    if (used && k < first_opt) problem.SetParameterBlockConstant(poses[k].data());
  }
  if (residuals < 10) return false;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = opt.max_iterations;
  so.max_solver_time_in_seconds = opt.max_time_s;
  so.num_threads = 1;
  so.minimizer_progress_to_stdout = false;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) return false;
  for (size_t k = first_opt; k < n; ++k) {
    const SE3d T_cw = FromParams(poses[k]);
    if (IsFinite(T_cw)) kfs[k]->T_world_cam = T_cw.inverse();
  }
  for (const auto& [id, xyz] : points) {
    MapPoint* p = map->Point(id);
    const Vec3d v(xyz[0], xyz[1], xyz[2]);
    if (p && v.allFinite()) p->p_world = v;
  }
  return true;
}

}  // namespace loci

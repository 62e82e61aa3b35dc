#include "client/tracking/pose_refiner.h"

#include <Eigen/Cholesky>
#include <cmath>

namespace loci {
namespace {

constexpr double kChi2Mono = 5.991;    // 95 %, 2 dof
constexpr double kChi2Stereo = 7.815;  // 95 %, 3 dof

Mat3d Skew(const Vec3d& v) {
  Mat3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

}  // namespace

SE3d ExpLeft(const Eigen::Matrix<double, 6, 1>& xi, const SE3d& T) {
  const Vec3d w = xi.head<3>();
  const double angle = w.norm();
  SE3d d = SE3d::Identity();
  if (angle > 1e-12) d.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  d.translation() = xi.tail<3>();
  SE3d out = d * T;
  // Keep the rotation orthonormal after many small updates.
  Eigen::Quaterniond q(out.linear());
  q.normalize();
  out.linear() = q.toRotationMatrix();
  return out;
}

PoseRefineResult RefinePose(const PinholeCamera& cam, double bf_px,
                            const std::vector<PoseObservation>& obs, const SE3d& T_cam_world_init,
                            int rounds, int iterations) {
  PoseRefineResult res;
  res.T_cam_world = T_cam_world_init;
  const size_t n = obs.size();
  res.inlier.assign(n, 1);
  for (int round = 0; round < rounds; ++round) {
    for (int it = 0; it < iterations; ++it) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
      int used = 0;
      for (size_t i = 0; i < n; ++i) {
        if (!res.inlier[i]) continue;
        const PoseObservation& o = obs[i];
        const Vec3d p = res.T_cam_world * o.p_world;
        if (p.z() <= 1e-3) continue;
        const double iz = 1.0 / p.z(), iz2 = iz * iz;
        const bool stereo = o.ur_px >= 0;
        Eigen::Vector3d r;
        Eigen::Matrix<double, 3, 3> J_p;  // d residual / d p_cam
        const double u = cam.fx * p.x() * iz + cam.cx;
        const double v = cam.fy * p.y() * iz + cam.cy;
        r(0) = u - o.uv_px.x();
        r(1) = v - o.uv_px.y();
        r(2) = stereo ? (u - bf_px * iz) - o.ur_px : 0.0;
        J_p << cam.fx * iz, 0, -cam.fx * p.x() * iz2, 0, cam.fy * iz, -cam.fy * p.y() * iz2,
            cam.fx * iz, 0, -(cam.fx * p.x() - bf_px) * iz2;
        if (!stereo) J_p.row(2).setZero();
        Eigen::Matrix<double, 3, 6> J_xi;  // d p / d xi for the left perturbation
        J_xi.leftCols<3>() = -Skew(p);
        J_xi.rightCols<3>().setIdentity();
        const Eigen::Matrix<double, 3, 6> J = J_p * J_xi;
        const double chi2 = r.squaredNorm() * o.inv_sigma2;
        const double delta2 = stereo ? kChi2Stereo : kChi2Mono;
        double w = o.inv_sigma2;
        if (chi2 > delta2) w *= std::sqrt(delta2 / chi2);  // Huber
        H.noalias() += J.transpose() * w * J;
        b.noalias() -= J.transpose() * (w * r);
        ++used;
      }
      if (used < 3) break;
      const Eigen::Matrix<double, 6, 1> dx = H.ldlt().solve(b);
      if (!dx.allFinite()) break;
      res.T_cam_world = ExpLeft(dx, res.T_cam_world);
      if (dx.squaredNorm() < 1e-12) break;
    }
    // Re-classify every observation (outliers may come back) with the current pose.
    res.num_inliers = 0;
    for (size_t i = 0; i < n; ++i) {
      const PoseObservation& o = obs[i];
      const Vec3d p = res.T_cam_world * o.p_world;
      if (p.z() <= 1e-3) {
        res.inlier[i] = 0;
        continue;
      }
      const double u = cam.fx * p.x() / p.z() + cam.cx;
      const double v = cam.fy * p.y() / p.z() + cam.cy;
      double e2 = (u - o.uv_px.x()) * (u - o.uv_px.x()) + (v - o.uv_px.y()) * (v - o.uv_px.y());
      const bool stereo = o.ur_px >= 0;
      if (stereo) {
        const double ur = u - bf_px / p.z();
        e2 += (ur - o.ur_px) * (ur - o.ur_px);
      }
      res.inlier[i] = e2 * o.inv_sigma2 <= (stereo ? kChi2Stereo : kChi2Mono);
      res.num_inliers += res.inlier[i];
    }
    if (res.num_inliers < 6) break;
  }
  return res;
}

}  // namespace loci

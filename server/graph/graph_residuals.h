// Ceres residuals and the yaw-only manifold of the pose graph. A keyframe pose is two parameter
// blocks: t_map_kf (3) and q_map_kf (4, Eigen order x, y, z, w).
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/autodiff_manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "server/graph/graph_types.h"

namespace loci::server {

// Relative pose error of an edge measuring T_a_b (as the Ceres pose_graph_3d example):
// r = sqrt_info * [R_a^T (t_b - t_a) - t_ab; 2 vec(q_ab * (q_a^-1 q_b)^-1)].
class RelativePoseError {
 public:
  RelativePoseError(const SE3d& T_a_b, const Information6& information);

  template <typename T>
  bool operator()(const T* t_a_ptr, const T* q_a_ptr, const T* t_b_ptr, const T* q_b_ptr,
                  T* residual_ptr) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_a(t_a_ptr), t_b(t_b_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_ptr), q_b(q_b_ptr);
    const Eigen::Quaternion<T> q_a_inv = q_a.conjugate();
    const Eigen::Quaternion<T> q_ab = q_a_inv * q_b;
    const Eigen::Matrix<T, 3, 1> t_ab = q_a_inv * (t_b - t_a);
    const Eigen::Quaternion<T> dq = q_ab_.template cast<T>() * q_ab.conjugate();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual_ptr);
    r.template head<3>() = t_ab - t_ab_.template cast<T>();
    r.template tail<3>() = T(2.0) * dq.vec();
    r.applyOnTheLeft(sqrt_information_.template cast<T>());
    return true;
  }

  static ceres::CostFunction* Create(const SE3d& T_a_b, const Information6& information);

 private:
  Vec3d t_ab_;
  Quatd q_ab_;
  Information6 sqrt_information_;  // upper Cholesky factor: L^T with L L^T = information
};

// Object-centroid observation (paper 000 eq. 20): r = (R_map_kf^T (c_map - t_map_kf) - c_kf) /
// sigma.
class CentroidError {
 public:
  CentroidError(const Vec3d& c_kf_m, double sigma_m) : c_kf_m_(c_kf_m), inv_sigma_(1 / sigma_m) {}

  template <typename T>
  bool operator()(const T* t_ptr, const T* q_ptr, const T* c_ptr, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_map_kf(t_ptr), c_map(c_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_map_kf(q_ptr);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual_ptr);
    r = (q_map_kf.conjugate() * (c_map - t_map_kf) - c_kf_m_.template cast<T>()) * T(inv_sigma_);
    return true;
  }

  static ceres::CostFunction* Create(const Vec3d& c_kf_m, double sigma_m);

 private:
  Vec3d c_kf_m_;
  double inv_sigma_;
};

// Gravity prior (GravityPriorOptions): r = (R_map_kf * up_kf).xy / sigma, zero when the
// keyframe's measured up is the map's z.
class GravityError {
 public:
  GravityError(const Vec3d& up_kf, double sigma_rad)
      : up_kf_(up_kf.normalized()), inv_sigma_(1 / sigma_rad) {}

  template <typename T>
  bool operator()(const T* q_ptr, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_map_kf(q_ptr);
    const Eigen::Matrix<T, 3, 1> up_map = q_map_kf * up_kf_.template cast<T>();
    residual_ptr[0] = up_map.x() * T(inv_sigma_);
    residual_ptr[1] = up_map.y() * T(inv_sigma_);
    return true;
  }

  static ceres::CostFunction* Create(const Vec3d& up_kf, double sigma_rad);

 private:
  Vec3d up_kf_;
  double inv_sigma_;
};

// Rotation about the map's z axis only, q <- Rz(delta) * q: the 4-DoF mode's orientation
// manifold (roll and pitch, known from gravity, never change).
struct YawOnlyQuaternion {
  template <typename T>
  bool Plus(const T* x, const T* delta, T* x_plus_delta) const {
    const T half = delta[0] * T(0.5);
    const Eigen::Quaternion<T> rz(cos(half), T(0), T(0), sin(half));
    Eigen::Map<Eigen::Quaternion<T>> out(x_plus_delta);
    out = rz * Eigen::Map<const Eigen::Quaternion<T>>(x);
    return true;
  }
  template <typename T>
  bool Minus(const T* y, const T* x, T* y_minus_x) const {
    const Eigen::Quaternion<T> d =
        Eigen::Map<const Eigen::Quaternion<T>>(y) * Eigen::Map<const Eigen::Quaternion<T>>(x).conjugate();
    y_minus_x[0] = T(2.0) * atan2(d.z(), d.w());
    return true;
  }
  static ceres::Manifold* Create() {
    return new ceres::AutoDiffManifold<YawOnlyQuaternion, 4, 1>(new YawOnlyQuaternion);
  }
};

}  // namespace loci::server

// Small SE(3) helpers of the pose graph: the adjoint, a first-order log and exp in the
// residual's order (translation, then rotation), covariance transport.
#pragma once

#include "common/se3.h"
#include "server/graph/graph_types.h"

namespace loci::server {

using Vec6d = Eigen::Matrix<double, 6, 1>;

// Ad(T) for xi = (rho, phi) (translation first): T * Exp(xi) * T^-1 = Exp(Ad(T) * xi).
Covariance6 Adjoint(const SE3d& T);

// (translation, angle-axis of the rotation): the residual of an edge whose error is T.
Vec6d PoseError6(const SE3d& T);
// Inverse of PoseError6: translation e.head(3), rotation by the angle-axis e.tail(3).
SE3d PoseFromError6(const Vec6d& e);

// Covariance of T^-1's right perturbation given T's: Ad(T) * cov * Ad(T)^T.
Covariance6 InverseCovariance(const SE3d& T, const Covariance6& cov_right);

// Yaw of R = Rz(yaw) * Ry(pitch) * Rx(roll) (z-y-x Euler angles), rad: atan2(R(1,0), R(0,0)).
// Used to keep only the yaw of a rotation between two gravity-aligned frames.
double YawOf(const Mat3d& R_map_x);

}  // namespace loci::server

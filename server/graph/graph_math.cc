#include "server/graph/graph_math.h"

#include <cmath>

namespace loci::server {
namespace {

Mat3d Hat(const Vec3d& v) {
  Mat3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace

Information6 IsotropicInformation(double sigma_trans_m, double sigma_rot_rad) {
  Vec6d d;
  d << Vec3d::Constant(1.0 / (sigma_trans_m * sigma_trans_m)),
      Vec3d::Constant(1.0 / (sigma_rot_rad * sigma_rot_rad));
  return d.asDiagonal();
}

const char* EdgeKindName(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kOdometry: return "odometry";
    case EdgeKind::kLoop: return "loop";
    case EdgeKind::kMerge: return "merge";
  }
  return "?";
}

Covariance6 Adjoint(const SE3d& T) {
  const Mat3d R = T.rotation();
  Covariance6 ad = Covariance6::Zero();
  ad.topLeftCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = Hat(T.translation()) * R;
  ad.bottomRightCorner<3, 3>() = R;
  return ad;
}

Vec6d PoseError6(const SE3d& T) {
  const Eigen::AngleAxisd aa(T.rotation());
  Vec6d e;
  e << T.translation(), aa.angle() * aa.axis();
  return e;
}

SE3d PoseFromError6(const Vec6d& e) {
  SE3d T = SE3d::Identity();
  const double angle = e.tail<3>().norm();
  if (angle > 0) T.linear() = Eigen::AngleAxisd(angle, e.tail<3>() / angle).toRotationMatrix();
  T.translation() = e.head<3>();
  return T;
}

Covariance6 InverseCovariance(const SE3d& T, const Covariance6& cov_right) {
  const Covariance6 ad = Adjoint(T);
  return ad * cov_right * ad.transpose();
}

double YawOf(const Mat3d& R_map_x) { return std::atan2(R_map_x(1, 0), R_map_x(0, 0)); }

}  // namespace loci::server

#include "common/se3.h"

#include <cmath>

namespace loci {

SE3d MakeSE3(const Vec3d& t_m, const Quatd& q) {
  SE3d T = SE3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t_m;
  return T;
}

SE3d SE3FromTum(double tx, double ty, double tz, double qx, double qy, double qz, double qw) {
  return MakeSE3(Vec3d(tx, ty, tz), Quatd(qw, qx, qy, qz));
}

Quatd QuatOf(const SE3d& T) {
  Quatd q(T.rotation());
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return q;
}

bool IsFinite(const SE3d& T) { return T.matrix().allFinite(); }

Status ValidatePose(const Vec3d& t_m, double qw, double qx, double qy, double qz,
                    double unit_tol) {
  if (!t_m.allFinite()) {
    return absl::InvalidArgumentError("pose translation is not finite");
  }
  if (!std::isfinite(qw) || !std::isfinite(qx) || !std::isfinite(qy) || !std::isfinite(qz)) {
    return absl::InvalidArgumentError("pose quaternion is not finite");
  }
  const double norm = std::sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
  if (std::abs(norm - 1.0) > unit_tol) {
    return absl::InvalidArgumentError(
        absl::StrCat("pose quaternion is not unit (|q| = ", norm, ")"));
  }
  return absl::OkStatus();
}

double RotationAngleRad(const SE3d& T) {
  const double c = std::clamp((T.rotation().trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c);
}

Mat3d RotationAligningToZ(const Vec3d& up) {
  return Quatd::FromTwoVectors(up.normalized(), Vec3d::UnitZ()).toRotationMatrix();
}

}  // namespace loci

#include "synth/camera_path.h"

#include <cmath>

namespace loci::synth {

double CameraPath::Wave::At(double t_s) const {
  return amplitude * std::sin(2.0 * M_PI * t_s / period_s + phase_rad);
}

CameraPath CameraPath::Random(const Vec3d& target_world_m, Rng& rng) {
  CameraPath p;
  auto wave = [&rng](double amp_lo, double amp_hi, double per_lo, double per_hi) {
    return Wave{rng.Uniform(amp_lo, amp_hi), rng.Uniform(per_lo, per_hi), rng.Uniform(0, 2 * M_PI)};
  };
  p.target_world_m_ = target_world_m;
  p.azimuth0_rad_ = -M_PI / 2 + rng.Uniform(-0.15, 0.15);
  p.azimuth_ = wave(0.55, 0.75, 16.0, 22.0);
  p.range0_m_ = rng.Uniform(1.4, 1.7);
  p.range_ = wave(0.15, 0.25, 7.0, 11.0);
  p.height0_m_ = rng.Uniform(1.3, 1.5);
  p.height_ = wave(0.08, 0.14, 5.0, 8.0);
  p.gaze_x_ = wave(0.25, 0.40, 2.2, 3.5);
  p.gaze_y_ = wave(0.15, 0.25, 2.5, 4.0);
  p.gaze_z_ = wave(0.10, 0.18, 1.8, 3.0);
  p.roll_ = wave(0.05, 0.10, 3.0, 6.0);
  return p;
}

Vec3d CameraPath::PositionAt(double t_s) const {
  const double az = azimuth0_rad_ + azimuth_.At(t_s);
  const double r = range0_m_ + range_.At(t_s);
  return {target_world_m_.x() + r * std::cos(az), target_world_m_.y() + r * std::sin(az),
          height0_m_ + height_.At(t_s)};
}

Vec3d CameraPath::LookTargetAt(double t_s) const {
  return target_world_m_ + Vec3d(gaze_x_.At(t_s), gaze_y_.At(t_s), gaze_z_.At(t_s));
}

double CameraPath::RollAt(double t_s) const { return roll_.At(t_s); }

SE3d CameraPath::PoseAt(double t_s) const {
  const Vec3d c = PositionAt(t_s);
  const Vec3d z_cam = (LookTargetAt(t_s) - c).normalized();
  // Right-handed cam frame with y pointing down: x = z x up, y = z x x.
  const Vec3d x_cam = z_cam.cross(Vec3d::UnitZ()).normalized();
  const Vec3d y_cam = z_cam.cross(x_cam);
  Mat3d R_world_cam;
  R_world_cam.col(0) = x_cam;
  R_world_cam.col(1) = y_cam;
  R_world_cam.col(2) = z_cam;
  R_world_cam = R_world_cam * Eigen::AngleAxisd(RollAt(t_s), Vec3d::UnitZ()).toRotationMatrix();
  SE3d T = SE3d::Identity();
  T.linear() = R_world_cam;
  T.translation() = c;
  return T;
}

Vec3d CameraPath::AccelerationAt(double t_s) const {
  constexpr double h = 1e-3;
  return (PositionAt(t_s + h) - 2.0 * PositionAt(t_s) + PositionAt(t_s - h)) / (h * h);
}

}  // namespace loci::synth

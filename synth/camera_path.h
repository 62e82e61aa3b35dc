// Smooth hand-held-like camera trajectory of a synthetic scene: the camera swings on an arc in
// front of a target (the table), bobs in height and range, and its gaze wanders around the
// target, all as sums of sinusoids (C-infinity, so velocities and accelerations are exact).
// Typical speeds like TUM hand-held sequences: ~0.2-0.5 m/s and 15-40 deg/s.
#pragma once

#include <Eigen/Core>

#include "common/se3.h"
#include "synth/rng.h"

namespace loci::synth {

class CameraPath {
 public:
  CameraPath() = default;
  // Random path (from rng) around `target_world_m` (the point the camera looks at on average),
  // with the camera on the side of -y from the target (azimuth -90 deg +- the swing).
  static CameraPath Random(const Vec3d& target_world_m, Rng& rng);

  // T_world_cam at time t_s since the start (cam: x right, y down, z forward; world z up).
  SE3d PoseAt(double t_s) const;
  // Camera centre in the world frame at t_s (m).
  Vec3d PositionAt(double t_s) const;
  // Linear acceleration of the camera centre in the world frame (m/s^2), by central differences
  // of the analytic position (h = 1 ms; error far below 1e-3 m/s^2 for these frequencies).
  Vec3d AccelerationAt(double t_s) const;

 private:
  Vec3d LookTargetAt(double t_s) const;
  double RollAt(double t_s) const;

  struct Wave {
    double amplitude = 0, period_s = 1, phase_rad = 0;
    double At(double t_s) const;
  };
  Vec3d target_world_m_ = Vec3d::Zero();
  double azimuth0_rad_ = 0;        // mean azimuth of the camera around the target
  Wave azimuth_;                   // swing of the arc, rad
  double range0_m_ = 2.0;          // mean horizontal distance to the target
  Wave range_;                     // m
  double height0_m_ = 1.4;         // mean camera height above the floor (world z)
  Wave height_;                    // m
  Wave gaze_x_, gaze_y_, gaze_z_;  // wander of the looked-at point, m
  Wave roll_;                      // rad
};

}  // namespace loci::synth

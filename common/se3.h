// Rigid transforms. Convention (one place for the whole project):
//   T_a_b maps a point from frame b to frame a:  p_a = T_a_b * p_b.
//   Composition: T_a_c = T_a_b * T_b_c.  Inverse: T_b_a = T_a_b.inverse().
// Frames: cam (x right, y down, z forward), kf (a keyframe's cam), odom (a robot's odometry
// origin), base (the first robot's odometry frame; the server places each session's odom in
// it), map (the shared map, ROS REP-103/105: x forward, y left, z up, origin at the first
// keyframe; the server levels base into it, server/map/map_frame.h). Translations in metres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/status.h"

namespace loci {

using SE3d = Eigen::Isometry3d;
using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;
using Quatd = Eigen::Quaterniond;

// Builds T from a translation (m) and a quaternion; the quaternion is normalised.
SE3d MakeSE3(const Vec3d& t_m, const Quatd& q);

// Builds T from TUM order: tx ty tz qx qy qz qw.
SE3d SE3FromTum(double tx, double ty, double tz, double qx, double qy, double qz, double qw);

// Unit quaternion of T's rotation with w >= 0 (one canonical sign).
Quatd QuatOf(const SE3d& T);

// True when every entry is finite.
bool IsFinite(const SE3d& T);

// Checks a pose as received from outside: finite translation, finite quaternion with
// | |q| - 1 | <= tol. Returns InvalidArgument with a readable message otherwise.
Status ValidatePose(const Vec3d& t_m, double qw, double qx, double qy, double qz,
                    double unit_tol = 1e-3);

// Rotation angle of T in radians, in [0, pi].
double RotationAngleRad(const SE3d& T);

// Rotation whose z axis is `up` (unit vector, in the source frame): R_aligned_src maps
// vectors so that `up` becomes +z. Rotation about z is chosen minimal.
Mat3d RotationAligningToZ(const Vec3d& up);

}  // namespace loci

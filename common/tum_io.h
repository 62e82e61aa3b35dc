// TUM RGB-D dataset I/O: rgb.txt / depth.txt association, groundtruth.txt, accelerometer.txt,
// and TUM trajectory files ("t tx ty tz qx qy qz qw", poses T_world_cam).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/se3.h"
#include "common/status.h"

namespace loci {

// One time-stamped pose of a trajectory, T_world_cam.
struct StampedPose {
  int64_t t_ns = 0;
  SE3d T_world_cam = SE3d::Identity();
};
using Trajectory = std::vector<StampedPose>;

// An accelerometer sample in the sensor frame (TUM: m/s^2, Kinect accelerometer axes).
struct AccelSample {
  int64_t t_ns = 0;
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();
};

// One RGB image with its associated depth image.
struct TumFrame {
  int64_t rgb_t_ns = 0;
  int64_t depth_t_ns = 0;
  std::string rgb_path;    // absolute or relative to the working directory
  std::string depth_path;
};

struct TumSequence {
  std::string dir;
  std::vector<TumFrame> frames;       // rgb order, each with its nearest depth within max_dt
  Trajectory groundtruth;             // empty when groundtruth.txt is absent
  std::vector<AccelSample> accel;     // empty when accelerometer.txt is absent
};

// Time-stamped lines "stamp value..." of a TUM list file (comments '#' skipped).
struct StampedLine {
  int64_t t_ns = 0;
  std::vector<std::string> fields;  // the fields after the stamp
};
StatusOr<std::vector<StampedLine>> ReadStampedFile(const std::string& path);

// Associates two stamp lists like TUM's associate.py: every pair closer than max_dt_ns is a
// candidate; pairs are taken greedily by increasing |dt|, each stamp used at most once.
// Returns index pairs (i into a, j into b) sorted by i.
std::vector<std::pair<size_t, size_t>> AssociateStamps(const std::vector<int64_t>& a,
                                                       const std::vector<int64_t>& b,
                                                       int64_t max_dt_ns);

// Loads a TUM folder (rgb.txt, depth.txt required; groundtruth.txt, accelerometer.txt optional).
StatusOr<TumSequence> LoadTumSequence(const std::string& dir, int64_t max_dt_ns = 20'000'000);

StatusOr<Trajectory> ReadTumTrajectory(const std::string& path);
// The pose at t_ns between the two poses of `sorted` (ascending t_ns) around it: translation
// linear, rotation slerp; nullopt when t_ns lies outside it or the two are more than max_gap_ns
// apart. A 100 Hz ground truth turns 1.2 deg between samples at 120 deg/s, so its nearest sample
// can be 0.6 deg off the pose at an image's stamp.
std::optional<SE3d> InterpolatePose(const Trajectory& sorted, int64_t t_ns, int64_t max_gap_ns);
Status WriteTumTrajectory(const std::string& path, const Trajectory& traj);

// Gravity direction (unit, pointing down) in the cam frame from the mean of the accelerometer
// samples within max_dt_ns of t_ns. The Kinect accelerometer axes are the optical axes with x
// and y reversed (checked against fr1_rpy ground truth: world +z in cam = (-ax, -ay, az)/|a|),
// and at rest it reads the reaction to gravity, so gravity_cam = (ax, ay, -az) / |a|.
StatusOr<Eigen::Vector3d> GravityInCamAt(const std::vector<AccelSample>& accel, int64_t t_ns,
                                         int64_t max_dt_ns = 50'000'000);

}  // namespace loci

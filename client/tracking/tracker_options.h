// Options of the RGB-D visual odometry (loci::Tracker). Every field has its unit and default;
// FromYaml fills only the keys present (config/client.yaml, section `tracker`).
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <string>

#include "common/camera.h"
#include "common/status.h"

namespace loci {

struct OrbOptions {
  int num_features = 1000;    // keypoints kept per frame after grid distribution
  int fast_threshold = 12;    // FAST corner threshold, grey levels (low: blurred fr1 images)
  int num_levels = 8;         // pyramid levels
  float scale_factor = 1.2f;  // pyramid scale between levels
  int grid_cols = 8;          // grid distribution: cells across the image
  int grid_rows = 6;          // grid distribution: cells down the image
};

struct KeyframeRuleOptions {
  // Paper 004 eq. (6): "effective motion" since the last keyframe.
  double min_rotation_rad = 0.087;  // 5 deg
  double min_translation_m = 0.05;
  // Paper 004 eq. (7): static co-visibility index below which a moving camera needs a keyframe.
  double max_covisibility = 0.60;
  int min_new_points = 15;  // paper 004: new features needed to justify a keyframe
  // Paper 001 sec. 4 / ORB-SLAM: keyframe whenever tracking gets thin, and at least every N frames.
  int min_tracked_points = 120;
  int max_frames_between = 30;
};

struct DynamicOptions {
  bool enabled = true;              // false: no box prior, no geometric test (ablation)
  double epipolar_sigma_px = 1.5;   // d1 normaliser (pixel noise at level 0)
  double depth_sigma_at_1m = 0.01;  // d2 normaliser: sigma_z = this * z^2 (Kinect, m)
  // Paper 004 threshold on D = |d1|/sigma_px + |d2|/sigma_z; a feature in a box of class weight
  // w is dynamic when D > threshold / w (paper 002: stricter test for more dynamic classes).
  double threshold = 6.0;
  double weight_outside_boxes = 0.25;  // w for features outside every box (geometric test only)
  double prior_dynamic_weight = 1.0;   // w >= this: excluded from the first pose estimate
  std::map<std::string, double> class_weights = {{"person", 1.0}};  // config/classes.yaml
};

struct TrackerOptions {
  PinholeCamera camera = PinholeCamera::TumFr1();  // of the pinhole images Track() is given
  // The raw images' lens distortion: the pipeline (RunTrackPipeline, `loci bench track`)
  // removes it with a FrameUndistorter before Track(), detection and streaming.
  LensDistortion distortion = LensDistortion::TumFr1();
  // The colour camera's rolling shutter, us between rows (CameraCalibration::line_time_us; 0:
  // global shutter). The pipeline rectifies each frame with the tracked turn rate before
  // Track() (rolling_shutter.h).
  double line_time_us = kKinectV1LineTimeUs;
  double depth_scale = 5000.0;  // depth PNG units per metre
  double min_depth_m = 0.1;     // valid depth range for 3-D points
  double max_depth_m = 4.0;
  // Depth at a keypoint is used only when its 3x3 neighbours differ by less than this fraction.
  double depth_edge_ratio = 0.03;
  // The pipeline moves each depth image from its own stamp to the colour image's with the
  // constant-velocity motion between them (depth_time_warp.h) when the two stamps differ. Off:
  // on fr1_rpy it left the odometry as it was (ATE 0.0272 -> 0.0270 m) and two desks fused
  // into one table in 4 of 8 object-map runs.
  bool align_depth_time = false;
  OrbOptions orb;
  KeyframeRuleOptions keyframes;
  DynamicOptions dynamic;
  int local_map_keyframes = 30;      // keyframes whose points form the local map
  double search_radius_px = 12.0;    // projection search radius at level 0 (first pass)
  double refine_radius_px = 4.0;     // second pass after the first pose, level 0
  int max_hamming = 64;              // ORB descriptor distance accepted for a match (bits)
  float match_ratio = 0.85f;         // best / second-best distance ratio
  int min_inliers = 20;              // fewer: frame lost, relocalisation
  int lost_frames_before_reset = 5;  // failed relocalisations before a new segment
  double virtual_baseline_m = 0.08;  // RGB-D depth as a virtual stereo residual (ORB-SLAM2)
  // Windowed local bundle adjustment after each keyframe: newest keyframes optimised (0 = off)
  // and Levenberg-Marquardt iterations. Off by default: on fr1_rpy it cost ~50 ms per keyframe
  // and did not lower the ATE (0.029 m with 5 or 10 keyframes vs 0.027 m without).
  int local_ba_keyframes = 0;
  int local_ba_iterations = 5;
  int pnp_iterations = 100;    // PnP-RANSAC iterations
  double pnp_reproj_px = 4.0;  // PnP-RANSAC inlier threshold

  Status Validate() const;
  // Reads the `tracker` node (see config/client.yaml) over the current values.
  Status FromYaml(const YAML::Node& node);
  // The camera, its lens distortion and its line time from one calibration.
  void SetCamera(const CameraCalibration& cal);
  // Reads `dynamic_weight` of config/classes.yaml into dynamic.class_weights.
  Status ClassWeightsFromYaml(const YAML::Node& classes);
};

}  // namespace loci

// Test helper: keyframes of a TUM folder with their ORB features and ground-truth poses.
#pragma once

#include <string>
#include <vector>

#include "common/se3.h"
#include "common/status.h"
#include "server/place/keyframe_features.h"

namespace loci::place::testing {

struct TumKeyframe {
  int index = 0;     // frame number in rgb.txt
  int64_t t_ns = 0;  // rgb stamp
  cv::Mat bgr;
  cv::Mat depth_m;
  KeyframeFeatures features;
  bool has_gt = false;
  // groundtruth.txt pose (T_world_cam of the colour camera's optical frame) of the stamp
  // nearest the rgb stamp (NearestByTime, at most 10 ms away; the mocap runs at 100 Hz).
  SE3d T_world_cam = SE3d::Identity();
  // Rotation speed of the camera from the ground truth 50 ms either side, deg/s (-1 unknown).
  double gt_speed_deg_s = -1;
};

// Every `stride`-th frame of the TUM folder, at most max_frames of them (0 = all), with
// features extracted with `options` and fr1 intrinsics. Keeps the images when keep_images.
StatusOr<std::vector<TumKeyframe>> LoadTumKeyframes(const std::string& dir, int stride,
                                                    int max_frames, const FeatureOptions& options,
                                                    bool keep_images = false);

// Ground-truth T_a_b = T_world_a^-1 * T_world_b.
SE3d GroundTruthT_a_b(const TumKeyframe& a, const TumKeyframe& b);

// The full fr1_rpy (723 frames) from $LOCI_DATA or ../shared/data beside the source tree, or
// "" when absent.
std::string FullFr1RpyDir();

}  // namespace loci::place::testing

// Poses from a TUM trajectory instead of odometry (robots that already run SLAM; tests with
// ground truth). Keyframes follow the motion rule of paper 004 eq. (6) (rotation or translation
// since the last keyframe above the thresholds) plus the max_frames_between rule.
#pragma once

#include <memory>
#include <string>

#include "client/tracking/tracker.h"
#include "common/tum_io.h"

namespace loci {

class PoseSource {
 public:
  static StatusOr<std::unique_ptr<PoseSource>> FromFile(const std::string& path,
                                                        const KeyframeRuleOptions& rules,
                                                        int64_t max_dt_ns = 20'000'000);
  // The pose nearest t_ns (tracked = false when none within max_dt_ns).
  StatusOr<FrameResult> At(int64_t t_ns);

 private:
  Trajectory poses_;
  KeyframeRuleOptions rules_;
  int64_t max_dt_ns_ = 0;
  bool have_kf_ = false;
  SE3d T_odom_lastkf_ = SE3d::Identity();
  int frames_since_kf_ = 0;
};

}  // namespace loci

// Geometric verification of a place-recognition candidate before anything moves:
// ORB matches (ratio test), PnP-RANSAC of keyframe b's 3D points (depth) against keyframe a's
// keypoints, then a 3D-3D check and refinement on the PnP inliers that have depth in both
// keyframes (Umeyama / Kabsch, Eigen::umeyama without scale, iterated on the points that agree
// within max_point_error_m).
#pragma once

#include <string>

#include "common/se3.h"
#include "server/place/keyframe_features.h"
#include "server/place/place_options.h"

namespace loci::place {

struct Verification {
  bool accepted = false;
  std::string reason;  // why it was rejected; empty when accepted
  // p_a = T_a_b * p_b, keyframe b's camera frame into a's; meaningful only when accepted.
  SE3d T_a_b = SE3d::Identity();
  SE3d T_a_b_pnp = SE3d::Identity();  // the PnP estimate, before the 3D-3D refinement
  SE3d T_a_b_3d = SE3d::Identity();   // the 3D-3D (Umeyama) estimate on the 3D inliers
  int matches = 0;                    // descriptor matches passing the ratio test
  int pnp_inliers = 0;                // PnP-RANSAC inliers
  int inliers = 0;                    // 3D-3D inliers of the final T_a_b
  double rms_m = 0;                   // RMS 3D distance of those inliers after alignment, m
  // Share of keyframe a's image covered by the box of the middle 90% of the inliers' pixels.
  double inlier_area = 0;
  // Rotation standard deviation of T_a_b along its weakest direction under the noise model, deg
  // (AlignmentFit::rotation_sigma_rad of the weighted refinement).
  double rotation_sigma_deg = 0;
  double chi2_per_pair = 0;  // the refinement's chi2 / pairs (3 when the noise model holds)
};

// Verifies that keyframes a and b see the same place and estimates T_a_b. Accepted when PnP
// and 3D-3D inliers both reach min_inliers, the 3D RMS is at most max_rms_m and the inliers
// spread over at least min_inlier_area of the image (one poster or one repeated patch is not a
// place).
Verification VerifyPair(const KeyframeFeatures& a, const KeyframeFeatures& b,
                        const VerifyOptions& options);

}  // namespace loci::place

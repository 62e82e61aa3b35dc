// Robust pose refinement: Gauss-Newton over T_cam_world with Huber weights on the reprojection
// error and, for RGB-D observations, the "virtual right image" coordinate u_r = u - bf / z
// (ORB-SLAM2), which turns the measured depth into a pixel-scaled residual. Outliers are
// re-classified between rounds with chi-square gates (95 %, 2 / 3 degrees of freedom).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/camera.h"
#include "common/se3.h"

namespace loci {

struct PoseObservation {
  Vec3d p_world;            // the map point (m, world frame)
  Eigen::Vector2d uv_px;    // measured pixel
  double ur_px = -1;        // measured virtual right coordinate; < 0: no depth
  double inv_sigma2 = 1.0;  // 1 / sigma^2 of the keypoint's pyramid level (px^-2)
};

struct PoseRefineResult {
  SE3d T_cam_world;
  std::vector<char> inlier;  // per observation
  int num_inliers = 0;
};

// bf_px = fx * virtual baseline (m). rounds x iterations Gauss-Newton steps.
PoseRefineResult RefinePose(const PinholeCamera& cam, double bf_px,
                            const std::vector<PoseObservation>& obs, const SE3d& T_cam_world_init,
                            int rounds = 4, int iterations = 10);

// Applies the left perturbation exp([w; v]) to T (rotation w in rad, translation v in m).
SE3d ExpLeft(const Eigen::Matrix<double, 6, 1>& xi, const SE3d& T);

}  // namespace loci

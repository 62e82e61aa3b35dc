// Dynamic-feature suppression (papers 002 sec. 3.2 and 004 sec. III.C).
// 1. Semantic prior: each keypoint gets the dynamic weight w of the detection box (or mask)
//    containing it (class weights from config/classes.yaml; -1 outside every box).
// 2. Geometric test of a matched feature, with the pose estimated from features that are not
//    prior-dynamic: the epipolar distance d1 (px) of its pixel to the epipolar line of its
//    previous observation (F = K^-T [t]x R K^-1 of the relative pose, i.e. the fundamental
//    matrix of the static features) and the depth error d2 = Z - Z' (m) between the map
//    point's predicted depth and the measured one. D = |d1| / sigma_px + |d2| / sigma_z(Z);
//    dynamic when D > threshold / w.
#pragma once

#include <vector>

#include "client/tracking/orb_frame.h"
#include "client/tracking/tracker_options.h"
#include "common/detections_io.h"
#include "common/se3.h"

namespace loci {

class DynamicFilter {
 public:
  explicit DynamicFilter(const TrackerOptions& options) : opt_(options) {}

  // Weight of a class name (0 when not listed).
  double ClassWeight(const std::string& class_name) const;
  // Fills frame->class_weight from the detections (max weight over the boxes containing it).
  void AssignWeights(const std::vector<Detection2D>& detections, OrbFrame* frame) const;
  // True when a keypoint must stay out of the first pose estimate.
  bool IsPriorDynamic(float weight) const {
    return opt_.dynamic.enabled && weight >= opt_.dynamic.prior_dynamic_weight;
  }

  // Paper 004's dynamic value D of one matched feature. uv_px: its pixel now; depth_m: measured
  // depth now (0 = none); p_world: its map point; T_cam_world: the current pose estimate;
  // prev_uv_px / T_world_prevcam: its previous observation (has_prev false: depth term only).
  double DynamicValue(const Eigen::Vector2d& uv_px, double depth_m, const Vec3d& p_world,
                      const SE3d& T_cam_world, bool has_prev, const Eigen::Vector2d& prev_uv_px,
                      const SE3d& T_world_prevcam) const;
  // Threshold on D for a feature of weight w (w < 0: outside every box).
  double Threshold(float weight) const;

 private:
  TrackerOptions opt_;
};

}  // namespace loci

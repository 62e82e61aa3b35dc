#include "client/tracking/tracker_options.h"

#include "common/config.h"

namespace loci {

// The keys FromYaml reads, per section (CheckKnownKeys warns about any other).
constexpr const char* kTrackerKeys[] = {"depth_scale",
                                        "min_depth_m",
                                        "max_depth_m",
                                        "depth_edge_ratio",
                                        "align_depth_time",
                                        "local_map_keyframes",
                                        "search_radius_px",
                                        "refine_radius_px",
                                        "max_hamming",
                                        "match_ratio",
                                        "min_inliers",
                                        "lost_frames_before_reset",
                                        "virtual_baseline_m",
                                        "local_ba_keyframes",
                                        "local_ba_iterations",
                                        "pnp_iterations",
                                        "pnp_reproj_px",
                                        "camera",
                                        "orb",
                                        "keyframes",
                                        "dynamic"};
constexpr const char* kOrbKeys[] = {"num_features", "fast_threshold", "num_levels",
                                    "scale_factor", "grid_cols",      "grid_rows"};
constexpr const char* kKeyframeKeys[] = {"min_rotation_rad",   "min_translation_m",
                                         "max_covisibility",   "min_new_points",
                                         "min_tracked_points", "max_frames_between"};
constexpr const char* kDynamicKeys[] = {
    "enabled",   "epipolar_sigma_px",    "depth_sigma_at_1m",
    "threshold", "weight_outside_boxes", "prior_dynamic_weight"};

Status TrackerOptions::Validate() const {
  LOCI_RETURN_IF_ERROR(camera.Validate());
  LOCI_RETURN_IF_ERROR(distortion.Validate(camera));
  if (!(depth_scale > 0)) return absl::InvalidArgumentError("depth_scale must be > 0");
  if (!(min_depth_m > 0 && max_depth_m > min_depth_m)) {
    return absl::InvalidArgumentError("need 0 < min_depth_m < max_depth_m");
  }
  if (orb.num_features < 50 || orb.num_levels < 1 || orb.scale_factor <= 1.f || orb.grid_cols < 1 ||
      orb.grid_rows < 1 || orb.fast_threshold < 1) {
    return absl::InvalidArgumentError("orb options out of range");
  }
  if (local_map_keyframes < 1 || min_inliers < 6 || search_radius_px <= 0 ||
      refine_radius_px <= 0 || max_hamming <= 0 || match_ratio <= 0 || match_ratio > 1) {
    return absl::InvalidArgumentError("tracker matching options out of range");
  }
  if (dynamic.threshold <= 0 || dynamic.epipolar_sigma_px <= 0 || dynamic.depth_sigma_at_1m <= 0 ||
      dynamic.weight_outside_boxes < 0) {
    return absl::InvalidArgumentError("dynamic options out of range");
  }
  return absl::OkStatus();
}

void TrackerOptions::SetCamera(const CameraCalibration& cal) {
  camera = cal.intrinsics;
  distortion = cal.distortion;
  line_time_us = cal.line_time_us;
}

Status TrackerOptions::FromYaml(const YAML::Node& n) {
  if (!n) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(n, "tracker", kTrackerKeys));
  if (n["camera"]) {
    LOCI_ASSIGN_OR_RETURN(const CameraCalibration cal, CameraFromYaml(n["camera"]));
    SetCamera(cal);
  }
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "depth_scale", &depth_scale));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_depth_m", &min_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_depth_m", &max_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "depth_edge_ratio", &depth_edge_ratio));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "align_depth_time", &align_depth_time));
  const YAML::Node o = n["orb"];
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(o, "tracker.orb", kOrbKeys));
  LOCI_RETURN_IF_ERROR(ReadOptional(o, "num_features", &orb.num_features));
  LOCI_RETURN_IF_ERROR(ReadOptional(o, "fast_threshold", &orb.fast_threshold));
  LOCI_RETURN_IF_ERROR(ReadOptional(o, "num_levels", &orb.num_levels));
  LOCI_RETURN_IF_ERROR(ReadOptional(o, "scale_factor", &orb.scale_factor));
  LOCI_RETURN_IF_ERROR(ReadOptional(o, "grid_cols", &orb.grid_cols));
  LOCI_RETURN_IF_ERROR(ReadOptional(o, "grid_rows", &orb.grid_rows));
  const YAML::Node k = n["keyframes"];
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(k, "tracker.keyframes", kKeyframeKeys));
  LOCI_RETURN_IF_ERROR(ReadOptional(k, "min_rotation_rad", &keyframes.min_rotation_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(k, "min_translation_m", &keyframes.min_translation_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(k, "max_covisibility", &keyframes.max_covisibility));
  LOCI_RETURN_IF_ERROR(ReadOptional(k, "min_new_points", &keyframes.min_new_points));
  LOCI_RETURN_IF_ERROR(ReadOptional(k, "min_tracked_points", &keyframes.min_tracked_points));
  LOCI_RETURN_IF_ERROR(ReadOptional(k, "max_frames_between", &keyframes.max_frames_between));
  const YAML::Node d = n["dynamic"];
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(d, "tracker.dynamic", kDynamicKeys));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "enabled", &dynamic.enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "epipolar_sigma_px", &dynamic.epipolar_sigma_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "depth_sigma_at_1m", &dynamic.depth_sigma_at_1m));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "threshold", &dynamic.threshold));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "weight_outside_boxes", &dynamic.weight_outside_boxes));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "prior_dynamic_weight", &dynamic.prior_dynamic_weight));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "local_map_keyframes", &local_map_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "search_radius_px", &search_radius_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "refine_radius_px", &refine_radius_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_hamming", &max_hamming));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "match_ratio", &match_ratio));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_inliers", &min_inliers));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "lost_frames_before_reset", &lost_frames_before_reset));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "virtual_baseline_m", &virtual_baseline_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "local_ba_keyframes", &local_ba_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "local_ba_iterations", &local_ba_iterations));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pnp_iterations", &pnp_iterations));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pnp_reproj_px", &pnp_reproj_px));
  return Validate();
}

Status TrackerOptions::ClassWeightsFromYaml(const YAML::Node& classes) {
  const YAML::Node w = classes["dynamic_weight"];
  if (!w) return absl::OkStatus();
  if (!w.IsMap()) return absl::InvalidArgumentError("dynamic_weight must be a map");
  dynamic.class_weights.clear();
  try {
    for (const auto& kv : w) {
      dynamic.class_weights[kv.first.as<std::string>()] = kv.second.as<double>();
    }
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("dynamic_weight: ", e.what()));
  }
  return absl::OkStatus();
}

}  // namespace loci

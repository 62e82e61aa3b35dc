#include "server/graph/graph_options.h"

#include "common/config.h"

namespace loci::server {
namespace {

// The keys FromYaml reads, per section (a key added there belongs here too).
Status CheckGraphKeys(const YAML::Node& node) {
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node, "graph",
      {"odometry", "pcm", "loss", "landmarks", "solver", "dof", "gravity", "reference_robot",
       "place_trans_m", "place_rot_rad", "moved_trans_m", "moved_rot_rad"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node["odometry"], "graph.odometry",
                                      {"sigma_trans_m", "sigma_trans_per_m", "sigma_rot_rad",
                                       "sigma_rot_per_rad", "full_quality_inliers",
                                       "min_quality", "local_map_keyframes"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node["pcm"], "graph.pcm",
                                      {"enabled", "chi2_threshold", "min_set_size", "residual_chi2"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node["loss"], "graph.loss", {"type", "scale"}));
  LOCI_RETURN_IF_ERROR(
      CheckKnownKeys(node["gravity"], "graph.gravity", {"sigma_rad", "loss_scale"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node["landmarks"], "graph.landmarks",
                                      {"enabled", "sigma_m", "huber_m", "min_observations",
                                       "max_object_size_m"}));
  return CheckKnownKeys(node["solver"], "graph.solver",
                        {"max_iterations", "threads", "function_tolerance"});
}

Status ReadOdometry(const YAML::Node& n, OdometryInformationOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sigma_trans_m", &o->sigma_trans_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sigma_trans_per_m", &o->sigma_trans_per_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sigma_rot_rad", &o->sigma_rot_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sigma_rot_per_rad", &o->sigma_rot_per_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "full_quality_inliers", &o->full_quality_inliers));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "local_map_keyframes", &o->local_map_keyframes));
  return ReadOptional(n, "min_quality", &o->min_quality);
}

Status ReadSections(const YAML::Node& node, GraphOptions* g) {
  LOCI_RETURN_IF_ERROR(ReadOdometry(node["odometry"], &g->odometry));
  const YAML::Node pcm = node["pcm"];
  LOCI_RETURN_IF_ERROR(ReadOptional(pcm, "enabled", &g->pcm.enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(pcm, "chi2_threshold", &g->pcm.chi2_threshold));
  LOCI_RETURN_IF_ERROR(ReadOptional(pcm, "min_set_size", &g->pcm.min_set_size));
  LOCI_RETURN_IF_ERROR(ReadOptional(pcm, "residual_chi2", &g->pcm.residual_chi2));
  LOCI_RETURN_IF_ERROR(ReadOptional(node["loss"], "type", &g->loss.type));
  LOCI_RETURN_IF_ERROR(ReadOptional(node["loss"], "scale", &g->loss.scale));
  LOCI_RETURN_IF_ERROR(ReadOptional(node["gravity"], "sigma_rad", &g->gravity.sigma_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(node["gravity"], "loss_scale", &g->gravity.loss_scale));
  const YAML::Node lm = node["landmarks"];
  LOCI_RETURN_IF_ERROR(ReadOptional(lm, "enabled", &g->landmarks.enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(lm, "sigma_m", &g->landmarks.sigma_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(lm, "huber_m", &g->landmarks.huber_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(lm, "min_observations", &g->landmarks.min_observations));
  LOCI_RETURN_IF_ERROR(ReadOptional(lm, "max_object_size_m", &g->landmarks.max_object_size_m));
  const YAML::Node solver = node["solver"];
  LOCI_RETURN_IF_ERROR(ReadOptional(solver, "max_iterations", &g->solver.max_iterations));
  LOCI_RETURN_IF_ERROR(ReadOptional(solver, "threads", &g->solver.threads));
  return ReadOptional(solver, "function_tolerance", &g->solver.function_tolerance);
}

Status Bad(const char* what) {
  return absl::InvalidArgumentError(absl::StrCat("graph options: ", what));
}

Status ValidateOdometry(const OdometryInformationOptions& o) {
  if (!(o.sigma_trans_m > 0) || !(o.sigma_rot_rad > 0)) {
    return Bad("odometry.sigma_trans_m and odometry.sigma_rot_rad must be > 0");
  }
  if (!(o.sigma_trans_per_m >= 0) || !(o.sigma_rot_per_rad >= 0)) {
    return Bad("odometry.sigma_trans_per_m and odometry.sigma_rot_per_rad must be >= 0");
  }
  if (o.full_quality_inliers < 1) return Bad("odometry.full_quality_inliers >= 1");
  if (o.local_map_keyframes < 0) return Bad("odometry.local_map_keyframes >= 0");
  if (!(o.min_quality > 0 && o.min_quality <= 1)) return Bad("odometry.min_quality in (0, 1]");
  return absl::OkStatus();
}

}  // namespace

Status GraphOptions::FromYaml(const YAML::Node& node) {
  if (!node) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckGraphKeys(node));
  LOCI_RETURN_IF_ERROR(ReadSections(node, this));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "dof", &dof));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "reference_robot", &reference_robot));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "place_trans_m", &place_trans_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "place_rot_rad", &place_rot_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "moved_trans_m", &moved_trans_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "moved_rot_rad", &moved_rot_rad));
  return Validate();
}

Status GraphOptions::Validate() const {
  LOCI_RETURN_IF_ERROR(ValidateOdometry(odometry));
  if (!(pcm.chi2_threshold > 0)) return Bad("pcm.chi2_threshold > 0");
  if (pcm.min_set_size < 1) return Bad("pcm.min_set_size >= 1");
  if (!(pcm.residual_chi2 >= 0)) return Bad("pcm.residual_chi2 >= 0 (0 = off)");
  if (loss.type != "huber" && loss.type != "cauchy" && loss.type != "none") {
    return Bad("loss.type is huber, cauchy or none");
  }
  if (!(loss.scale > 0)) return Bad("loss.scale > 0");
  if (!(gravity.sigma_rad >= 0 && gravity.sigma_rad < 1) || !(gravity.loss_scale > 0)) {
    return Bad("gravity.sigma_rad in [0, 1) and gravity.loss_scale > 0");
  }
  if (!(landmarks.sigma_m > 0) || !(landmarks.huber_m > 0)) {
    return Bad("landmarks.sigma_m and landmarks.huber_m must be > 0");
  }
  if (landmarks.min_observations < 1) return Bad("landmarks.min_observations >= 1");
  if (!(landmarks.max_object_size_m > 0)) return Bad("landmarks.max_object_size_m must be > 0");
  if (solver.max_iterations < 1 || solver.threads < 1) {
    return Bad("solver.max_iterations and solver.threads must be >= 1");
  }
  if (!(solver.function_tolerance > 0)) return Bad("solver.function_tolerance > 0");
  if (dof != "auto" && dof != "4dof" && dof != "6dof") return Bad("dof is auto, 4dof or 6dof");
  if (!(place_trans_m >= 0) || !(place_rot_rad >= 0)) {
    return Bad("place_trans_m and place_rot_rad must be >= 0");
  }
  if (!(moved_trans_m >= 0) || !(moved_rot_rad >= 0)) {
    return Bad("moved_trans_m and moved_rot_rad must be >= 0");
  }
  return absl::OkStatus();
}

}  // namespace loci::server

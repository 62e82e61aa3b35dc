#include "server/align/align_options.h"

#include "common/config.h"

namespace loci::server {

Status AlignOptions::FromYaml(const YAML::Node& node) {
  if (!node) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node, "align", {"enabled", "max_verify", "level_with_gravity", "min_gravity_keyframes",
                 "refine_max_matches", "held_chunk_keyframes", "island_octomap",
                 "query_ahead_backlog", "loops"}));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "enabled", &enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_verify", &max_verify));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "level_with_gravity", &level_with_gravity));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_gravity_keyframes", &min_gravity_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "refine_max_matches", &refine_max_matches));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "held_chunk_keyframes", &held_chunk_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "island_octomap", &island_octomap));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "query_ahead_backlog", &query_ahead_backlog));
  LOCI_RETURN_IF_ERROR(loops.FromYaml(node["loops"]));
  return Validate();
}

Status LoopOptions::FromYaml(const YAML::Node& node) {
  if (!node) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node, "align.loops",
                                      {"enabled", "min_gap_s", "sigma_trans_m", "sigma_rot_rad",
                                       "optimize_every_edges", "optimize_min_keyframes",
                                       "optimize_growth", "apply_chunk_keyframes",
                                       "island_max_verify"}));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "enabled", &enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_gap_s", &min_gap_s));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "sigma_trans_m", &sigma_trans_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "sigma_rot_rad", &sigma_rot_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "optimize_every_edges", &optimize_every_edges));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "optimize_min_keyframes", &optimize_min_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "optimize_growth", &optimize_growth));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "apply_chunk_keyframes", &apply_chunk_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "island_max_verify", &island_max_verify));
  return Validate();
}

Status LoopOptions::Validate() const {
  if (!(min_gap_s >= 0)) return absl::InvalidArgumentError("align.loops.min_gap_s must be >= 0");
  if (!(sigma_trans_m > 0) || !(sigma_rot_rad > 0)) {
    return absl::InvalidArgumentError("align.loops.sigma_trans_m and sigma_rot_rad must be > 0");
  }
  if (optimize_every_edges < 1 || optimize_min_keyframes < 0) {
    return absl::InvalidArgumentError(
        "align.loops.optimize_every_edges must be >= 1 and optimize_min_keyframes >= 0");
  }
  if (!(optimize_growth >= 0 && optimize_growth <= 1)) {
    return absl::InvalidArgumentError("align.loops.optimize_growth must be in [0, 1]");
  }
  if (apply_chunk_keyframes < 0) {
    return absl::InvalidArgumentError("align.loops.apply_chunk_keyframes must be >= 0");
  }
  if (island_max_verify < 0 || island_max_verify > 50) {
    return absl::InvalidArgumentError("align.loops.island_max_verify must be in [0, 50]");
  }
  return absl::OkStatus();
}

Status AlignOptions::Validate() const {
  if (max_verify < 1 || max_verify > 50) {
    return absl::InvalidArgumentError("align.max_verify must be in [1, 50]");
  }
  if (min_gravity_keyframes < 1) {
    return absl::InvalidArgumentError("align.min_gravity_keyframes must be >= 1");
  }
  LOCI_RETURN_IF_ERROR(loops.Validate());
  if (refine_max_matches < 0) {
    return absl::InvalidArgumentError("align.refine_max_matches must be >= 0 (0 = off)");
  }
  if (query_ahead_backlog < 0) {
    return absl::InvalidArgumentError("align.query_ahead_backlog must be >= 0 (0 = off)");
  }
  if (held_chunk_keyframes < 0) {
    return absl::InvalidArgumentError("align.held_chunk_keyframes must be >= 0 (0 = all at once)");
  }
  return absl::OkStatus();
}

}  // namespace loci::server

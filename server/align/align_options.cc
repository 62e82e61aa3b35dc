#include "server/align/align_options.h"

#include "common/config.h"

namespace loci::server {

Status AlignOptions::FromYaml(const YAML::Node& node) {
  if (!node) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node, "align", {"enabled", "max_verify", "level_with_gravity", "min_gravity_keyframes",
                 "refine_max_matches"}));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "enabled", &enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_verify", &max_verify));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "level_with_gravity", &level_with_gravity));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_gravity_keyframes", &min_gravity_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "refine_max_matches", &refine_max_matches));
  return Validate();
}

Status AlignOptions::Validate() const {
  if (max_verify < 1 || max_verify > 50) {
    return absl::InvalidArgumentError("align.max_verify must be in [1, 50]");
  }
  if (min_gravity_keyframes < 1) {
    return absl::InvalidArgumentError("align.min_gravity_keyframes must be >= 1");
  }
  if (refine_max_matches < 0) {
    return absl::InvalidArgumentError("align.refine_max_matches must be >= 0 (0 = off)");
  }
  return absl::OkStatus();
}

}  // namespace loci::server

#include "server/place/place_options.h"

#include "common/config.h"

namespace loci::place {
namespace {

// Raised whenever ExtractFeatures (keyframe_features.cc) changes what it extracts.
constexpr int kFeaturesVersion = 1;

Status CheckPlaceKeys(const YAML::Node& node) {
  LOCI_RETURN_IF_ERROR(
      CheckKnownKeys(node, "place", {"features", "vocabulary", "query", "verify", "consistency",
                                     "dense"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node["dense"], "place.dense",
      {"enabled", "scale", "levels", "min_depth_m", "max_depth_m", "max_depth_diff_m",
       "max_correction_m", "max_correction_rad", "max_per_keyframe", "cache_keyframes"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node["features"], "place.features",
      {"max_features", "scale_factor", "levels", "fast_threshold", "min_depth_m", "max_depth_m",
       "cache_keyframes"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node["vocabulary"], "place.vocabulary",
      {"word_max_hamming", "branching", "max_leaf_words", "max_depth", "search_leaves"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node["query"], "place.query",
                                      {"max_candidates", "exclude_recent_keyframes", "min_score",
                                       "older_candidates", "older_than_keyframes"}));
  LOCI_RETURN_IF_ERROR(
      CheckKnownKeys(node["verify"], "place.verify",
                     {"ratio", "max_hamming", "pnp_reprojection_px", "pnp_iterations",
                      "pnp_confidence", "max_point_error_m", "min_inliers", "max_rms_m",
                      "min_inlier_area", "pixel_sigma_px", "depth_sigma_m_per_m2"}));
  return CheckKnownKeys(node["consistency"], "place.consistency",
                        {"min_matches", "max_translation_m", "max_rotation_deg"});
}

Status ReadFeatures(const YAML::Node& n, FeatureOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_features", &o->max_features));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "scale_factor", &o->scale_factor));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "levels", &o->levels));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "fast_threshold", &o->fast_threshold));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_depth_m", &o->min_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "cache_keyframes", &o->cache_keyframes));
  return ReadOptional(n, "max_depth_m", &o->max_depth_m);
}

Status ReadVocabulary(const YAML::Node& n, VocabularyOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "word_max_hamming", &o->word_max_hamming));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "branching", &o->branching));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_leaf_words", &o->max_leaf_words));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "search_leaves", &o->search_leaves));
  return ReadOptional(n, "max_depth", &o->max_depth);
}

Status ReadQuery(const YAML::Node& n, QueryOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_candidates", &o->max_candidates));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "exclude_recent_keyframes", &o->exclude_recent_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "older_candidates", &o->older_candidates));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "older_than_keyframes", &o->older_than_keyframes));
  return ReadOptional(n, "min_score", &o->min_score);
}

Status ReadVerify(const YAML::Node& n, VerifyOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "ratio", &o->ratio));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_hamming", &o->max_hamming));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pnp_reprojection_px", &o->pnp_reprojection_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pnp_iterations", &o->pnp_iterations));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pnp_confidence", &o->pnp_confidence));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_point_error_m", &o->max_point_error_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_inliers", &o->min_inliers));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pixel_sigma_px", &o->pixel_sigma_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "depth_sigma_m_per_m2", &o->depth_sigma_m_per_m2));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_inlier_area", &o->min_inlier_area));
  return ReadOptional(n, "max_rms_m", &o->max_rms_m);
}

Status ReadConsistency(const YAML::Node& n, ConsistencyOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_matches", &o->min_matches));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_translation_m", &o->max_translation_m));
  return ReadOptional(n, "max_rotation_deg", &o->max_rotation_deg);
}

Status ReadDense(const YAML::Node& n, DenseOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "enabled", &o->enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "scale", &o->scale));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "levels", &o->levels));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_depth_m", &o->min_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_depth_m", &o->max_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_depth_diff_m", &o->max_depth_diff_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_correction_m", &o->max_correction_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_correction_rad", &o->max_correction_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_per_keyframe", &o->max_per_keyframe));
  return ReadOptional(n, "cache_keyframes", &o->cache_keyframes);
}

Status Bad(const char* what) {
  return absl::InvalidArgumentError(absl::StrCat("place options: ", what));
}

Status ValidateDense(const DenseOptions& d) {
  if (!(d.scale >= 0.1 && d.scale <= 1)) return Bad("dense.scale in [0.1, 1]");
  if (d.levels < 1 || d.levels > 4) return Bad("dense.levels in [1, 4]");
  if (!(d.min_depth_m > 0 && d.max_depth_m > d.min_depth_m)) {
    return Bad("dense: 0 < min_depth_m < max_depth_m");
  }
  if (!(d.max_depth_diff_m > 0) || !(d.max_correction_m > 0) || !(d.max_correction_rad > 0)) {
    return Bad("dense.max_depth_diff_m, max_correction_m and max_correction_rad > 0");
  }
  if (d.cache_keyframes < 1) return Bad("dense.cache_keyframes >= 1");
  if (d.max_per_keyframe < 0) return Bad("dense.max_per_keyframe >= 0");
  return absl::OkStatus();
}

Status ValidateFeatures(const FeatureOptions& f) {
  if (f.max_features < 10 || f.max_features > 20000)
    return Bad("features.max_features in [10, 20000]");
  if (!(f.scale_factor > 1.0 && f.scale_factor <= 2.0))
    return Bad("features.scale_factor in (1, 2]");
  if (f.levels < 1 || f.levels > 16) return Bad("features.levels in [1, 16]");
  if (f.fast_threshold < 1 || f.fast_threshold > 255)
    return Bad("features.fast_threshold in [1, 255]");
  if (!(f.min_depth_m >= 0 && f.max_depth_m > f.min_depth_m)) {
    return Bad("features: 0 <= min_depth_m < max_depth_m");
  }
  if (f.cache_keyframes < 1 || f.cache_keyframes > 1000000) {
    return Bad("features.cache_keyframes in [1, 1000000]");
  }
  return absl::OkStatus();
}

Status ValidateVocabulary(const VocabularyOptions& v) {
  if (v.word_max_hamming < 0 || v.word_max_hamming > 128) {
    return Bad("vocabulary.word_max_hamming in [0, 128]");
  }
  if (v.branching < 2 || v.branching > 64) return Bad("vocabulary.branching in [2, 64]");
  if (v.max_leaf_words < v.branching || v.max_leaf_words > 4096) {
    return Bad("vocabulary.max_leaf_words in [branching, 4096]");
  }
  if (v.max_depth < 1 || v.max_depth > 64) return Bad("vocabulary.max_depth in [1, 64]");
  if (v.search_leaves < 1 || v.search_leaves > kMaxSearchLeaves)
    return Bad("vocabulary.search_leaves in [1, 256]");
  static_assert(kMaxSearchLeaves == 256, "the message above names the bound");
  return absl::OkStatus();
}

Status ValidateVerify(const VerifyOptions& v) {
  if (!(v.ratio > 0 && v.ratio <= 1)) return Bad("verify.ratio in (0, 1]");
  if (v.max_hamming < 0 || v.max_hamming > 256) return Bad("verify.max_hamming in [0, 256]");
  if (!(v.pnp_reprojection_px > 0)) return Bad("verify.pnp_reprojection_px > 0");
  if (v.pnp_iterations < 1) return Bad("verify.pnp_iterations >= 1");
  if (!(v.pnp_confidence > 0 && v.pnp_confidence < 1))
    return Bad("verify.pnp_confidence in (0, 1)");
  if (!(v.max_point_error_m > 0)) return Bad("verify.max_point_error_m > 0");
  if (v.min_inliers < 6) return Bad("verify.min_inliers >= 6");
  if (!(v.max_rms_m > 0)) return Bad("verify.max_rms_m > 0");
  if (!(v.min_inlier_area >= 0 && v.min_inlier_area < 1))
    return Bad("verify.min_inlier_area in [0, 1)");
  if (!(v.pixel_sigma_px > 0) || !(v.depth_sigma_m_per_m2 > 0)) {
    return Bad("verify.pixel_sigma_px and depth_sigma_m_per_m2 > 0");
  }
  return absl::OkStatus();
}

}  // namespace

Status PlaceOptions::FromYaml(const YAML::Node& node) {
  if (!node) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckPlaceKeys(node));
  LOCI_RETURN_IF_ERROR(ReadFeatures(node["features"], &features));
  LOCI_RETURN_IF_ERROR(ReadVocabulary(node["vocabulary"], &vocabulary));
  LOCI_RETURN_IF_ERROR(ReadQuery(node["query"], &query));
  LOCI_RETURN_IF_ERROR(ReadVerify(node["verify"], &verify));
  LOCI_RETURN_IF_ERROR(ReadConsistency(node["consistency"], &consistency));
  LOCI_RETURN_IF_ERROR(ReadDense(node["dense"], &dense));
  return Validate();
}

std::string FeatureOptions::Fingerprint() const {
  return absl::StrCat("orb", kFeaturesVersion, "/", max_features, "/", scale_factor, "/", levels,
                      "/", fast_threshold, "/", min_depth_m, "/", max_depth_m);
}

Status PlaceOptions::Validate() const {
  LOCI_RETURN_IF_ERROR(ValidateFeatures(features));
  LOCI_RETURN_IF_ERROR(ValidateVocabulary(vocabulary));
  if (query.max_candidates < 1 || query.max_candidates > 1000) {
    return Bad("query.max_candidates in [1, 1000]");
  }
  if (query.exclude_recent_keyframes < 0) return Bad("query.exclude_recent_keyframes >= 0");
  if (!(query.min_score >= 0 && query.min_score < 1)) return Bad("query.min_score in [0, 1)");
  if (query.older_candidates < 0 || query.older_candidates > 1000) {
    return Bad("query.older_candidates in [0, 1000]");
  }
  if (query.older_than_keyframes < 0) return Bad("query.older_than_keyframes >= 0");
  LOCI_RETURN_IF_ERROR(ValidateVerify(verify));
  if (consistency.min_matches < 1) return Bad("consistency.min_matches >= 1");
  if (!(consistency.max_translation_m > 0) || !(consistency.max_rotation_deg > 0)) {
    return Bad("consistency.max_translation_m and max_rotation_deg > 0");
  }
  return ValidateDense(dense);
}

}  // namespace loci::place

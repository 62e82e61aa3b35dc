#include "server/map/map_options.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "common/config.h"

namespace loci::server {
namespace {

// The keys FromYaml reads, per section (a key added there belongs here too).
// clang-format off
constexpr const char* kFusionKeys[] = {
    "max_centroid_distance_m", "centroid_from_box", "min_overlap",          "support_cell_m",
    "min_support_fraction",    "overlap_voxel_m",   "weight_track",         "weight_centroid",
    "weight_overlap",          "score_threshold",   "track_gate_m",         "confirm_observations",
    "merge_centroid_m",        "merge_containment", "merge_across_classes", "assoc_containment",
    "max_size_ratio",          "label_universe",    "min_likelihood",       "existence_p_real",
    "existence_p_false",       "confirm_llr",       "remove_llr",           "visibility",
    "centroid_min_part",       "class_size_slack",  "merge_box_containment", "bottom_quantile",
    "merge_sigmas",            "depth_sigma_at_1m", "view_sigma_rad",       "shape_min_label_views",
    "existence_class_prior_views", "confirm_min_span_s", "straddle_share",
    "straddle_apart_views", "straddle_pieces", "furniture_merge_containment",
    "furniture_footprint_containment",
    "top_load_reach_m", "top_load_max_gap_m", "top_load_max_sink_m", "top_load_rival_min_views",
    "top_load_confirm_loads", "top_load_floor_classes", "top_load_lower_loads",
    "part_containment", "never_part_of", "stand_classes", "stand_height_m"};
// clang-format on

Status CheckMapKeys(const YAML::Node& node) {
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node, "map",
      {"dynamic_classes", "mapped_classes", "cloud", "observation", "fusion", "frame", "octomap"}));
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node["cloud"], "map.cloud",
      {"min_depth_m", "max_depth_m", "pixel_stride", "voxel_m", "sor_mean_k", "sor_stddev_mul"}));
  LOCI_RETURN_IF_ERROR(
      CheckKnownKeys(node["observation"], "map.observation",
                     {"min_score", "mask", "voxel_m", "max_points", "sor_mean_k", "sor_stddev_mul",
                      "sor_min_voxels", "min_points", "min_box_px", "max_object_depth_m",
                      "min_centre_cover", "support_tops"}));
  if (const YAML::Node observation = node["observation"]) {
    LOCI_RETURN_IF_ERROR(
        CheckKnownKeys(observation["support_tops"], "map.observation.support_tops",
                       {"enabled", "cell_m", "max_tilt_deg", "min_top_area_m2", "reach_m",
                        "max_planes", "ransac_iterations", "cell_band_share"}));
  }
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node["fusion"], "map.fusion", kFusionKeys));
  if (const YAML::Node fusion = node["fusion"]) {
    LOCI_RETURN_IF_ERROR(
        CheckKnownKeys(fusion["visibility"], "map.fusion.visibility",
                       {"min_visible_fraction", "occlusion_tol_m", "occlusion_tol_rel", "border_px",
                        "min_projected_px", "max_depth_m", "excuse_iou", "depth_stride"}));
  }
  LOCI_RETURN_IF_ERROR(
      CheckKnownKeys(node["frame"], "map.frame", {"settle_keyframes", "plane_refine_max_deg"}));
  return CheckKnownKeys(node["octomap"], "map.octomap",
                        {"enabled", "resolution_m", "max_range_m", "ray_voxel_m"});
}

// FNV-1a, 64 bit, as 16 hex digits: a stable digest (std::hash and absl::Hash are seeded or
// unspecified across builds).
std::string Fnv1aHex(const std::string& text) {
  uint64_t h = 14695981039346656037ULL;
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  char out[17];
  std::snprintf(out, sizeof(out), "%016llx", static_cast<unsigned long long>(h));
  return out;
}

// "key:\n<yaml>\n" for a present key, "" for an absent one (defaults: kMapCodeVersion).
std::string DumpKey(const YAML::Node& node, const char* key) {
  const YAML::Node value = node[key];
  return value ? absl::StrCat(key, ":\n", YAML::Dump(value), "\n") : std::string();
}

}  // namespace

std::string MapOptions::ProductsFingerprint() const {
  return Fnv1aHex(absl::StrCat("v", kMapCodeVersion, " stride ", fusion.visibility.depth_stride,
                               "\n", products_yaml_));
}

std::string MapOptions::MapFingerprint() const {
  return Fnv1aHex(absl::StrCat(ProductsFingerprint(), "\n", map_yaml_));
}

Status MapOptions::FromYaml(const YAML::Node& node) {
  if (!node) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(CheckMapKeys(node));
  products_yaml_ += DumpKey(node, "cloud") + DumpKey(node, "observation") +
                    DumpKey(node, "dynamic_classes") + DumpKey(node, "mapped_classes");
  map_yaml_ += YAML::Dump(node) + "\n";
  if (const YAML::Node n = node["cloud"]) {
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_depth_m", &cloud.min_depth_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_depth_m", &cloud.max_depth_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "pixel_stride", &cloud.pixel_stride));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "voxel_m", &cloud.voxel_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_mean_k", &cloud.sor_mean_k));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_stddev_mul", &cloud.sor_stddev_mul));
  }
  if (const YAML::Node n = node["observation"]) {
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_score", &observation.min_score));
    if (n["mask"]) {
      LOCI_ASSIGN_OR_RETURN(observation.mask, detection::MaskOptions::FromYaml(n["mask"]));
    }
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "voxel_m", &observation.voxel_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_points", &observation.max_points));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_mean_k", &observation.sor_mean_k));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_stddev_mul", &observation.sor_stddev_mul));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_min_voxels", &observation.sor_min_voxels));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_points", &observation.min_points));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_box_px", &observation.min_box_px));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_object_depth_m", &observation.max_object_depth_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_centre_cover", &observation.min_centre_cover));
    if (const YAML::Node t = n["support_tops"]) {
      SupportTopsOptions& o = observation.support_tops;
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "enabled", &o.enabled));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "cell_m", &o.cell_m));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "max_tilt_deg", &o.max_tilt_deg));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "min_top_area_m2", &o.min_top_area_m2));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "reach_m", &o.reach_m));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "max_planes", &o.max_planes));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "ransac_iterations", &o.ransac_iterations));
      LOCI_RETURN_IF_ERROR(ReadOptional(t, "cell_band_share", &o.cell_band_share));
    }
  }
  if (const YAML::Node n = node["fusion"]) {
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "max_centroid_distance_m", &fusion.max_centroid_distance_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "centroid_from_box", &fusion.centroid_from_box));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_overlap", &fusion.min_overlap));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "support_cell_m", &fusion.support_cell_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_support_fraction", &fusion.min_support_fraction));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "centroid_min_part", &fusion.centroid_min_part));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "bottom_quantile", &fusion.bottom_quantile));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "shape_min_label_views", &fusion.shape_min_label_views));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "class_size_slack", &fusion.class_size_slack));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_box_containment", &fusion.merge_box_containment));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "part_containment", &fusion.part_containment));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "never_part_of", &fusion.never_part_of));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "stand_classes", &fusion.stand_classes));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "stand_height_m", &fusion.stand_height_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "overlap_voxel_m", &fusion.overlap_voxel_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "weight_track", &fusion.weight_track));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "weight_centroid", &fusion.weight_centroid));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "weight_overlap", &fusion.weight_overlap));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "score_threshold", &fusion.score_threshold));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "track_gate_m", &fusion.track_gate_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "confirm_observations", &fusion.confirm_observations));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "confirm_min_span_s", &fusion.confirm_min_span_s));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "straddle_share", &fusion.straddle_share));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "straddle_apart_views", &fusion.straddle_apart_views));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "straddle_pieces", &fusion.straddle_pieces));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_reach_m", &fusion.top_loads.reach_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_max_gap_m", &fusion.top_loads.max_gap_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_max_sink_m", &fusion.top_loads.max_sink_m));
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "top_load_rival_min_views", &fusion.top_loads.rival_min_views));
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "top_load_confirm_loads", &fusion.top_loads.confirm_loads));
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "top_load_floor_classes", &fusion.top_loads.floor_classes));
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "top_load_lower_loads", &fusion.top_loads.lower_loads));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_centroid_m", &fusion.merge_centroid_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_sigmas", &fusion.merge_sigmas));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "depth_sigma_at_1m", &fusion.depth_sigma_at_1m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "view_sigma_rad", &fusion.view_sigma_rad));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_containment", &fusion.merge_containment));
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "furniture_merge_containment", &fusion.furniture_merge_containment));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "furniture_footprint_containment",
                                      &fusion.furniture_footprint_containment));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_across_classes", &fusion.merge_across_classes));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "assoc_containment", &fusion.assoc_containment));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_size_ratio", &fusion.max_size_ratio));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "label_universe", &fusion.label_universe));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_likelihood", &fusion.min_likelihood));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "existence_p_real", &fusion.existence_p_real));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "existence_p_false", &fusion.existence_p_false));
    LOCI_RETURN_IF_ERROR(
        ReadOptional(n, "existence_class_prior_views", &fusion.existence_class_prior_views));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "confirm_llr", &fusion.confirm_llr));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "remove_llr", &fusion.remove_llr));
    if (const YAML::Node v = n["visibility"]) {
      VisibilityOptions& o = fusion.visibility;
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "min_visible_fraction", &o.min_visible_fraction));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "occlusion_tol_m", &o.occlusion_tol_m));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "occlusion_tol_rel", &o.occlusion_tol_rel));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "border_px", &o.border_px));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "min_projected_px", &o.min_projected_px));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "max_depth_m", &o.max_depth_m));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "excuse_iou", &o.excuse_iou));
      LOCI_RETURN_IF_ERROR(ReadOptional(v, "depth_stride", &o.depth_stride));
    }
  }
  if (const YAML::Node n = node["frame"]) {
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "settle_keyframes", &frame.settle_keyframes));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "plane_refine_max_deg", &frame.plane_refine_max_deg));
  }
  if (const YAML::Node n = node["octomap"]) {
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "enabled", &octomap.enabled));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "resolution_m", &octomap.resolution_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_range_m", &octomap.max_range_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(n, "ray_voxel_m", &octomap.ray_voxel_m));
  }
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "dynamic_classes", &dynamic_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "mapped_classes", &mapped_classes));
  return Validate();
}

namespace {

// `key` of the classes file: a map class name -> metres, > 0 (or >= 0 with allow_zero) and at
// most max_m.
Status ReadClassMetres(const YAML::Node& node, const char* key,
                       std::map<std::string, double>* out, bool allow_zero = false,
                       double max_m = std::numeric_limits<double>::infinity()) {
  const YAML::Node sizes = node[key];
  if (!sizes) return absl::OkStatus();
  if (!sizes.IsMap())
    return absl::InvalidArgumentError(absl::StrCat(key, " must be a map class: metres"));
  for (const auto& kv : sizes) {
    try {
      const double m = kv.second.as<double>();
      if (!((allow_zero ? m >= 0 : m > 0) && m <= max_m)) {
        const char* low = allow_zero ? ">= 0" : "> 0";
        throw YAML::Exception(kv.second.Mark(), absl::StrCat("must be ", low, " and <= ", max_m));
      }
      (*out)[kv.first.as<std::string>()] = m;
    } catch (const YAML::Exception& e) {
      return absl::InvalidArgumentError(
          absl::StrCat(key, ".", kv.first.as<std::string>(), ": ", e.what()));
    }
  }
  return absl::OkStatus();
}

}  // namespace

Status MapOptions::ClassesFromYaml(const YAML::Node& node) {
  products_yaml_ += YAML::Dump(node) + "\n";
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "dynamic_classes", &dynamic_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "mapped", &mapped_classes));
  LOCI_RETURN_IF_ERROR(ReadClassMetres(node, "max_size_m", &max_size_m));
  LOCI_RETURN_IF_ERROR(ReadClassMetres(node, "max_height_m", &max_height_m));
  LOCI_RETURN_IF_ERROR(ReadClassMetres(node, "max_thickness_m", &max_thickness_m));
  if (node["stand_m"]) {  // replaces the built-in stands; 0 turns a class's off
    fusion.top_loads.stand_m.clear();
    LOCI_RETURN_IF_ERROR(ReadClassMetres(node, "stand_m", &fusion.top_loads.stand_m, true, 2.0));
  }
  if (!mapped_classes.empty()) {
    fusion.label_universe = std::max<int>(2, static_cast<int>(mapped_classes.size()));
  }
  return Validate();
}

Status MapOptions::Validate() const {
  auto bad = [](const char* what) {
    return absl::InvalidArgumentError(absl::StrCat("map options: ", what));
  };
  if (!(cloud.min_depth_m >= 0 && cloud.max_depth_m > cloud.min_depth_m)) {
    return bad("cloud depth range must satisfy 0 <= min_depth_m < max_depth_m");
  }
  if (cloud.pixel_stride < 1 || cloud.pixel_stride > 16)
    return bad("cloud.pixel_stride in [1, 16]");
  if (!(cloud.voxel_m > 0.001) || !(observation.voxel_m > 0.001) ||
      !(fusion.overlap_voxel_m > 0.001)) {
    return bad("voxel sizes must be > 1 mm");
  }
  if (cloud.sor_mean_k < 0 || observation.sor_mean_k < 0) return bad("sor_mean_k >= 0 (0 = off)");
  if (!(observation.sor_min_voxels >= 0)) return bad("observation.sor_min_voxels >= 0");
  if (!(fusion.min_likelihood > 0 && fusion.min_likelihood < 0.5)) {
    return bad("fusion.min_likelihood in (0, 0.5)");
  }
  if (observation.max_points < 10) return bad("observation.max_points >= 10");
  const SupportTopsOptions& tops = observation.support_tops;
  if (!(tops.cell_m > 0.001) || !(tops.max_tilt_deg >= 0 && tops.max_tilt_deg < 90) ||
      !(tops.min_top_area_m2 >= 0) || !(tops.reach_m >= 0) || tops.max_planes < 1 ||
      tops.ransac_iterations < 1 || !(tops.cell_band_share <= 1)) {
    return bad(
        "observation.support_tops: cell_m > 0.001, max_tilt_deg in [0, 90), "
        "min_top_area_m2 >= 0, reach_m >= 0, max_planes >= 1, ransac_iterations >= 1, "
        "cell_band_share <= 1");
  }
  if (!(observation.min_centre_cover >= 0 && observation.min_centre_cover <= 1)) {
    return bad("observation.min_centre_cover in [0, 1]");
  }
  if (fusion.confirm_observations < 1) return bad("fusion.confirm_observations >= 1");
  if (!(fusion.confirm_min_span_s >= 0 && fusion.confirm_min_span_s <= 3600)) {
    return bad("fusion.confirm_min_span_s in [0, 3600]");
  }
  if (!(fusion.straddle_share >= 0 && fusion.straddle_share <= 1)) {
    return bad("fusion.straddle_share in [0, 1]");
  }
  if (!(fusion.furniture_footprint_containment >= 0 &&
        fusion.furniture_footprint_containment <= 1)) {
    return bad("fusion.furniture_footprint_containment in [0, 1]");
  }
  if (!(fusion.furniture_merge_containment >= 0 && fusion.furniture_merge_containment <= 1)) {
    return bad("fusion.furniture_merge_containment in [0, 1]");
  }
  if (fusion.straddle_apart_views < 0) return bad("fusion.straddle_apart_views >= 0");
  if (!(fusion.top_loads.reach_m >= 0 && fusion.top_loads.reach_m <= 2)) {
    return bad("fusion.top_load_reach_m in [0, 2]");
  }
  if (!(fusion.top_loads.max_gap_m >= 0 && fusion.top_loads.max_gap_m <= 0.5)) {
    return bad("fusion.top_load_max_gap_m in [0, 0.5]");
  }
  if (!(fusion.top_loads.max_sink_m >= 0 && fusion.top_loads.max_sink_m <= 0.5)) {
    return bad("fusion.top_load_max_sink_m in [0, 0.5]");
  }
  if (fusion.top_loads.rival_min_views < 0) return bad("fusion.top_load_rival_min_views >= 0");
  if (fusion.top_loads.confirm_loads < 0) return bad("fusion.top_load_confirm_loads >= 0");
  if (!(fusion.support_cell_m > 0.001) ||
      !(fusion.min_support_fraction >= 0 && fusion.min_support_fraction <= 1)) {
    return bad("fusion.support_cell_m > 0.001 and fusion.min_support_fraction in [0, 1]");
  }
  if (fusion.label_universe < 2) return bad("fusion.label_universe >= 2");
  if (!(fusion.merge_box_containment > 0)) return bad("fusion.merge_box_containment > 0");
  if (!(fusion.part_containment > 0)) return bad("fusion.part_containment > 0");
  if (!(fusion.stand_height_m >= 0 && fusion.stand_height_m <= 1)) {
    return bad("fusion.stand_height_m in [0, 1]");
  }
  if (!(fusion.merge_sigmas >= 0 && fusion.merge_sigmas <= 5 && fusion.depth_sigma_at_1m >= 0 &&
        fusion.view_sigma_rad >= 0 && fusion.view_sigma_rad < 0.5)) {
    return bad(
        "fusion: merge_sigmas in [0, 5], depth_sigma_at_1m >= 0, view_sigma_rad in [0, 0.5)");
  }
  if (!std::isfinite(fusion.class_size_slack)) return bad("fusion.class_size_slack finite");
  if (!(fusion.centroid_min_part >= 0 && fusion.centroid_min_part < 0.5)) {
    return bad("fusion.centroid_min_part in [0, 0.5)");
  }
  if (!(fusion.bottom_quantile >= 0 && fusion.bottom_quantile < 0.5)) {
    return bad("fusion.bottom_quantile in [0, 0.5)");
  }
  if (fusion.shape_min_label_views < 0) {
    return bad("fusion.shape_min_label_views >= 0");
  }
  if (!(fusion.existence_p_false > 0 && fusion.existence_p_false < fusion.existence_p_real &&
        fusion.existence_p_real < 1)) {
    return bad("fusion: 0 < existence_p_false < existence_p_real < 1");
  }
  if (!(fusion.remove_llr < fusion.confirm_llr)) return bad("fusion: remove_llr < confirm_llr");
  if (fusion.visibility.depth_stride < 1 || fusion.visibility.depth_stride > 16) {
    return bad("fusion.visibility.depth_stride in [1, 16]");
  }
  if (frame.settle_keyframes < 1 || frame.settle_keyframes > 1000) {
    return bad("frame.settle_keyframes in [1, 1000]");
  }
  if (octomap.enabled && !(octomap.resolution_m >= 0.005))
    return bad("octomap.resolution_m >= 0.005");
  return absl::OkStatus();
}

bool MapOptions::IsDynamic(const std::string& c) const {
  return std::find(dynamic_classes.begin(), dynamic_classes.end(), c) != dynamic_classes.end();
}

double MapOptions::MaxSizeM(const std::string& c) const {
  const auto it = max_size_m.find(c);
  return it == max_size_m.end() ? std::numeric_limits<double>::infinity() : it->second;
}

double MapOptions::MaxHeightM(const std::string& c) const {
  const auto it = max_height_m.find(c);
  return it == max_height_m.end() ? std::numeric_limits<double>::infinity() : it->second;
}

bool MapOptions::IsMapped(const std::string& c) const {
  return mapped_classes.empty() ||
         std::find(mapped_classes.begin(), mapped_classes.end(), c) != mapped_classes.end();
}

}  // namespace loci::server

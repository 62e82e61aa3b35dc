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
                      "min_centre_cover", "support_tops", "object_tops"}));
  if (const YAML::Node observation = node["observation"]) {
    LOCI_RETURN_IF_ERROR(
        CheckKnownKeys(observation["support_tops"], "map.observation.support_tops",
                       {"enabled", "cell_m", "max_tilt_deg", "min_top_area_m2", "reach_m",
                        "max_planes", "ransac_iterations", "cell_band_share"}));
    LOCI_RETURN_IF_ERROR(
        CheckKnownKeys(observation["object_tops"], "map.observation.object_tops",
                       {"classes", "min_step_m", "cell_m", "max_tilt_deg", "min_top_area_m2",
                        "reach_m", "max_planes", "ransac_iterations", "cell_band_share"}));
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
  return CheckKnownKeys(
      node["octomap"], "map.octomap",
      {"enabled", "resolution_m", "max_range_m", "ray_voxel_m", "rebuild_tolerance_m"});
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

// The sections of `map:`, each read into its options (only the keys present).
Status ReadCloud(const YAML::Node& n, CloudOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_depth_m", &o->min_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_depth_m", &o->max_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "pixel_stride", &o->pixel_stride));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "voxel_m", &o->voxel_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_mean_k", &o->sor_mean_k));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_stddev_mul", &o->sor_stddev_mul));
  return absl::OkStatus();
}

Status ReadSupportTops(const YAML::Node& n, SupportTopsOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "enabled", &o->enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "cell_m", &o->cell_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_tilt_deg", &o->max_tilt_deg));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_top_area_m2", &o->min_top_area_m2));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "reach_m", &o->reach_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_planes", &o->max_planes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "ransac_iterations", &o->ransac_iterations));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "cell_band_share", &o->cell_band_share));
  return absl::OkStatus();
}

Status ReadObservation(const YAML::Node& n, ObservationOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_score", &o->min_score));
  if (n["mask"]) {
    LOCI_ASSIGN_OR_RETURN(o->mask, detection::MaskOptions::FromYaml(n["mask"]));
  }
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "voxel_m", &o->voxel_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_points", &o->max_points));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_mean_k", &o->sor_mean_k));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_stddev_mul", &o->sor_stddev_mul));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "sor_min_voxels", &o->sor_min_voxels));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_points", &o->min_points));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_box_px", &o->min_box_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_object_depth_m", &o->max_object_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_centre_cover", &o->min_centre_cover));
  if (const YAML::Node t = n["support_tops"])
    LOCI_RETURN_IF_ERROR(ReadSupportTops(t, &o->support_tops));
  if (const YAML::Node t = n["object_tops"]) {
    LOCI_RETURN_IF_ERROR(ReadOptional(t, "classes", &o->object_tops.classes));
    LOCI_RETURN_IF_ERROR(ReadOptional(t, "min_step_m", &o->object_tops.min_step_m));
    LOCI_RETURN_IF_ERROR(ReadSupportTops(t, &o->object_tops.tops));
  }
  return absl::OkStatus();
}

Status ReadVisibility(const YAML::Node& n, VisibilityOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_visible_fraction", &o->min_visible_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "occlusion_tol_m", &o->occlusion_tol_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "occlusion_tol_rel", &o->occlusion_tol_rel));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "border_px", &o->border_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_projected_px", &o->min_projected_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_depth_m", &o->max_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "excuse_iou", &o->excuse_iou));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "depth_stride", &o->depth_stride));
  return absl::OkStatus();
}

// fusion: associating an observation with an object.
Status ReadAssociation(const YAML::Node& n, FusionOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_centroid_distance_m", &o->max_centroid_distance_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "centroid_from_box", &o->centroid_from_box));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_overlap", &o->min_overlap));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "overlap_voxel_m", &o->overlap_voxel_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "weight_track", &o->weight_track));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "weight_centroid", &o->weight_centroid));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "weight_overlap", &o->weight_overlap));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "score_threshold", &o->score_threshold));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "track_gate_m", &o->track_gate_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "straddle_share", &o->straddle_share));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "straddle_apart_views", &o->straddle_apart_views));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "straddle_pieces", &o->straddle_pieces));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "assoc_containment", &o->assoc_containment));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_size_ratio", &o->max_size_ratio));
  return absl::OkStatus();
}

// fusion: an object's shape, centroid, size and parts.
Status ReadShape(const YAML::Node& n, FusionOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "support_cell_m", &o->support_cell_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_support_fraction", &o->min_support_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "centroid_min_part", &o->centroid_min_part));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "bottom_quantile", &o->bottom_quantile));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "shape_min_label_views", &o->shape_min_label_views));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "class_size_slack", &o->class_size_slack));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "part_containment", &o->part_containment));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "never_part_of", &o->never_part_of));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "stand_classes", &o->stand_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "stand_height_m", &o->stand_height_m));
  return absl::OkStatus();
}

// fusion.top_load_*: what a table top carries.
Status ReadTopLoads(const YAML::Node& n, TopLoadOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_reach_m", &o->reach_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_max_gap_m", &o->max_gap_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_max_sink_m", &o->max_sink_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_rival_min_views", &o->rival_min_views));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_confirm_loads", &o->confirm_loads));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_floor_classes", &o->floor_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "top_load_lower_loads", &o->lower_loads));
  return absl::OkStatus();
}

// fusion: merging duplicate objects.
Status ReadMerge(const YAML::Node& n, FusionOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_box_containment", &o->merge_box_containment));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_centroid_m", &o->merge_centroid_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_sigmas", &o->merge_sigmas));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "depth_sigma_at_1m", &o->depth_sigma_at_1m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "view_sigma_rad", &o->view_sigma_rad));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_containment", &o->merge_containment));
  LOCI_RETURN_IF_ERROR(
      ReadOptional(n, "furniture_merge_containment", &o->furniture_merge_containment));
  LOCI_RETURN_IF_ERROR(
      ReadOptional(n, "furniture_footprint_containment", &o->furniture_footprint_containment));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "merge_across_classes", &o->merge_across_classes));
  return absl::OkStatus();
}

// fusion: labels, existence and confirmation.
Status ReadEvidence(const YAML::Node& n, FusionOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "confirm_observations", &o->confirm_observations));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "confirm_min_span_s", &o->confirm_min_span_s));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "label_universe", &o->label_universe));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "min_likelihood", &o->min_likelihood));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "existence_p_real", &o->existence_p_real));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "existence_p_false", &o->existence_p_false));
  LOCI_RETURN_IF_ERROR(
      ReadOptional(n, "existence_class_prior_views", &o->existence_class_prior_views));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "confirm_llr", &o->confirm_llr));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "remove_llr", &o->remove_llr));
  return absl::OkStatus();
}

Status ReadFusion(const YAML::Node& n, FusionOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadAssociation(n, o));
  LOCI_RETURN_IF_ERROR(ReadShape(n, o));
  LOCI_RETURN_IF_ERROR(ReadTopLoads(n, &o->top_loads));
  LOCI_RETURN_IF_ERROR(ReadMerge(n, o));
  LOCI_RETURN_IF_ERROR(ReadEvidence(n, o));
  if (const YAML::Node v = n["visibility"]) LOCI_RETURN_IF_ERROR(ReadVisibility(v, &o->visibility));
  return absl::OkStatus();
}

Status ReadFrame(const YAML::Node& n, MapFrameOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "settle_keyframes", &o->settle_keyframes));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "plane_refine_max_deg", &o->plane_refine_max_deg));
  return absl::OkStatus();
}

Status ReadOctomap(const YAML::Node& n, OctomapOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "enabled", &o->enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "resolution_m", &o->resolution_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_range_m", &o->max_range_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "ray_voxel_m", &o->ray_voxel_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "rebuild_tolerance_m", &o->rebuild_tolerance_m));
  return absl::OkStatus();
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
  if (const YAML::Node n = node["cloud"]) LOCI_RETURN_IF_ERROR(ReadCloud(n, &cloud));
  if (const YAML::Node n = node["observation"]) {
    LOCI_RETURN_IF_ERROR(ReadObservation(n, &observation));
  }
  if (const YAML::Node n = node["fusion"]) LOCI_RETURN_IF_ERROR(ReadFusion(n, &fusion));
  if (const YAML::Node n = node["frame"]) LOCI_RETURN_IF_ERROR(ReadFrame(n, &frame));
  if (const YAML::Node n = node["octomap"]) LOCI_RETURN_IF_ERROR(ReadOctomap(n, &octomap));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "dynamic_classes", &dynamic_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "mapped_classes", &mapped_classes));
  return Validate();
}

namespace {

// `key` of the classes file: a map class name -> metres, > 0 (or >= 0 with allow_zero) and at
// most max_m.
Status ReadClassMetres(const YAML::Node& node, const char* key, std::map<std::string, double>* out,
                       bool allow_zero = false,
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

namespace {

Status BadMapOption(const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("map options: ", what));
}

// Depth ranges, voxels and outlier removal of the dense cloud and the object clouds.
Status CheckClouds(const MapOptions& m) {
  if (!(m.cloud.min_depth_m >= 0 && m.cloud.max_depth_m > m.cloud.min_depth_m)) {
    return BadMapOption("cloud depth range must satisfy 0 <= min_depth_m < max_depth_m");
  }
  if (m.cloud.pixel_stride < 1 || m.cloud.pixel_stride > 16)
    return BadMapOption("cloud.pixel_stride in [1, 16]");
  if (!(m.cloud.voxel_m > 0.001) || !(m.observation.voxel_m > 0.001) ||
      !(m.fusion.overlap_voxel_m > 0.001)) {
    return BadMapOption("voxel sizes must be > 1 mm");
  }
  if (m.cloud.sor_mean_k < 0 || m.observation.sor_mean_k < 0)
    return BadMapOption("sor_mean_k >= 0 (0 = off)");
  if (!(m.observation.sor_min_voxels >= 0)) return BadMapOption("observation.sor_min_voxels >= 0");
  if (m.observation.max_points < 10) return BadMapOption("observation.max_points >= 10");
  if (!(m.observation.min_centre_cover >= 0 && m.observation.min_centre_cover <= 1)) {
    return BadMapOption("observation.min_centre_cover in [0, 1]");
  }
  return absl::OkStatus();
}

// observation.support_tops or observation.object_tops (`name`).
Status CheckSupportTops(const SupportTopsOptions& t, const std::string& name) {
  if (!(t.cell_m > 0.001) || !(t.max_tilt_deg >= 0 && t.max_tilt_deg < 90) ||
      !(t.min_top_area_m2 >= 0) || !(t.reach_m >= 0) || t.max_planes < 1 ||
      t.ransac_iterations < 1 || !(t.cell_band_share <= 1)) {
    return BadMapOption(absl::StrCat(
        name,
        ": cell_m > 0.001, max_tilt_deg in [0, 90), min_top_area_m2 >= 0, reach_m >= 0, "
        "max_planes >= 1, ransac_iterations >= 1, cell_band_share <= 1"));
  }
  return absl::OkStatus();
}

// Confirmation and the furniture rules of fusion.
Status CheckConfirmAndFurniture(const FusionOptions& f) {
  if (f.confirm_observations < 1) return BadMapOption("fusion.confirm_observations >= 1");
  if (!(f.confirm_min_span_s >= 0 && f.confirm_min_span_s <= 3600)) {
    return BadMapOption("fusion.confirm_min_span_s in [0, 3600]");
  }
  if (!(f.straddle_share >= 0 && f.straddle_share <= 1)) {
    return BadMapOption("fusion.straddle_share in [0, 1]");
  }
  if (!(f.furniture_footprint_containment >= 0 && f.furniture_footprint_containment <= 1)) {
    return BadMapOption("fusion.furniture_footprint_containment in [0, 1]");
  }
  if (!(f.furniture_merge_containment >= 0 && f.furniture_merge_containment <= 1)) {
    return BadMapOption("fusion.furniture_merge_containment in [0, 1]");
  }
  if (f.straddle_apart_views < 0) return BadMapOption("fusion.straddle_apart_views >= 0");
  return absl::OkStatus();
}

// fusion.top_load_*.
Status CheckTopLoads(const TopLoadOptions& l) {
  if (!(l.reach_m >= 0 && l.reach_m <= 2)) {
    return BadMapOption("fusion.top_load_reach_m in [0, 2]");
  }
  if (!(l.max_gap_m >= 0 && l.max_gap_m <= 0.5)) {
    return BadMapOption("fusion.top_load_max_gap_m in [0, 0.5]");
  }
  if (!(l.max_sink_m >= 0 && l.max_sink_m <= 0.5)) {
    return BadMapOption("fusion.top_load_max_sink_m in [0, 0.5]");
  }
  if (l.rival_min_views < 0) return BadMapOption("fusion.top_load_rival_min_views >= 0");
  if (l.confirm_loads < 0) return BadMapOption("fusion.top_load_confirm_loads >= 0");
  return absl::OkStatus();
}

// An object's support grid, shape, parts and merge geometry.
Status CheckShape(const FusionOptions& f) {
  if (!(f.support_cell_m > 0.001) ||
      !(f.min_support_fraction >= 0 && f.min_support_fraction <= 1)) {
    return BadMapOption("fusion.support_cell_m > 0.001 and fusion.min_support_fraction in [0, 1]");
  }
  if (f.label_universe < 2) return BadMapOption("fusion.label_universe >= 2");
  if (!(f.merge_box_containment > 0)) return BadMapOption("fusion.merge_box_containment > 0");
  if (!(f.part_containment > 0)) return BadMapOption("fusion.part_containment > 0");
  if (!(f.stand_height_m >= 0 && f.stand_height_m <= 1)) {
    return BadMapOption("fusion.stand_height_m in [0, 1]");
  }
  if (!(f.merge_sigmas >= 0 && f.merge_sigmas <= 5 && f.depth_sigma_at_1m >= 0 &&
        f.view_sigma_rad >= 0 && f.view_sigma_rad < 0.5)) {
    return BadMapOption(
        "fusion: merge_sigmas in [0, 5], depth_sigma_at_1m >= 0, view_sigma_rad in [0, 0.5)");
  }
  if (!std::isfinite(f.class_size_slack)) return BadMapOption("fusion.class_size_slack finite");
  if (!(f.centroid_min_part >= 0 && f.centroid_min_part < 0.5)) {
    return BadMapOption("fusion.centroid_min_part in [0, 0.5)");
  }
  if (!(f.bottom_quantile >= 0 && f.bottom_quantile < 0.5)) {
    return BadMapOption("fusion.bottom_quantile in [0, 0.5)");
  }
  if (f.shape_min_label_views < 0) {
    return BadMapOption("fusion.shape_min_label_views >= 0");
  }
  return absl::OkStatus();
}

// Labels, existence and visibility.
Status CheckEvidence(const FusionOptions& f) {
  if (!(f.min_likelihood > 0 && f.min_likelihood < 0.5)) {
    return BadMapOption("fusion.min_likelihood in (0, 0.5)");
  }
  if (!(f.existence_p_false > 0 && f.existence_p_false < f.existence_p_real &&
        f.existence_p_real < 1)) {
    return BadMapOption("fusion: 0 < existence_p_false < existence_p_real < 1");
  }
  if (!(f.remove_llr < f.confirm_llr)) return BadMapOption("fusion: remove_llr < confirm_llr");
  if (f.visibility.depth_stride < 1 || f.visibility.depth_stride > 16) {
    return BadMapOption("fusion.visibility.depth_stride in [1, 16]");
  }
  return absl::OkStatus();
}

// The map frame and the OctoMap.
Status CheckFrameAndOctomap(const MapOptions& m) {
  if (m.frame.settle_keyframes < 1 || m.frame.settle_keyframes > 1000) {
    return BadMapOption("frame.settle_keyframes in [1, 1000]");
  }
  if (m.octomap.enabled && !(m.octomap.resolution_m >= 0.005))
    return BadMapOption("octomap.resolution_m >= 0.005");
  if (!(m.octomap.rebuild_tolerance_m >= 0))
    return BadMapOption("octomap.rebuild_tolerance_m >= 0");
  return absl::OkStatus();
}

}  // namespace

Status MapOptions::Validate() const {
  LOCI_RETURN_IF_ERROR(CheckClouds(*this));
  LOCI_RETURN_IF_ERROR(CheckSupportTops(observation.support_tops, "observation.support_tops"));
  LOCI_RETURN_IF_ERROR(CheckSupportTops(observation.object_tops.tops, "observation.object_tops"));
  if (!(observation.object_tops.min_step_m >= 0)) {
    return BadMapOption("observation.object_tops.min_step_m >= 0");
  }
  LOCI_RETURN_IF_ERROR(CheckConfirmAndFurniture(fusion));
  LOCI_RETURN_IF_ERROR(CheckTopLoads(fusion.top_loads));
  LOCI_RETURN_IF_ERROR(CheckShape(fusion));
  LOCI_RETURN_IF_ERROR(CheckEvidence(fusion));
  return CheckFrameAndOctomap(*this);
}

bool ObservationOptions::ObjectTops::Applies(const std::string& class_name) const {
  return std::find(classes.begin(), classes.end(), class_name) != classes.end();
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

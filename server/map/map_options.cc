#include "server/map/map_options.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "common/config.h"
#include "common/option_table.h"

namespace loci::server {
namespace {

using CloudRow = OptionRow<CloudOptions>;
const CloudRow kCloud[] = {
    {"min_depth_m", &CloudOptions::min_depth_m, 0, 10, "nearer depth readings are ignored, m"},
    {"max_depth_m", &CloudOptions::max_depth_m, 0.2, 20,
     "farther readings are ignored, m (Kinect noise grows with z^2)"},
    {"pixel_stride", &CloudOptions::pixel_stride, 1, 16, "back-project every n-th pixel in u, v"},
    {"voxel_m", &CloudOptions::voxel_m, 0.002, 1, "voxel edge of keyframe and global cloud, m"},
    {"sor_mean_k", &CloudOptions::sor_mean_k, 0, 100,
     "statistical outlier removal: K neighbours (0 = off)"},
    {"sor_stddev_mul", &CloudOptions::sor_stddev_mul, 0, 10,
     "eq. 18: drop points with mean neighbour distance > m + k s; this is k"},
};

using ObservationRow = OptionRow<ObservationOptions>;
const ObservationRow kObservation[] = {
    {"min_score", &ObservationOptions::min_score, 0, 1, "weaker detections are ignored"},
    {"voxel_m", &ObservationOptions::voxel_m, 0.002, 0.2, "voxel edge of object clouds, m"},
    {"max_points", &ObservationOptions::max_points, 10, 1000000,
     "larger views get coarser voxels: sqrt(visible area / this)"},
    {"sor_mean_k", &ObservationOptions::sor_mean_k, 0, 100,
     "outlier removal on object clouds: K (0 = off)"},
    {"sor_stddev_mul", &ObservationOptions::sor_stddev_mul, 0, 10,
     "outlier removal on object clouds: k of eq. 18"},
    {"sor_min_voxels", &ObservationOptions::sor_min_voxels, 0, 100,
     "keep points within this many voxels of their K neighbours (rims)"},
    {"min_points", &ObservationOptions::min_points, 1, 100000,
     "views with fewer filtered points are dropped"},
    {"min_box_px", &ObservationOptions::min_box_px, 0, 10000,
     "boxes with a shorter side are not fused (detector precision falls)"},
    {"max_object_depth_m", &ObservationOptions::max_object_depth_m, 0.1, 20,
     "objects whose median depth is farther are not fused (depth noise ~z^2)"},
    {"min_centre_cover", &ObservationOptions::min_centre_cover, 0, 1,
     "a mask covering less of its box's middle half is a ring around no depth (0 = off)"},
};

using TopsRow = OptionRow<SupportTopsOptions>;
const TopsRow kSupportTops[] = {
    {"enabled", &SupportTopsOptions::enabled, 0, 0,
     "furniture seen with gravity: one observation per top surface"},
    {"cell_m", &SupportTopsOptions::cell_m, 0.005, 1,
     "footprint grid, m: coarser than depth noise, finer than any top"},
    {"max_tilt_deg", &SupportTopsOptions::max_tilt_deg, 0, 89,
     "a top's normal within this of up, deg (gravity in motion: 1-3 deg)"},
    {"min_top_area_m2", &SupportTopsOptions::min_top_area_m2, 0, 100,
     "smallest top of a piece of furniture, m^2 (half a 0.4 m side table)"},
    {"reach_m", &SupportTopsOptions::reach_m, 0, 2,
     "points within this horizontal distance of a top are its furniture's, m"},
    {"max_planes", &SupportTopsOptions::max_planes, 1, 20, "level planes tried per view"},
    {"ransac_iterations", &SupportTopsOptions::ransac_iterations, 1, 100000,
     "RANSAC samples per plane (fixed sequence)"},
    {"cell_band_share", &SupportTopsOptions::cell_band_share, -1, 1,
     "a cell is on a plane when half its points lie in this share of its band"},
};

using FusionRow = OptionRow<FusionOptions>;
const FusionRow kFusion[] = {
    {"overlap_voxel_m", &FusionOptions::overlap_voxel_m, 0.002, 0.5,
     "voxel edge of the containment test, m"},
    {"containment", &FusionOptions::containment, 0, 1,
     "one object when this share of the smaller one's voxels lies in the other"},
    {"centroid_gate_m", &FusionOptions::centroid_gate_m, 0, 2,
     "one object when centroids are closer than this, m (or the range gate)"},
    {"gate_sigmas", &FusionOptions::gate_sigmas, 0, 5,
     "range gate: this x sqrt(2) s(r) at the nearer one's range r (0 = off)"},
    {"depth_sigma_at_1m", &FusionOptions::depth_sigma_at_1m, 0, 0.2,
     "s(r): depth noise at 1 m, grows with r^2, m"},
    {"view_sigma_rad", &FusionOptions::view_sigma_rad, 0, 0.5,
     "s(r): view orientation error, moves an object by r times it, rad"},
    {"track_gate_m", &FusionOptions::track_gate_m, 0, 5,
     "the client's track id links views within this distance, m"},
    {"max_size_ratio", &FusionOptions::max_size_ratio, 1, 100,
     "sizes compatible: larger half extent <= this x the smaller"},
    {"class_size_slack", &FusionOptions::class_size_slack, 0, 10,
     "a fused box may be this x its class's max_size_m (0 = no class sizes)"},
    {"support_cell_m", &FusionOptions::support_cell_m, 0.005, 1, "shape support cells, m"},
    {"min_support_fraction", &FusionOptions::min_support_fraction, 0, 1,
     "a shape cell needs this share of the views (at least 2; 0 = every voxel)"},
    {"shape_min_label_views", &FusionOptions::shape_min_label_views, 0, 1000,
     "once the top class has this many views, only they shape the object (0 = all)"},
    {"bottom_quantile", &FusionOptions::bottom_quantile, 0, 0.49,
     "an object's bottom: this quantile of its shape voxels' heights"},
    {"label_universe", &FusionOptions::label_universe, 2, 1000,
     "K classes of the Bayesian label fusion (default: size of `mapped`)"},
    {"min_likelihood", &FusionOptions::min_likelihood, 0.001, 0.49,
     "detection scores are clamped to [this, 1 - this]"},
    {"existence_prior", &FusionOptions::existence_prior, 1e-6, 0.999,
     "P(real) of a new object before any evidence"},
    {"p_detect", &FusionOptions::p_detect, 0.001, 0.999,
     "P(box | real object) in a window of views that should show it"},
    {"p_false", &FusionOptions::p_false, 0.0001, 0.999,
     "P(box | no object there) in such a window: a false box recurring at one place"},
    {"evidence_window_s", &FusionOptions::evidence_window_s, 0, 3600,
     "views within this time are one piece of evidence (shared blur, light, viewpoint), s"},
    {"confirm_belief", &FusionOptions::confirm_belief, 0, 1,
     "an object is confirmed at this P(real)"},
    {"remove_belief", &FusionOptions::remove_belief, 0, 1,
     "an object is removed when P(real) falls to this"},
    {"max_belief", &FusionOptions::max_belief, 0.5, 1,
     "P(real) is held at or below this, so a place seen empty long enough is empty (1 = off)"},
};

using VisibilityRow = OptionRow<VisibilityOptions>;
const VisibilityRow kVisibility[] = {
    {"min_visible_fraction", &VisibilityOptions::min_visible_fraction, 0, 1,
     "share of the object's sample points that must be visible"},
    {"occlusion_tol_m", &VisibilityOptions::occlusion_tol_m, 0, 1,
     "hidden: the keyframe's depth is nearer by more than this"},
    {"occlusion_tol_rel", &VisibilityOptions::occlusion_tol_rel, 0, 1,
     "  + this x depth + the object's half size"},
    {"border_px", &VisibilityOptions::border_px, 0, 1000,
     "points this close to the image border do not count"},
    {"min_projected_px", &VisibilityOptions::min_projected_px, 0, 10000,
     "the projection's larger side must reach this, px"},
    {"max_depth_m", &VisibilityOptions::max_depth_m, 0.1, 20, "farther points do not count, m"},
    {"excuse_iou", &VisibilityOptions::excuse_iou, 0, 1,
     "a detection of any class overlapping this much excuses a miss"},
    {"depth_stride", &VisibilityOptions::depth_stride, 1, 16,
     "depth kept for this test: every n-th pixel in u and v"},
};

using FrameRow = OptionRow<MapFrameOptions>;
const FrameRow kFrame[] = {
    {"settle_keyframes", &MapFrameOptions::settle_keyframes, 1, 1000,
     "the first N keyframes fix the frame; the map is re-derived once then"},
    {"plane_refine_max_deg", &MapFrameOptions::plane_refine_max_deg, 0, 90,
     "planes replace the mean gravity when within this angle of it, deg"},
};

using OctomapRow = OptionRow<OctomapOptions>;
const OctomapRow kOctomap[] = {
    {"enabled", &OctomapOptions::enabled, 0, 0, "build the OctoMap"},
    {"resolution_m", &OctomapOptions::resolution_m, 0.005, 10, "leaf size, m"},
    {"max_range_m", &OctomapOptions::max_range_m, -1, 100,
     "rays are cut at this range, m (<= 0: no limit)"},
    {"ray_voxel_m", &OctomapOptions::ray_voxel_m, 0, 10,
     "free space: one ray per voxel of this edge (<= resolution_m: every point)"},
    {"rebuild_tolerance_m", &OctomapOptions::rebuild_tolerance_m, 0, 10,
     "a pose update rebuilds the tree when a scan moves more than this, m"},
};

using MapRow = OptionRow<MapOptions>;
const MapRow kMap[] = {
    {"dynamic_classes", &MapOptions::dynamic_classes, 0, 0,
     "classes whose pixels never enter the map (default: the classes file's)"},
    {"mapped_classes", &MapOptions::mapped_classes, 0, 0,
     "classes of the object database, [] = all (default: the classes file's `mapped`)"},
};

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
Status ReadObservation(const YAML::Node& n, ObservationOptions* o) {
  LOCI_RETURN_IF_ERROR(ReadOptionTable<ObservationOptions>(n, "map.observation", kObservation, o,
                                                           {"mask", "support_tops"}));
  if (n["mask"]) {
    LOCI_ASSIGN_OR_RETURN(o->mask, detection::MaskOptions::FromYaml(n["mask"]));
  }
  return ReadOptionTable<SupportTopsOptions>(n["support_tops"], "map.observation.support_tops",
                                             kSupportTops, &o->support_tops);
}

Status ReadFusion(const YAML::Node& n, FusionOptions* o) {
  LOCI_RETURN_IF_ERROR(
      ReadOptionTable<FusionOptions>(n, "map.fusion", kFusion, o, {"visibility"}));
  return ReadOptionTable<VisibilityOptions>(n["visibility"], "map.fusion.visibility", kVisibility,
                                            &o->visibility);
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
  products_yaml_ += DumpKey(node, "cloud") + DumpKey(node, "observation") +
                    DumpKey(node, "dynamic_classes") + DumpKey(node, "mapped_classes");
  map_yaml_ += YAML::Dump(node) + "\n";
  LOCI_RETURN_IF_ERROR(ReadOptionTable<CloudOptions>(node["cloud"], "map.cloud", kCloud, &cloud));
  if (const YAML::Node n = node["observation"]) {
    LOCI_RETURN_IF_ERROR(ReadObservation(n, &observation));
  }
  if (const YAML::Node n = node["fusion"]) LOCI_RETURN_IF_ERROR(ReadFusion(n, &fusion));
  LOCI_RETURN_IF_ERROR(ReadOptionTable<MapFrameOptions>(node["frame"], "map.frame", kFrame, &frame));
  LOCI_RETURN_IF_ERROR(
      ReadOptionTable<OctomapOptions>(node["octomap"], "map.octomap", kOctomap, &octomap));
  LOCI_RETURN_IF_ERROR(ReadOptionTable<MapOptions>(
      node, "map", kMap, this, {"cloud", "observation", "fusion", "frame", "octomap"}));
  return Validate();
}

namespace {

// `key` of the classes file: a map class name -> a value (metres, days), > 0 (or >= 0 with
// allow_zero) and at most max_value.
Status ReadClassValues(const YAML::Node& node, const char* key, std::map<std::string, double>* out,
                       bool allow_zero = false,
                       double max_value = std::numeric_limits<double>::infinity()) {
  const YAML::Node sizes = node[key];
  if (!sizes) return absl::OkStatus();
  if (!sizes.IsMap())
    return absl::InvalidArgumentError(absl::StrCat(key, " must be a map class: value"));
  for (const auto& kv : sizes) {
    try {
      const double v = kv.second.as<double>();
      if (!((allow_zero ? v >= 0 : v > 0) && v <= max_value)) {
        const char* low = allow_zero ? ">= 0" : "> 0";
        throw YAML::Exception(kv.second.Mark(),
                              absl::StrCat("must be ", low, " and <= ", max_value));
      }
      (*out)[kv.first.as<std::string>()] = v;
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
  LOCI_RETURN_IF_ERROR(ReadClassValues(node, "max_size_m", &max_size_m));
  LOCI_RETURN_IF_ERROR(ReadClassValues(node, "max_height_m", &max_height_m));
  LOCI_RETURN_IF_ERROR(ReadClassValues(node, "max_thickness_m", &max_thickness_m));
  LOCI_RETURN_IF_ERROR(ReadClassValues(node, "stays_days", &stays_days, false, 36500.0));
  if (node["stand_m"]) {  // replaces the built-in stands; 0 turns a class's off
    stand_m.clear();
    LOCI_RETURN_IF_ERROR(ReadClassValues(node, "stand_m", &stand_m, true, 2.0));
  }
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "top", &observation.mask.flat_top_classes));
  if (!mapped_classes.empty()) {
    fusion.label_universe = std::max<int>(2, static_cast<int>(mapped_classes.size()));
  }
  return Validate();
}

namespace {

Status BadMapOption(const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("map options: ", what));
}

// What the tables' bounds cannot say: relations between options.
Status CheckRelations(const MapOptions& m) {
  if (!(m.cloud.max_depth_m > m.cloud.min_depth_m)) {
    return BadMapOption("cloud depth range must satisfy min_depth_m < max_depth_m");
  }
  const FusionOptions& f = m.fusion;
  if (!(f.p_false < f.p_detect)) return BadMapOption("fusion: p_false < p_detect");
  if (!(f.remove_belief < f.existence_prior && f.existence_prior < f.confirm_belief)) {
    return BadMapOption("fusion: remove_belief < existence_prior < confirm_belief");
  }
  if (!(f.confirm_belief < f.max_belief)) return BadMapOption("fusion: confirm_belief < max_belief");
  return absl::OkStatus();
}

}  // namespace

Status MapOptions::Validate() const {
  LOCI_RETURN_IF_ERROR(CheckOptionTable<CloudOptions>("map.cloud", kCloud, cloud));
  LOCI_RETURN_IF_ERROR(
      CheckOptionTable<ObservationOptions>("map.observation", kObservation, observation));
  LOCI_RETURN_IF_ERROR(CheckOptionTable<SupportTopsOptions>(
      "map.observation.support_tops", kSupportTops, observation.support_tops));
  LOCI_RETURN_IF_ERROR(CheckOptionTable<FusionOptions>("map.fusion", kFusion, fusion));
  LOCI_RETURN_IF_ERROR(CheckOptionTable<VisibilityOptions>("map.fusion.visibility", kVisibility,
                                                           fusion.visibility));
  LOCI_RETURN_IF_ERROR(CheckOptionTable<MapFrameOptions>("map.frame", kFrame, frame));
  LOCI_RETURN_IF_ERROR(CheckOptionTable<OctomapOptions>("map.octomap", kOctomap, octomap));
  return CheckRelations(*this);
}

std::string MapOptions::DefaultsYaml() { return MapOptions().ValuesYaml(); }

std::string MapOptions::ValuesYaml() const {
  const MapOptions& d = *this;
  std::string y = "map:\n" + OptionTableYaml<MapOptions>(kMap, d, 2);
  y += "  frame:\n" + OptionTableYaml<MapFrameOptions>(kFrame, d.frame, 4);
  y += "  cloud:\n" + OptionTableYaml<CloudOptions>(kCloud, d.cloud, 4);
  y += "  observation:\n" + OptionTableYaml<ObservationOptions>(kObservation, d.observation, 4);
  y += "    support_tops:\n" +
       OptionTableYaml<SupportTopsOptions>(kSupportTops, d.observation.support_tops, 6);
  y += "  fusion:\n" + OptionTableYaml<FusionOptions>(kFusion, d.fusion, 4);
  y += "    visibility:\n" + OptionTableYaml<VisibilityOptions>(kVisibility, d.fusion.visibility, 6);
  y += "  octomap:\n" + OptionTableYaml<OctomapOptions>(kOctomap, d.octomap, 4);
  return y;
}

size_t MapOptions::OptionCount() {
  return std::size(kMap) + std::size(kFrame) + std::size(kCloud) + std::size(kObservation) +
         std::size(kSupportTops) + std::size(kFusion) + std::size(kVisibility) + std::size(kOctomap);
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

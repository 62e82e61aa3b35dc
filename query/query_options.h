// Options of the query engine: relation thresholds, vocabulary (classes, synonyms, plurals),
// the fallback up direction and answer sizes. Defaults live here; config/query.yaml documents
// and overrides them (QueryOptionsFromYaml fills only the keys present).
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "common/status.h"

namespace loci::query {

// Thresholds of the geometric relations. All lengths in metres, measured in the gravity-aligned
// frame (up = +z) on the objects' axis-aligned boxes in that frame. "size" of an object is the
// largest side of its box.
struct RelationOptions {
  // on: |subject bottom - anchor top| is scored with a Gaussian of this sigma (m). Default 0.03.
  double on_gap_sigma_m = 0.03;
  // on: a gap (either sign) beyond this is never "on" (m). Default 0.08.
  double on_max_gap_m = 0.08;
  // on: minimal fraction of the subject's footprint lying over the anchor's footprint. Default 0.5.
  double on_min_overlap = 0.5;
  // on: per subject class, the height of the stand or feet it usually rests on that its points
  // leave out (a monitor's points end at its panel, 10-25 cm above the desk): a gap of up to
  // this much above the anchor's top counts as none (m). Default {tv: 0.25}. Not a query.yaml
  // key: the server sets it from config/classes.yaml `stand_m`, which the map's table loads use
  // too (server::UseMapClassPriors).
  std::map<std::string, double> on_stand_m = {{"tv", 0.25}};
  // under: minimal fraction of the subject's footprint below the anchor's footprint. Default 0.2.
  double under_min_overlap = 0.2;
  // under: only these classes have room under them (a keyboard is not "under" a monitor whose
  // box reaches over it). COCO names plus common furniture words.
  std::vector<std::string> under_anchors = {"dining table", "desk",  "bench", "bed",  "couch",
                                            "chair",        "shelf", "cabinet", "sink", "toilet"};
  // above / below: minimal footprint overlap, as a fraction of the smaller footprint. Default 0.2.
  double above_min_overlap = 0.2;
  // above / below: the subject may reach this far into the anchor's height range (m). Default 0.05.
  double vertical_tolerance_m = 0.05;
  // near: threshold = near_factor * mean size of the two objects, clamped to
  // [near_min_m, near_max_m], compared with the gap between the two boxes. Defaults 1.0, 0.3, 1.5.
  double near_factor = 1.0;
  double near_min_m = 0.3;
  double near_max_m = 1.5;
  // next to: horizontal gap <= next_to_factor * mean size, clamped to [next_to_min_m,
  // next_to_max_m], bottoms within next_to_level_tolerance_m. Defaults 0.5, 0.25, 0.8, 0.15.
  double next_to_factor = 0.5;
  double next_to_min_m = 0.25;
  double next_to_max_m = 0.8;
  double next_to_level_tolerance_m = 0.15;
  // inside: minimal fraction of the subject's box volume inside the anchor's box. Default 0.7.
  double inside_min_fraction = 0.7;
  // inside: only these classes hold things (COCO names), and only things whose size is at most
  // inside_max_size_ratio times theirs (0.9).
  std::vector<std::string> inside_containers = {
      "cup",     "bowl",     "vase",     "sink",    "refrigerator", "oven",   "microwave",
      "toaster", "suitcase", "backpack", "handbag", "shelf",        "cabinet", "drawer", "box"};
  double inside_max_size_ratio = 0.9;
  // between: the distance from the subject's centre to the segment joining the anchors' centres
  // must be at most max(between_min_m, between_factor * half the subject's size), 5-95 % of the
  // way along, and the subject must not hold up either anchor. Defaults 1.0, 0.3.
  double between_factor = 1.0;
  double between_min_m = 0.3;
  // left / right / in front / behind (seen from a viewpoint): the horizontal offset from the
  // anchor must lie within this half angle of the direction (deg). Default 50.
  double directional_half_angle_deg = 50.0;
  // ... and the box gap within directional_factor * mean size clamped to [directional_min_m,
  // directional_max_m]. Defaults 3.0, 0.5, 3.0.
  double directional_factor = 3.0;
  double directional_min_m = 0.5;
  double directional_max_m = 3.0;
  // A relation holds when its confidence is at least this. Default 0.5.
  double min_confidence = 0.5;
};

struct QueryOptions {
  RelationOptions relations;
  // Canonical class names the parser knows (detector classes, COCO-80 by default). Classes met in
  // a map snapshot are added to these automatically.
  std::vector<std::string> classes;
  // Word or phrase -> canonical classes ("table" -> {"dining table"}). Keys are lower case.
  std::map<std::string, std::vector<std::string>> synonyms;
  // Irregular plural -> singular ("people" -> "person"); regular plurals are derived.
  std::map<std::string, std::string> irregular_plurals;
  // Up direction of the map frame when the caller gives none (unit vector, map frame). Default +z:
  // the server's map frame is z-up (server/map/map_frame.h).
  Eigen::Vector3d default_up_map = Eigen::Vector3d::UnitZ();
  // When the caller gives no up direction, estimate it from the viewpoints' camera -y axes (mean
  // of the latest poses) before falling back to default_up_map. Default false: a single handheld
  // camera pose is a worse estimate than the server's gravity-aligned map convention.
  bool up_from_viewpoints = false;
  // Side of the horizontal grid cells of the spatial index (m). Default 1.0.
  double grid_cell_m = 1.0;
  // Objects below this class confidence are ignored by Ask. Default 0 (keep all).
  double min_object_confidence = 0.0;
  // Ask ignores unconfirmed objects when true. Default false.
  bool confirmed_only = false;
  // Most objects returned in one answer (counts are always complete). Default 100.
  size_t max_result_objects = 100;
  // Most objects named in the answer sentence; the rest is summarised as "and N more". Default 4.
  size_t sentence_max_items = 4;

  // The built-in defaults: COCO-80 classes plus "shelf", the synonym and plural tables.
  static QueryOptions Defaults();
  // Empty when valid, else a message naming the first bad field.
  std::string Validate() const;
};

// Starts from `base` and overrides the keys present in `node` (layout of config/query.yaml).
StatusOr<QueryOptions> QueryOptionsFromYaml(const YAML::Node& node,
                                            const QueryOptions& base = QueryOptions::Defaults());
// Loads a YAML file with QueryOptionsFromYaml.
StatusOr<QueryOptions> LoadQueryOptions(const std::string& path);

}  // namespace loci::query

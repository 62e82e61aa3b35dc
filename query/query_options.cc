#include "query/query_options.h"

#include <cmath>

#include "common/config.h"

namespace loci::query {
namespace {

// COCO-80 as the shipped detectors name them, plus "shelf" (support surfaces of synthetic scenes).
const char* const kDefaultClasses[] = {"person",        "bicycle",      "car",
                                       "motorcycle",    "airplane",     "bus",
                                       "train",         "truck",        "boat",
                                       "traffic light", "fire hydrant", "stop sign",
                                       "parking meter", "bench",        "bird",
                                       "cat",           "dog",          "horse",
                                       "sheep",         "cow",          "elephant",
                                       "bear",          "zebra",        "giraffe",
                                       "backpack",      "umbrella",     "handbag",
                                       "tie",           "suitcase",     "frisbee",
                                       "skis",          "snowboard",    "sports ball",
                                       "kite",          "baseball bat", "baseball glove",
                                       "skateboard",    "surfboard",    "tennis racket",
                                       "bottle",        "wine glass",   "cup",
                                       "fork",          "knife",        "spoon",
                                       "bowl",          "banana",       "apple",
                                       "sandwich",      "orange",       "broccoli",
                                       "carrot",        "hot dog",      "pizza",
                                       "donut",         "cake",         "chair",
                                       "couch",         "potted plant", "bed",
                                       "dining table",  "toilet",       "tv",
                                       "laptop",        "mouse",        "remote",
                                       "keyboard",      "cell phone",   "microwave",
                                       "oven",          "toaster",      "sink",
                                       "refrigerator",  "book",         "clock",
                                       "vase",          "scissors",     "teddy bear",
                                       "hair drier",    "toothbrush",   "shelf"};

}  // namespace

QueryOptions QueryOptions::Defaults() {
  QueryOptions o;
  o.classes.assign(std::begin(kDefaultClasses), std::end(kDefaultClasses));
  o.synonyms = {
      {"tv", {"tv"}},
      {"television", {"tv"}},
      {"tv monitor", {"tv"}},
      {"monitor", {"tv"}},
      {"screen", {"tv"}},
      {"display", {"tv"}},
      {"table", {"dining table"}},
      {"desk", {"dining table"}},
      {"kitchen table", {"dining table"}},
      {"couch", {"couch"}},
      {"sofa", {"couch"}},
      {"settee", {"couch"}},
      {"mug", {"cup"}},
      {"coffee cup", {"cup"}},
      {"teacup", {"cup"}},
      {"plant", {"potted plant"}},
      {"houseplant", {"potted plant"}},
      {"flower pot", {"potted plant"}},
      {"phone", {"cell phone"}},
      {"mobile phone", {"cell phone"}},
      {"smartphone", {"cell phone"}},
      {"computer", {"laptop"}},
      {"notebook", {"laptop"}},
      {"computer mouse", {"mouse"}},
      {"remote control", {"remote"}},
      {"teddy", {"teddy bear"}},
      {"stuffed animal", {"teddy bear"}},
      {"fridge", {"refrigerator"}},
      {"bike", {"bicycle"}},
      {"motorbike", {"motorcycle"}},
      {"plane", {"airplane"}},
      {"ball", {"sports ball"}},
      {"glass", {"wine glass"}},
      {"bag", {"handbag", "backpack", "suitcase"}},
      {"rucksack", {"backpack"}},
      {"hair dryer", {"hair drier"}},
      {"human", {"person"}},
      {"man", {"person"}},
      {"woman", {"person"}},
      {"seat", {"chair"}},
      {"stool", {"chair"}},
      {"bookshelf", {"shelf"}},
      {"bookcase", {"shelf"}},
      {"shelving", {"shelf"}},
  };
  o.irregular_plurals = {{"people", "person"},        {"men", "man"},       {"women", "woman"},
                         {"mice", "mouse"},           {"shelves", "shelf"}, {"knives", "knife"},
                         {"bookshelves", "bookshelf"}};
  return o;
}

std::string QueryOptions::Validate() const {
  const RelationOptions& r = relations;
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  auto fraction = [](double v) { return std::isfinite(v) && v >= 0 && v <= 1; };
  if (!positive(r.on_gap_sigma_m)) return "relations.on_gap_sigma_m must be > 0";
  if (!positive(r.on_max_gap_m)) return "relations.on_max_gap_m must be > 0";
  if (!fraction(r.on_min_overlap)) return "relations.on_min_overlap must be in [0, 1]";
  for (const auto& [cls, stand_m] : r.on_stand_m) {
    if (!(stand_m >= 0 && stand_m <= 2)) return "relations.on_stand_m." + cls + " must be in [0, 2]";
  }
  if (!fraction(r.under_min_overlap)) return "relations.under_min_overlap must be in [0, 1]";
  if (!fraction(r.above_min_overlap)) return "relations.above_min_overlap must be in [0, 1]";
  if (!(r.vertical_tolerance_m >= 0)) return "relations.vertical_tolerance_m must be >= 0";
  if (!positive(r.near_factor) || !positive(r.near_min_m) || !(r.near_max_m >= r.near_min_m)) {
    return "relations.near_*: need factor > 0, 0 < min_m <= max_m";
  }
  if (!positive(r.next_to_factor) || !positive(r.next_to_min_m) ||
      !(r.next_to_max_m >= r.next_to_min_m) || !(r.next_to_level_tolerance_m >= 0)) {
    return "relations.next_to_*: need factor > 0, 0 < min_m <= max_m, level tolerance >= 0";
  }
  if (!fraction(r.inside_min_fraction)) return "relations.inside_min_fraction must be in [0, 1]";
  if (!positive(r.between_factor) || !positive(r.between_min_m)) {
    return "relations.between_*: must be > 0";
  }
  if (!(r.directional_half_angle_deg > 0 && r.directional_half_angle_deg <= 90)) {
    return "relations.directional_half_angle_deg must be in (0, 90]";
  }
  if (!positive(r.directional_factor) || !positive(r.directional_min_m) ||
      !(r.directional_max_m >= r.directional_min_m)) {
    return "relations.directional_*: need factor > 0, 0 < min_m <= max_m";
  }
  if (!fraction(r.min_confidence)) return "relations.min_confidence must be in [0, 1]";
  if (classes.empty()) return "classes must not be empty";
  if (!default_up_map.allFinite() || default_up_map.norm() < 1e-6) {
    return "default_up_map must be a non-zero finite vector";
  }
  if (!positive(grid_cell_m)) return "grid_cell_m must be > 0";
  if (!fraction(min_object_confidence)) return "min_object_confidence must be in [0, 1]";
  if (max_result_objects == 0) return "max_result_objects must be > 0";
  if (sentence_max_items == 0) return "sentence_max_items must be > 0";
  return "";
}

// The keys FromYaml reads, per section (CheckKnownKeys warns about any other).
constexpr const char* kQueryKeys[] = {"classes",
                                      "synonyms",
                                      "irregular_plurals",
                                      "default_up_map",
                                      "up_from_viewpoints",
                                      "grid_cell_m",
                                      "min_object_confidence",
                                      "confirmed_only",
                                      "max_result_objects",
                                      "sentence_max_items",
                                      "relations"};
constexpr const char* kRelationKeys[] = {"on_gap_sigma_m",
                                         "on_max_gap_m",
                                         "on_min_overlap",
                                         "under_min_overlap",
                                         "above_min_overlap",
                                         "vertical_tolerance_m",
                                         "near_factor",
                                         "near_min_m",
                                         "near_max_m",
                                         "next_to_factor",
                                         "next_to_min_m",
                                         "next_to_max_m",
                                         "next_to_level_tolerance_m",
                                         "inside_min_fraction",
                                         "inside_containers",
                                         "under_anchors",
                                         "inside_max_size_ratio",
                                         "between_factor",
                                         "between_min_m",
                                         "directional_half_angle_deg",
                                         "directional_factor",
                                         "directional_min_m",
                                         "directional_max_m",
                                         "min_confidence"};

StatusOr<QueryOptions> QueryOptionsFromYaml(const YAML::Node& node, const QueryOptions& base) {
  QueryOptions o = base;
  if (!node) return o;
  if (!node.IsMap()) return absl::InvalidArgumentError("query options: expected a YAML map");
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node, "", kQueryKeys));
  const YAML::Node rel = node["relations"];
  if (rel && rel.IsMap() && rel["on_stand_m"]) {
    return absl::InvalidArgumentError(
        "relations.on_stand_m is now `stand_m` of config/classes.yaml (the map uses it too)");
  }
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(rel, "relations", kRelationKeys));
  RelationOptions& r = o.relations;
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "on_gap_sigma_m", &r.on_gap_sigma_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "on_max_gap_m", &r.on_max_gap_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "on_min_overlap", &r.on_min_overlap));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "under_min_overlap", &r.under_min_overlap));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "above_min_overlap", &r.above_min_overlap));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "vertical_tolerance_m", &r.vertical_tolerance_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "near_factor", &r.near_factor));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "near_min_m", &r.near_min_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "near_max_m", &r.near_max_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "next_to_factor", &r.next_to_factor));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "next_to_min_m", &r.next_to_min_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "next_to_max_m", &r.next_to_max_m));
  LOCI_RETURN_IF_ERROR(
      ReadOptional(rel, "next_to_level_tolerance_m", &r.next_to_level_tolerance_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "inside_min_fraction", &r.inside_min_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "inside_containers", &r.inside_containers));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "under_anchors", &r.under_anchors));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "inside_max_size_ratio", &r.inside_max_size_ratio));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "between_factor", &r.between_factor));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "between_min_m", &r.between_min_m));
  LOCI_RETURN_IF_ERROR(
      ReadOptional(rel, "directional_half_angle_deg", &r.directional_half_angle_deg));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "directional_factor", &r.directional_factor));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "directional_min_m", &r.directional_min_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "directional_max_m", &r.directional_max_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(rel, "min_confidence", &r.min_confidence));

  LOCI_RETURN_IF_ERROR(ReadOptional(node, "classes", &o.classes));
  // Synonyms and plurals extend the defaults; a key given here replaces the default entry.
  std::map<std::string, std::vector<std::string>> synonyms;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "synonyms", &synonyms));
  for (auto& [k, v] : synonyms) o.synonyms[k] = v;
  std::map<std::string, std::string> plurals;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "irregular_plurals", &plurals));
  for (auto& [k, v] : plurals) o.irregular_plurals[k] = v;

  std::vector<double> up;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "default_up_map", &up));
  if (!up.empty()) {
    if (up.size() != 3) return absl::InvalidArgumentError("default_up_map: expected [x, y, z]");
    o.default_up_map = Eigen::Vector3d(up[0], up[1], up[2]);
  }
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "up_from_viewpoints", &o.up_from_viewpoints));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "grid_cell_m", &o.grid_cell_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_object_confidence", &o.min_object_confidence));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "confirmed_only", &o.confirmed_only));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_result_objects", &o.max_result_objects));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "sentence_max_items", &o.sentence_max_items));
  const std::string err = o.Validate();
  if (!err.empty()) return absl::InvalidArgumentError(absl::StrCat("query options: ", err));
  return o;
}

StatusOr<QueryOptions> LoadQueryOptions(const std::string& path) {
  LOCI_ASSIGN_OR_RETURN(YAML::Node node, LoadYamlFile(path));
  const ConfigFileScope scope(path);
  auto o = QueryOptionsFromYaml(node);
  if (!o.ok()) return absl::InvalidArgumentError(absl::StrCat(path, ": ", o.status().message()));
  return o;
}

}  // namespace loci::query

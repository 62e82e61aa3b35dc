#include "detection/detector_options.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>

#include "common/config.h"

namespace loci::detection {
namespace {

std::string Resolve(const std::string& path, const std::string& base_dir) {
  if (path.empty() || std::filesystem::path(path).is_absolute()) return path;
  return (std::filesystem::path(base_dir) / path).lexically_normal().string();
}

StatusOr<std::vector<std::string>> ReadStringList(const YAML::Node& node, const char* key) {
  std::vector<std::string> out;
  if (!node.IsSequence()) {
    return absl::InvalidArgumentError(absl::StrCat("config key '", key, "': expected a list"));
  }
  try {
    for (const auto& item : node) out.push_back(item.as<std::string>());
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("config key '", key, "': ", e.what()));
  }
  return out;
}

}  // namespace

// The keys FromYaml reads, per section (CheckKnownKeys warns about any other).
constexpr const char* kDetectorKeys[] = {"type",
                                         "model",
                                         "class_names",
                                         "input_size_px",
                                         "num_threads",
                                         "score_threshold",
                                         "nms_iou",
                                         "detections_file",
                                         "max_dt_s",
                                         "classes_file",
                                         "class_score_thresholds",
                                         "classes"};

StatusOr<DetectorOptions> DetectorOptions::FromYaml(const YAML::Node& node,
                                                    const std::string& base_dir_in) {
  const std::string base_dir = base_dir_in.empty() ? SourceDir() : base_dir_in;
  DetectorOptions o;
  if (!node) return o;
  if (!node.IsMap()) return absl::InvalidArgumentError("detector: expected a map");
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node, "detector", kDetectorKeys));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "type", &o.type));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "model", &o.model_path));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "class_names", &o.class_names_path));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "input_size_px", &o.input_size_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "num_threads", &o.num_threads));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "score_threshold", &o.score_threshold));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "nms_iou", &o.nms_iou));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "detections_file", &o.detections_path));
  double max_dt_s = o.max_dt_ns * 1e-9;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_dt_s", &max_dt_s));
  o.max_dt_ns = static_cast<int64_t>(max_dt_s * 1e9 + 0.5);
  if (node["class_score_thresholds"]) {
    if (!node["class_score_thresholds"].IsMap()) {
      return absl::InvalidArgumentError("config key 'class_score_thresholds': expected a map");
    }
    for (const auto& kv : node["class_score_thresholds"]) {
      try {
        o.class_score_thresholds[kv.first.as<std::string>()] = kv.second.as<float>();
      } catch (const YAML::Exception& e) {
        return absl::InvalidArgumentError(
            absl::StrCat("config key 'class_score_thresholds': ", e.what()));
      }
    }
  }
  if (node["classes"]) {
    LOCI_ASSIGN_OR_RETURN(o.classes, ReadStringList(node["classes"], "classes"));
  } else if (node["classes_file"]) {
    std::string file;
    LOCI_RETURN_IF_ERROR(ReadOptional(node, "classes_file", &file));
    LOCI_ASSIGN_OR_RETURN(YAML::Node classes_yaml, LoadYamlFile(Resolve(file, base_dir)));
    if (!classes_yaml["mapped"]) {
      return absl::InvalidArgumentError(absl::StrCat(file, ": no 'mapped' list"));
    }
    LOCI_ASSIGN_OR_RETURN(o.classes, ReadStringList(classes_yaml["mapped"], "mapped"));
  }
  o.model_path = Resolve(o.model_path, base_dir);
  o.class_names_path = Resolve(o.class_names_path, base_dir);
  o.detections_path = Resolve(o.detections_path, base_dir);
  LOCI_RETURN_IF_ERROR(o.Validate());
  return o;
}

Status DetectorOptions::Validate() const {
  if (type != "yolox" && type != "nanodet" && type != "file") {
    return absl::InvalidArgumentError(
        absl::StrCat("detector type '", type, "' unknown (yolox, nanodet, file)"));
  }
  if (type != "file" && (input_size_px < 32 || input_size_px % 32 != 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("input_size_px must be a positive multiple of 32, got ", input_size_px));
  }
  if (num_threads < 0) return absl::InvalidArgumentError("num_threads must be >= 0");
  if (!(score_threshold >= 0.f && score_threshold <= 1.f)) {
    return absl::InvalidArgumentError("score_threshold must be in [0, 1]");
  }
  for (const auto& [name, t] : class_score_thresholds) {
    if (!(t >= 0.f && t <= 1.f)) {
      return absl::InvalidArgumentError(
          absl::StrCat("class_score_thresholds[", name, "] must be in [0, 1]"));
    }
  }
  if (!(nms_iou > 0.f && nms_iou <= 1.f)) {
    return absl::InvalidArgumentError("nms_iou must be in (0, 1]");
  }
  if (max_dt_ns < 0) return absl::InvalidArgumentError("max_dt_s must be >= 0");
  return absl::OkStatus();
}

float DetectorOptions::ThresholdFor(const std::string& name) const {
  auto it = class_score_thresholds.find(name);
  return it == class_score_thresholds.end() ? score_threshold : it->second;
}

bool DetectorOptions::Keeps(const std::string& name) const {
  return classes.empty() || std::find(classes.begin(), classes.end(), name) != classes.end();
}

StatusOr<std::vector<std::string>> ReadClassNames(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("class names file not found: ", path));
  std::vector<std::string> names;
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    names.push_back(line);
  }
  while (!names.empty() && names.back().empty()) names.pop_back();
  if (names.empty()) return absl::InvalidArgumentError(absl::StrCat("no class names in ", path));
  return names;
}

}  // namespace loci::detection

#include "common/objects_json.h"

#include <algorithm>
#include <fstream>

#include <nlohmann/json.hpp>

namespace loci {
namespace {

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Vector3d ToVec(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw std::runtime_error("expected [x, y, z]");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

}  // namespace

StatusOr<GroundTruthScene> ReadObjectsJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  GroundTruthScene scene;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    if (j.contains("up")) scene.up = ToVec(j["up"]);
    if (j.contains("up_world")) scene.up = ToVec(j["up_world"]).normalized();
    std::vector<std::string> on_names;
    for (const auto& o : j.at("objects")) {
      GroundTruthObject g;
      if (o.at("id").is_string()) {
        g.name = o["id"].get<std::string>();
        g.id = static_cast<int64_t>(scene.objects.size()) + 1;
      } else {
        g.id = o["id"].get<int64_t>();
        g.name = std::to_string(g.id);
      }
      g.class_name = o.at("class_name").get<std::string>();
      g.centroid_m = ToVec(o.at("centroid_m"));
      g.extent_m = ToVec(o.at("extent_m"));
      g.aabb_min_m = o.contains("aabb_min_m") ? ToVec(o["aabb_min_m"]) : g.centroid_m - g.extent_m / 2;
      g.aabb_max_m = o.contains("aabb_max_m") ? ToVec(o["aabb_max_m"]) : g.centroid_m + g.extent_m / 2;
      const bool on_by_name = o.contains("on") && o["on"].is_string();
      on_names.push_back(on_by_name ? o["on"].get<std::string>() : "");
      g.on_id = o.contains("on") && o["on"].is_number() ? o["on"].get<int64_t>() : 0;
      g.dynamic = o.value("dynamic", false);
      // A number is the map export's class confidence (server/map/map_export.h), not a grade.
      const bool graded = o.contains("confidence") && o["confidence"].is_string();
      g.confidence = graded ? o["confidence"].get<std::string>() : std::string("high");
      if (g.confidence != "high" && g.confidence != "medium" && g.confidence != "low") {
        throw std::runtime_error("confidence must be high, medium or low: " + g.confidence);
      }
      if (o.contains("visible_part_centroid_m")) {
        g.visible_part_centroid_m = ToVec(o["visible_part_centroid_m"]);
      }
      scene.objects.push_back(std::move(g));
    }
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      if (on_names[i].empty()) continue;
      const auto it = std::find_if(scene.objects.begin(), scene.objects.end(),
                                   [&](const GroundTruthObject& s) { return s.name == on_names[i]; });
      if (it == scene.objects.end()) throw std::runtime_error("unknown `on` object " + on_names[i]);
      scene.objects[i].on_id = it->id;
    }
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", e.what()));
  }
  return scene;
}

Status WriteObjectsJson(const std::string& path, const GroundTruthScene& scene) {
  nlohmann::json j;
  j["frame"] = "world";
  j["up"] = Vec(scene.up);
  j["objects"] = nlohmann::json::array();
  for (const GroundTruthObject& g : scene.objects) {
    j["objects"].push_back({{"id", g.id},
                            {"class_name", g.class_name},
                            {"centroid_m", Vec(g.centroid_m)},
                            {"extent_m", Vec(g.extent_m)},
                            {"aabb_min_m", Vec(g.aabb_min_m)},
                            {"aabb_max_m", Vec(g.aabb_max_m)},
                            {"on", g.on_id ? nlohmann::json(g.on_id) : nlohmann::json(nullptr)},
                            {"dynamic", g.dynamic}});
    if (g.confidence != "high") j["objects"].back()["confidence"] = g.confidence;
  }
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError(absl::StrCat("cannot write ", path));
  out << j.dump(2) << "\n";
  return out ? absl::OkStatus() : absl::DataLossError(absl::StrCat("short write to ", path));
}

}  // namespace loci

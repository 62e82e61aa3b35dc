// Ground-truth objects of a scene (objects.json, docs/formats.md): written by `loci synth`, read
// by `loci eval objects` and the tests. World frame = the groundtruth.txt frame, z up. Also reads
// hand-made ground truth such as objects_gt.json of TUM fr1_rpy (string ids, `on` by name,
// `confidence`, `visible_part_centroid_m`).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/status.h"

namespace loci {

struct GroundTruthObject {
  int64_t id = 0;
  std::string class_name;
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent_m = Eigen::Vector3d::Zero();  // full size of the world AABB
  Eigen::Vector3d aabb_min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_max_m = Eigen::Vector3d::Zero();
  int64_t on_id = 0;        // id of the object it stands on, 0 = none / floor
  bool dynamic = false;     // moves during the sequence (its centroid is its start position)
  // Hand-made ground truth (objects_gt.json) names objects by string: `name` is that id (the
  // number as text otherwise) and the numeric id is its 1-based position in the file.
  std::string name;
  // "high", "medium" or "low" (hand-made ground truth); "high" when absent. Low objects are far,
  // blurred or mostly hidden: evaluation neither rewards nor penalises a match with one.
  std::string confidence = "high";
  // Centre of the part the camera sees (partly hidden big objects); evaluation compares a map
  // object with the nearer of this and centroid_m.
  std::optional<Eigen::Vector3d> visible_part_centroid_m;
};

struct GroundTruthScene {
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<GroundTruthObject> objects;
};

StatusOr<GroundTruthScene> ReadObjectsJson(const std::string& path);
Status WriteObjectsJson(const std::string& path, const GroundTruthScene& scene);

}  // namespace loci

// Ground-truth objects of a scene (objects.json, docs/formats.md): written by `loci synth`, read
// by `loci eval objects` and the tests. World frame = the groundtruth.txt frame, z up.
#pragma once

#include <cstdint>
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
};

struct GroundTruthScene {
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<GroundTruthObject> objects;
};

StatusOr<GroundTruthScene> ReadObjectsJson(const std::string& path);
Status WriteObjectsJson(const std::string& path, const GroundTruthScene& scene);

}  // namespace loci

// A snapshot of one fused map object as the query engine, exports and evaluation see it.
// Every position is in the map frame, metres.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/se3.h"

namespace loci {

// One change of an object's place over time, in map time (the stamps of the keyframes that
// showed it). Appeared: first confirmed, at centroid_m. Moved: seen again at centroid_m after
// its earlier place (from_m) was seen empty. Removed: its place seen empty, no new place.
struct ObjectPlaceChange {
  enum class Kind { kAppeared, kMoved, kRemoved };
  Kind kind = Kind::kAppeared;
  int64_t t_ns = 0;
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero();  // kMoved: the earlier place
  // kMoved, kRemoved: the keyframes that saw the earlier place empty, oldest first.
  std::vector<int64_t> evidence_keyframe_ids;
};

struct MapObject {
  int64_t id = 0;
  std::string class_name;        // argmax of `labels`
  double confidence = 0;         // probability of class_name
  std::vector<std::pair<std::string, double>> labels;  // label distribution, sums to 1
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_max_m = Eigen::Vector3d::Zero();
  // Oriented box: centre, half sizes along its axes, rotation R_map_box.
  Eigen::Vector3d obb_center_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d obb_half_extent_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_map_box = Eigen::Matrix3d::Identity();
  int64_t first_seen_ns = 0;
  int64_t last_seen_ns = 0;
  std::vector<std::string> robots;  // robot names that observed it
  std::string last_robot;
  uint32_t observation_count = 0;
  uint32_t point_count = 0;
  bool confirmed = false;
  // Negative evidence: keyframes that should have seen it but did not, and the share of the
  // keyframes that saw or should have seen it that did: hits / (hits + misses).
  uint32_t missed_views = 0;
  double existence = 0;
  // Height (map z, z up) of the object's densest horizontal layer of points: the top of a
  // table whose box also caught a monitor foot or a chair back. NaN when unknown.
  double top_surface_z_m = std::numeric_limits<double>::quiet_NaN();
  // Height (map z, z up) below which only a small share of the object's points lie: its bottom
  // without the few points a fused box catches under it (the desk's edge under a book, 5-7 cm
  // below its top). NaN when unknown.
  double bottom_z_m = std::numeric_limits<double>::quiet_NaN();
  // "" for an object of the shared map. Otherwise the session id of the map island it is in:
  // a robot session not aligned to the shared map yet, mapped in its own frame (its odometry
  // frame levelled z-up), so its positions are not in the map frame.
  std::string island;
  // Its place over time, oldest first (confirmed objects; empty for the others).
  std::vector<ObjectPlaceChange> history;
  // Map time it was found gone (0: in the map); its other fields are its last state.
  int64_t removed_t_ns = 0;
};

// The object expressed in another frame: T_b_a maps its frame a to frame b. Centroid, oriented
// box and R_map_box move rigidly; the axis-aligned box becomes the box of the moved corners.
// The heights (top_surface_z_m, bottom_z_m) move with a transform that keeps z up and become
// NaN under one that tilts it.
MapObject Transformed(MapObject o, const SE3d& T_b_a);

// The object's bottom height (map z, z up): bottom_z_m when known and within its box, else the
// box's bottom.
double BottomZ(const MapObject& o);

}  // namespace loci

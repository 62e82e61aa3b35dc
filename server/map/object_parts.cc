// Parts (FusionOptions::part_containment): an object whose voxels are among the voxels that
// shape another object (FusedObject::ShapeKeysAt) has no surface of its own. Not among every
// voxel fused into it: a keyboard whose masks bled onto the cup beside it in a few views holds
// the cup's voxels, yet the cup is no part of it (fr1_rpy live runs, session 46). A monitor's
// stand boxed as "mouse" on a few blurred frames lies inside the monitor: it stays a candidate,
// with its evidence, as long as it does. Merged into the monitor instead, it lost that
// evidence: the stand's next "mouse" views made a new object, confirmed before its misses added
// up (fr1_rpy, session 27). A real thing beside or in front of another has a surface of its
// own. One holder, not the union of several: with the union, fr1_rpy's real mouse, between the
// keyboard and a monitor whose masks bleed onto it, went into the monitor.
//
// Stands (FusionOptions::stand_classes): a monitor's foot lies under its screen, not among the
// screen's voxels, so the voxel test misses it. An object under the middle of a stand-class
// object is its stand. The middle, not the whole footprint. On fr1_rpy (15 runs, session 39),
// in units of the monitor box's half extents, the stands' centroids lay within 0.10 of its
// width and 0.59 of its depth from its centre; a cup beside a monitor at 0.83-0.94 of its width
// and 0.99 or more of its depth; the real mouse at 0.52 or more and 1.37 or more.
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "server/map/object_map.h"

namespace loci::server {

bool ObjectMap::CanHoldPart(const FusedObject& whole, const FusedObject& part) const {
  const std::string whole_class = whole.labels().Argmax();
  const auto& never = options_.never_part_of;
  return whole.id() != part.id() && whole_class != part.labels().Argmax() &&
         whole.half_size_m() > part.half_size_m() &&
         whole.observation_count() >= part.observation_count() &&
         !IsFlatTopClass(options_.flat_top_classes, whole_class) &&
         std::find(never.begin(), never.end(), whole_class) == never.end() &&
         (whole.centroid_m() - part.centroid_m()).norm() <
             whole.half_size_m() + part.half_size_m();
}

namespace {

constexpr double kStandMaxDepthShare = 0.75;  // of the whole's half extent across its panel
constexpr double kStandMaxWidthShare = 0.35;  // of its half extent along it

// The part's centroid, projected on the floor, in units of the whole's horizontal half extents:
// (along the shorter horizontal axis, along the longer one). The whole's most vertical box axis
// is its height. Empty when the box is degenerate.
std::optional<Eigen::Vector2d> FootprintCoordinates(const FusedObject& whole,
                                                    const Eigen::Vector3d& p_map) {
  const Eigen::Matrix3d& R = whole.R_map_box();
  int up = 0;
  for (int i = 1; i < 3; ++i) {
    if (std::abs(R(2, i)) > std::abs(R(2, up))) up = i;
  }
  const Eigen::Vector2d d = (p_map - whole.obb_center_m()).head<2>();
  std::vector<double> coords;
  std::vector<double> halves;
  for (int i = 0; i < 3; ++i) {
    if (i == up) continue;
    const Eigen::Vector2d axis = R.col(i).head<2>();
    if (axis.norm() < 1e-6 || whole.obb_half_m()(i) <= 0) return std::nullopt;
    coords.push_back(std::abs(d.dot(axis.normalized())) / whole.obb_half_m()(i));
    halves.push_back(whole.obb_half_m()(i));
  }
  return halves[0] < halves[1] ? Eigen::Vector2d(coords[0], coords[1])
                               : Eigen::Vector2d(coords[1], coords[0]);
}

}  // namespace

bool ObjectMap::StandsUnder(const FusedObject& whole, const FusedObject& part) const {
  const auto& stands = options_.stand_classes;
  if (std::find(stands.begin(), stands.end(), whole.labels().Argmax()) == stands.end()) {
    return false;
  }
  const Eigen::Vector3d& p = part.centroid_m();
  const Eigen::Matrix3d& R = whole.R_map_box();
  const double bottom_z_m = whole.obb_center_m().z() - R.row(2).cwiseAbs().dot(whole.obb_half_m());
  if (p.z() > whole.obb_center_m().z() || p.z() < bottom_z_m - options_.stand_height_m) {
    return false;
  }
  const auto xy = FootprintCoordinates(whole, p);
  return xy && xy->x() <= kStandMaxDepthShare && xy->y() <= kStandMaxWidthShare;
}

int64_t ObjectMap::WholeOf(const FusedObject& part) const {
  if (options_.part_containment > 1 ||
      IsFlatTopClass(options_.flat_top_classes, part.labels().Argmax())) {
    return 0;
  }
  VoxelSet part_keys;
  for (const auto& [id, whole] : objects_) {
    if (!CanHoldPart(whole, part)) continue;
    if (StandsUnder(whole, part)) return id;
    if (part_keys.empty()) part_keys = part.KeysAt(options_.overlap_voxel_m);
    if (Within(part_keys, whole.ShapeKeysAt(options_.overlap_voxel_m)) >=
        options_.part_containment) {
      return id;
    }
  }
  return 0;
}

void ObjectMap::JudgeParts(int64_t id, const ClassDetectionRates& rates,
                           std::vector<ObjectChange>* changes) {
  const FusedObject& whole = objects_.at(id);
  for (auto& [other_id, other] : objects_) {
    if (!CanHoldPart(whole, other)) continue;
    const bool was_confirmed = other.confirmed();
    Judge(&other, rates);
    if (other.confirmed() != was_confirmed) {
      changes->push_back({ObjectChange::Kind::kUpdated, other_id, 0, {}});
    }
  }
}

}  // namespace loci::server

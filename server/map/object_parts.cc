// Parts (FusionOptions::part_containment): an object whose voxels are another object's
// voxels has no surface of its own. A monitor's stand boxed as "mouse" on a few blurred frames
// lies inside the monitor: it stays a candidate, with its evidence, as long as it does. Merged
// into the monitor instead, it lost that evidence: the stand's next "mouse" views made a new
// object, confirmed before its misses added up (fr1_rpy, session 27). A real thing beside or in
// front of another has a surface of its own. One holder, not the union of several: with the
// union, fr1_rpy's real mouse, between the keyboard and a monitor whose masks bleed onto it,
// went into the monitor.
#include <algorithm>

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

int64_t ObjectMap::WholeOf(const FusedObject& part) const {
  if (options_.part_containment > 1 ||
      IsFlatTopClass(options_.flat_top_classes, part.labels().Argmax())) {
    return 0;
  }
  VoxelSet part_keys;
  for (const auto& [id, whole] : objects_) {
    if (!CanHoldPart(whole, part)) continue;
    if (part_keys.empty()) part_keys = part.KeysAt(options_.overlap_voxel_m);
    if (Within(part_keys, whole.KeysAt(options_.overlap_voxel_m)) >=
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

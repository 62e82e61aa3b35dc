// Parts (FusionOptions::merge_part_containment): an object whose voxels are another object's
// voxels has no surface of its own: a monitor's stand boxed as "mouse" on a few blurred frames
// lies inside the monitor. Such an object merges into the object holding it, whatever the sizes,
// and that object keeps its class. A real thing beside or in front of another has a surface of
// its own. One holder, not the union of several: with the union, fr1_rpy's real mouse, between
// the keyboard and a monitor whose masks bleed onto it, merged into the monitor (session 27).
#include <algorithm>

#include "server/map/object_map.h"

namespace loci::server {

bool ObjectMap::CanHoldPart(const FusedObject& whole, const FusedObject& part) const {
  const std::string whole_class = whole.labels().Argmax();
  const auto& never = options_.part_never_into;
  if (whole.id() == part.id() || whole_class == part.labels().Argmax() ||
      whole.half_size_m() <= part.half_size_m() ||
      whole.observation_count() < part.observation_count() ||
      IsFlatTopClass(options_.flat_top_classes, whole_class) ||
      std::find(never.begin(), never.end(), whole_class) != never.end() ||
      (whole.centroid_m() - part.centroid_m()).norm() >=
          whole.half_size_m() + part.half_size_m()) {
    return false;
  }
  // The whole keeps its class: a part's boxes may not outvote it (a 1 m desk is no "laptop").
  LabelDistribution merged = whole.labels();
  merged.Merge(part.labels());
  return merged.Argmax() == whole_class;
}

int64_t ObjectMap::WholeOf(const FusedObject& part) const {
  if (options_.merge_part_containment > 1 || !options_.merge_across_classes ||
      IsFlatTopClass(options_.flat_top_classes, part.labels().Argmax())) {
    return 0;
  }
  const VoxelSet part_keys = part.KeysAt(options_.overlap_voxel_m);
  int64_t best_id = 0;
  double best_share = 0;
  for (const auto& [id, whole] : objects_) {
    if (!CanHoldPart(whole, part)) continue;
    const double share = Within(part_keys, whole.KeysAt(options_.overlap_voxel_m));
    if (share > best_share) {
      best_share = share;
      best_id = id;
    }
  }
  return best_share >= options_.merge_part_containment ? best_id : 0;
}

std::pair<int64_t, int64_t> ObjectMap::FindPart(int64_t id) const {
  const FusedObject& self = objects_.at(id);
  if (const int64_t whole = WholeOf(self); whole != 0) return {id, whole};
  // self grew: the smaller objects near it may now lie inside it (with their other neighbours).
  for (const auto& [other_id, other] : objects_) {
    if (!CanHoldPart(self, other)) continue;
    if (const int64_t whole = WholeOf(other); whole != 0) return {other_id, whole};
  }
  return {0, 0};
}

}  // namespace loci::server

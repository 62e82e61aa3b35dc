#include "client/tracking/local_map.h"

#include <algorithm>

namespace loci {

void LocalMap::Clear() {
  keyframes_.clear();
  points_.clear();
}

MapPoint* LocalMap::Point(int64_t id) {
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

MapPoint* LocalMap::AddPoint(const Vec3d& p_world, const Descriptor256& d, int octave,
                             double depth_m) {
  const int64_t id = next_point_id_++;
  MapPoint& p = points_[id];
  p.id = id;
  p.p_world = p_world;
  p.descriptor = d;
  p.octave = octave;
  p.ref_depth_m = depth_m;
  return &p;
}

void LocalMap::AddKeyframe(std::unique_ptr<KeyframeRecord> kf) {
  for (int64_t id : kf->point_ids) {
    if (MapPoint* p = Point(id)) ++p->num_keyframes;
  }
  keyframes_.push_back(std::move(kf));
  while (static_cast<int>(keyframes_.size()) > max_keyframes_) {
    for (int64_t id : keyframes_.front()->point_ids) {
      MapPoint* p = Point(id);
      if (p && --p->num_keyframes <= 0) points_.erase(id);
    }
    keyframes_.pop_front();
  }
}

void LocalMap::RemovePoint(int64_t id) {
  points_.erase(id);
  // Keyframes keep stale ids; Point() returns nullptr for them.
}

void LocalMap::CullPoints() {
  std::vector<int64_t> bad;
  for (const auto& [id, p] : points_) {
    if ((p.visible >= 10 && p.found * 4 < p.visible) || p.dynamic_votes >= 2) bad.push_back(id);
  }
  for (int64_t id : bad) RemovePoint(id);
}

std::vector<MapPoint*> LocalMap::Points() {
  std::vector<MapPoint*> out;
  out.reserve(points_.size());
  for (auto& [id, p] : points_) out.push_back(&p);
  return out;
}

}  // namespace loci

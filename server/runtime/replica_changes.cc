#include "server/runtime/replica_changes.h"

#include <unordered_map>

namespace loci::server {
namespace {

using Kind = ObjectChange::Kind;

// Whether anything a query reads of the object differs.
bool Differs(const MapObject& a, const MapObject& b) {
  return a.observation_count != b.observation_count || a.last_seen_ns != b.last_seen_ns ||
         a.confirmed != b.confirmed || a.class_name != b.class_name ||
         a.confidence != b.confidence || a.centroid_m != b.centroid_m ||
         a.aabb_min_m != b.aabb_min_m || a.aabb_max_m != b.aabb_max_m ||
         a.obb_center_m != b.obb_center_m || a.obb_half_extent_m != b.obb_half_extent_m ||
         a.point_count != b.point_count || a.missed_views != b.missed_views ||
         a.existence != b.existence || a.history.size() != b.history.size() ||
         a.robots != b.robots || a.island != b.island;
}

ObjectEventOut EventOf(Kind kind, const MapObject& o) {
  ObjectEventOut e;
  e.kind = kind;
  e.object = o;
  return e;
}

// The event's evidence from the object's newest place change of `kind`, when it has one.
void AddEvidence(ObjectPlaceChange::Kind kind, ObjectEventOut* e) {
  const std::vector<ObjectPlaceChange>& h = e->object.history;
  if (h.empty() || h.back().kind != kind) return;
  e->evidence_keyframe_ids = h.back().evidence_keyframe_ids;
  e->evidence_t_ns = h.back().t_ns;
  e->from_m = h.back().from_m;
}

// The event for an object published before and now: UPDATED or MOVED, none when unchanged.
std::optional<ObjectEventOut> ChangeOf(const MapObject& before, const MapObject& now) {
  if (!Differs(before, now)) return std::nullopt;
  const bool moved = now.history.size() > before.history.size() &&
                     now.history.back().kind == ObjectPlaceChange::Kind::kMoved;
  ObjectEventOut e = EventOf(moved ? Kind::kMoved : Kind::kUpdated, now);
  if (moved) AddEvidence(ObjectPlaceChange::Kind::kMoved, &e);
  return e;
}

}  // namespace

std::vector<ObjectEventOut> ChangesBetween(const ReplicaSnapshot& before,
                                           const ReplicaSnapshot& after) {
  std::unordered_map<int64_t, const MapObject*> live_before;
  for (const MapObject& o : before.objects) live_before[o.id] = &o;
  std::unordered_map<int64_t, const MapObject*> removed_before;
  for (const MapObject& o : before.removed) removed_before[o.id] = &o;

  std::vector<ObjectEventOut> out;
  for (const MapObject& o : after.objects) {
    auto it = live_before.find(o.id);
    if (it == live_before.end()) {  // new, or back after it was found gone
      out.push_back(EventOf(removed_before.count(o.id) ? Kind::kUpdated : Kind::kCreated, o));
      continue;
    }
    if (std::optional<ObjectEventOut> e = ChangeOf(*it->second, o)) out.push_back(std::move(*e));
    live_before.erase(it);
  }
  for (const MapObject& o : after.removed) {
    if (live_before.erase(o.id) == 0) continue;  // already gone before
    ObjectEventOut e = EventOf(Kind::kRemoved, o);
    AddEvidence(ObjectPlaceChange::Kind::kRemoved, &e);
    out.push_back(std::move(e));
  }
  for (const MapObject& o : before.objects) {  // neither live nor removed now: merged away
    if (live_before.count(o.id)) out.push_back(EventOf(Kind::kRemoved, o));
  }
  return out;
}

}  // namespace loci::server

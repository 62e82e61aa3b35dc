// Objects' places over time (ObjectMap): appeared, moved, removed. server/map/README.md
// ("Changes over time") gives the reasons.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <limits>

#include "server/map/object_map.h"

namespace loci::server {

bool ObjectMap::CouldBeMoved(const FusedObject& before, const FusedObject& after) const {
  // One thing is in one place at a time: the new place's sightings all come after the old
  // place's; and it keeps its class and size.
  return before.id() != after.id() && before.labels().Argmax() == after.labels().Argmax() &&
         before.last_seen_ns() < after.first_seen_ns() &&
         association_.SizesCompatible(before.half_size_m(), after.half_size_m());
}

void ObjectMap::TrackPlaces(std::vector<ObjectChange>* changes) {
  std::vector<int64_t> fresh;
  for (const auto& [id, object] : objects_) {
    if (object.confirmed() && !history_.count(id)) fresh.push_back(id);
  }
  for (int64_t id : fresh) {
    if (objects_.count(id)) OnConfirmed(id, changes);
  }
}

int64_t ObjectMap::MovedFrom(const FusedObject& object) const {
  int64_t old_id = 0;
  double best_d = std::numeric_limits<double>::infinity();
  auto consider = [&](int64_t before_id, const FusedObject& before) {
    const double d = (before.centroid_m() - object.centroid_m()).norm();
    if (CouldBeMoved(before, object) && d < best_d) {
      best_d = d;
      old_id = before_id;
    }
  };
  for (const auto& [gone_id, before] : gone_) consider(gone_id, before);
  // One that was confirmed and is now doubted (its place seen empty since) is also explained
  // by the move: more likely gone than there, and a thing like it has appeared.
  for (const auto& [live_id, before] : objects_) {
    if (!before.confirmed() && history_.count(live_id)) consider(live_id, before);
  }
  return old_id;
}

int64_t ObjectMap::FreshTwinOf(const FusedObject& object) const {
  // A confirmed object that only ever appeared, first seen after this one's last sighting, may
  // be this one at its new place; the nearest one is.
  int64_t fresh_id = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (const auto& [other_id, other] : objects_) {
    const auto h = history_.find(other_id);
    if (!other.confirmed() || h == history_.end() || h->second.size() != 1 ||
        !CouldBeMoved(object, other)) {
      continue;
    }
    const double d = (other.centroid_m() - object.centroid_m()).norm();
    if (d < best_d) {
      best_d = d;
      fresh_id = other_id;
    }
  }
  return fresh_id;
}

ObjectPlaceChange ObjectMap::Withdraw(int64_t id) {
  FusedObject& object = objects_.at(id);
  ObjectPlaceChange gone;
  gone.kind = ObjectPlaceChange::Kind::kRemoved;
  gone.from_m = object.centroid_m();
  gone.centroid_m = object.centroid_m();
  gone.t_ns = object.MissesSinceLastHit(&gone.evidence_keyframe_ids);
  gone_.emplace(id, std::move(object));
  objects_.erase(id);
  return gone;
}

void ObjectMap::OnConfirmed(int64_t id, std::vector<ObjectChange>* changes) {
  const int64_t old_id = MovedFrom(objects_.at(id));
  if (old_id == 0) {
    const FusedObject& object = objects_.at(id);
    ObjectPlaceChange appeared;
    appeared.t_ns = object.first_seen_ns();
    appeared.centroid_m = object.centroid_m();
    history_[id].push_back(std::move(appeared));
    return;
  }
  // Its old place was seen empty before: that removal (or doubt) was a move, or, seen again
  // where it was (within its size), a spell out of sight.
  ObjectPlaceChange moved;
  if (objects_.count(old_id)) {
    moved = Withdraw(old_id);
  } else {
    moved = history_.at(old_id).back();
    history_.at(old_id).pop_back();
  }
  const FusedObject& object = objects_.at(id);
  moved.t_ns = std::max(moved.t_ns, object.first_seen_ns());
  const FusedObject& before = gone_.at(old_id);
  const bool back = (before.centroid_m() - object.centroid_m()).norm() <=
                    std::max(before.half_size_m(), object.half_size_m());
  moved.kind = back ? ObjectPlaceChange::Kind::kAppeared : ObjectPlaceChange::Kind::kMoved;
  Adopt(old_id, id, std::move(moved), changes);
}

void ObjectMap::OnGone(int64_t id, std::vector<ObjectChange>* changes) {
  const int64_t fresh_id = FreshTwinOf(objects_.at(id));
  spdlog::debug("object {} ({}) gone{}", id, objects_.at(id).labels().Argmax(),
                fresh_id ? fmt::format(", seen again as {}", fresh_id) : "");
  const MapObject last_state = objects_.at(id).Snapshot();
  ObjectPlaceChange gone = Withdraw(id);
  if (fresh_id != 0) {
    gone.t_ns = std::max(gone.t_ns, objects_.at(fresh_id).first_seen_ns());
    gone.kind = ObjectPlaceChange::Kind::kMoved;
    Adopt(id, fresh_id, std::move(gone), changes);
    return;
  }
  ObjectChange removed = ChangeOf(ObjectChange::Kind::kRemoved, id);
  removed.removed_state = last_state;
  removed.evidence_keyframe_ids = gone.evidence_keyframe_ids;
  removed.evidence_t_ns = gone.t_ns;
  changes->push_back(std::move(removed));
  history_[id].push_back(std::move(gone));
}

void ObjectMap::Adopt(int64_t old_id, int64_t fresh_id, ObjectPlaceChange moved,
                      std::vector<ObjectChange>* changes) {
  FusedObject object = std::move(objects_.at(fresh_id));
  objects_.erase(fresh_id);
  ObjectChange provisional = ChangeOf(ObjectChange::Kind::kRemoved, fresh_id);
  provisional.removed_state = object.Snapshot();
  changes->push_back(std::move(provisional));
  history_.erase(fresh_id);
  merged_into_[fresh_id] = old_id;
  gone_.erase(old_id);
  object.set_id(old_id);
  moved.centroid_m = object.centroid_m();
  const bool is_move = moved.kind == ObjectPlaceChange::Kind::kMoved;
  ObjectChange change =
      ChangeOf(is_move ? ObjectChange::Kind::kMoved : ObjectChange::Kind::kCreated, old_id);
  change.from_m = moved.from_m;
  change.evidence_keyframe_ids = moved.evidence_keyframe_ids;
  change.evidence_t_ns = moved.t_ns;
  changes->push_back(std::move(change));
  spdlog::debug("object {} ({}) {} {:.2f} m away", old_id, object.labels().Argmax(),
                is_move ? "moved" : "back", (moved.centroid_m - moved.from_m).norm());
  history_[old_id].push_back(std::move(moved));
  objects_.emplace(old_id, std::move(object));
}

MapObject ObjectMap::SnapshotWithHistory(const FusedObject& object) const {
  MapObject m = object.Snapshot();
  if (auto it = history_.find(object.id()); it != history_.end()) m.history = it->second;
  return m;
}

std::vector<MapObject> ObjectMap::Removed() const {
  std::vector<MapObject> out;
  for (const auto& [id, object] : gone_) {
    if (std::optional<MapObject> m = RemovedOf(id)) out.push_back(std::move(*m));
  }
  return out;
}

std::optional<MapObject> ObjectMap::RemovedOf(int64_t id) const {
  auto it = gone_.find(id);
  if (it == gone_.end()) return std::nullopt;
  MapObject m = SnapshotWithHistory(it->second);
  m.removed_t_ns = m.history.empty() ? it->second.last_seen_ns() : m.history.back().t_ns;
  return m;
}

}  // namespace loci::server

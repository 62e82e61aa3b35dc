#include "server/map/object_map.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

namespace loci::server {

ObjectChange ChangeOf(ObjectChange::Kind kind, int64_t object_id, int64_t merged_from_id) {
  ObjectChange c;
  c.kind = kind;
  c.object_id = object_id;
  c.merged_from_id = merged_from_id;
  return c;
}

ObjectMap::ObjectMap(const FusionOptions& options, double voxel_m)
    : options_(options), association_(options), voxel_m_(voxel_m) {}

FusedObject ObjectMap::NewObject(int64_t id) const {
  // Disconnected parts under 5 % of an object's supported points are strays, not the object.
  constexpr double kCentroidMinPart = 0.05;
  return FusedObject(id, voxel_m_, /*centroid_from_box=*/true,
                     LabelDistribution(options_.label_universe, options_.min_likelihood),
                     {options_.support_cell_m, options_.min_support_fraction, kCentroidMinPart,
                      options_.top_classes, options_.top_margin_m, options_.shape_min_label_views,
                      options_.bottom_quantile});
}

FusedObject::ExistenceModel ObjectMap::Existence(const FusedObject& object) const {
  const auto stays = options_.stays_s.find(object.labels().Argmax());
  const double max_p = options_.max_belief;
  return {options_.existence_prior, options_.p_detect, options_.p_false,
          static_cast<int64_t>(options_.evidence_window_s * 1e9),
          stays == options_.stays_s.end() ? 0.0 : stays->second,
          max_p >= 1 ? std::numeric_limits<double>::infinity() : std::log(max_p / (1 - max_p))};
}

bool ObjectMap::FitsClassShape(const FusedObject& object) const {
  const std::string class_name = object.labels().Argmax();
  if (!association_.FitsClass(class_name, 2.0 * object.half_size_m())) return false;
  const auto it = options_.max_thickness_m.find(class_name);
  return it == options_.max_thickness_m.end() || 2.0 * object.obb_half_m().minCoeff() <= it->second;
}

double ObjectMap::Judge(FusedObject* object) const {
  const double log_odds = object->ExistenceLogOdds(Existence(*object));
  const double confirm = std::log(options_.confirm_belief / (1 - options_.confirm_belief));
  object->SetConfirmed(log_odds >= confirm && FitsClassShape(*object));
  return log_odds;
}

namespace {

// Whether a and b can be near enough for any geometric term (the cheap test before voxels).
bool MayTouch(double d_m, double half_a_m, double half_b_m, const FusionOptions& o) {
  return d_m < std::max({o.track_gate_m, half_a_m + half_b_m + o.overlap_voxel_m,
                         o.centroid_gate_m * std::max(1.0, o.gate_sigmas) * 4});
}

}  // namespace

AssociationView ObjectMap::ViewOf(const FusedObject& object, VoxelSet* keys,
                                  VoxelSet* footprint) const {
  AssociationView v;
  v.class_name = object.labels().Argmax();
  v.centroid_m = object.centroid_m();
  v.half_size_m = object.half_size_m();
  v.range_m = object.nearest_range_m();
  v.tracks = &object.tracks();
  if (keys != nullptr) {
    *keys = association_.IsTopClass(v.class_name) ? object.KeysAt(options_.overlap_voxel_m)
                                                  : object.ShapeKeysAt(options_.overlap_voxel_m);
    v.keys = keys;
    if (footprint != nullptr && association_.IsTopClass(v.class_name)) {
      *footprint = FootprintOfKeys(*keys, options_.overlap_voxel_m, options_.overlap_voxel_m);
      v.footprint = footprint;
    }
  }
  return v;
}

int64_t ObjectMap::BestObjectFor(const MapObservation& obs, const VoxelSet& obs_keys) const {
  const std::set<std::pair<int64_t, int64_t>> obs_tracks = {{obs.session_row, obs.track_id}};
  AssociationView o;
  o.class_name = obs.class_name;
  o.centroid_m = obs.centroid_m;
  o.half_size_m = obs.half_size_m;
  o.range_m = obs.range_m;
  o.keys = &obs_keys;
  o.tracks = &obs_tracks;
  VoxelSet obs_footprint;
  if (association_.IsTopClass(obs.class_name)) {
    obs_footprint = FootprintOfKeys(obs_keys, options_.overlap_voxel_m, options_.overlap_voxel_m);
    o.footprint = &obs_footprint;
  }
  int64_t best_id = 0;
  int best_score = 0;
  double best_d = 0;
  for (const auto& [id, object] : objects_) {
    const double d = (object.centroid_m() - obs.centroid_m).norm();
    if (!MayTouch(d, object.half_size_m(), obs.half_size_m, options_)) continue;
    VoxelSet keys, footprint;
    const int score = association_.Score(ViewOf(object, &keys, &footprint), o);
    if (score > best_score || (score > 0 && score == best_score && d < best_d)) {
      best_id = id;
      best_score = score;
      best_d = d;
    }
  }
  return best_id;
}

std::vector<int64_t> ObjectMap::Integrate(const std::vector<MapObservation>& observations,
                                          std::vector<ObjectChange>* changes) {
  std::vector<int64_t> ids;
  ids.reserve(observations.size());
  for (const MapObservation& obs : observations) {
    VoxelSet keys;
    for (const ColoredPoint& p : obs.points_m) {
      keys.insert(KeyOf(p.p_m.cast<double>(), options_.overlap_voxel_m));
    }
    int64_t id = BestObjectFor(obs, keys);
    ObjectChange::Kind kind = ObjectChange::Kind::kUpdated;
    if (id == 0) {
      id = next_id_++;
      objects_.emplace(id, NewObject(id));
      kind = ObjectChange::Kind::kCreated;
    }
    FusedObject& object = objects_.at(id);
    object.AddPoints(obs.points_m, obs.class_name);
    object.Observe(obs.class_name, obs.score, obs.session_row, obs.track_id, obs.robot,
                   obs.keyframe_id, obs.t_ns);
    object.ObserveRange(obs.range_m);
    Judge(&object);
    changes->push_back(ChangeOf(kind, id));
    ids.push_back(MergeDuplicates(id, changes));
  }
  TrackPlaces(changes);
  for (int64_t& id : ids) id = Resolve(id);
  return ids;
}

int64_t ObjectMap::MergeDuplicates(int64_t id, std::vector<ObjectChange>* changes) {
  bool merged = true;
  while (merged) {
    merged = false;
    const FusedObject& self = objects_.at(id);
    VoxelSet self_keys, self_footprint;
    std::optional<AssociationView> self_view;
    for (const auto& [other_id, other] : objects_) {
      if (other_id == id) continue;
      const double d = (other.centroid_m() - self.centroid_m()).norm();
      if (!MayTouch(d, self.half_size_m(), other.half_size_m(), options_)) continue;
      if (!self_view) {
        self_view = ViewOf(self, &self_keys, &self_footprint);
        self_view->tracks = nullptr;  // two objects merge on geometry alone (README, step 2)
      }
      VoxelSet keys, footprint;
      if (association_.Score(*self_view, ViewOf(other, &keys, &footprint)) == 0) continue;
      id = Merge(id, other_id, changes);
      merged = true;
      break;
    }
  }
  return id;
}

int64_t ObjectMap::Merge(int64_t a, int64_t b, std::vector<ObjectChange>* changes) {
  const FusedObject& first = objects_.at(a);
  const FusedObject& second = objects_.at(b);
  spdlog::debug("objects {} ({}, {} views) and {} ({}, {} views) merged, {:.2f} m apart", a,
                first.labels().Argmax(), first.observation_count(), b, second.labels().Argmax(),
                second.observation_count(), (second.centroid_m() - first.centroid_m()).norm());
  // The older object survives, so ids handed out earlier stay valid where possible.
  const int64_t keep = std::min(a, b), drop = std::max(a, b);
  objects_.at(keep).Absorb(objects_.at(drop));
  Judge(&objects_.at(keep));
  ObjectChange removed = ChangeOf(ObjectChange::Kind::kRemoved, drop);
  removed.removed_state = objects_.at(drop).Snapshot();
  objects_.erase(drop);
  merged_into_[drop] = keep;
  // One object has one history: the survivor's, or the absorbed one's when it has none.
  if (auto h = history_.find(drop); h != history_.end()) {
    if (!history_.count(keep)) history_[keep] = std::move(h->second);
    history_.erase(drop);
  }
  changes->push_back(ChangeOf(ObjectChange::Kind::kMerged, keep, drop));
  changes->push_back(std::move(removed));
  return keep;
}

bool ObjectMap::MoveObservation(int64_t object_id, const std::vector<ColoredPoint>& old_m,
                                const std::vector<ColoredPoint>& new_m,
                                const std::string& class_name) {
  const int64_t id = Resolve(object_id);
  auto it = objects_.find(id);
  if (it == objects_.end()) return false;
  it->second.MovePoints(old_m, new_m, class_name);
  return true;
}

void ObjectMap::MergeMoved(const std::vector<int64_t>& object_ids,
                           std::vector<ObjectChange>* changes) {
  std::set<int64_t> moved;
  for (int64_t object_id : object_ids) moved.insert(Resolve(object_id));
  for (int64_t id : moved) {
    auto it = objects_.find(id);
    if (it == objects_.end()) continue;
    it->second.RecomputeGeometry();
    changes->push_back(ChangeOf(ObjectChange::Kind::kUpdated, id));
  }
  for (int64_t object_id : moved) {
    const int64_t id = Resolve(object_id);
    if (objects_.count(id)) MergeDuplicates(id, changes);
  }
  // A move changes an object's shape, which its class must still fit.
  std::set<int64_t> judged;
  for (int64_t object_id : moved) {
    const int64_t id = Resolve(object_id);
    auto it = objects_.find(id);
    if (it == objects_.end() || !judged.insert(id).second) continue;
    const bool was_confirmed = it->second.confirmed();
    Judge(&it->second);
    if (it->second.confirmed() != was_confirmed) {
      changes->push_back(ChangeOf(ObjectChange::Kind::kUpdated, id));
    }
  }
  TrackPlaces(changes);
}

void ObjectMap::ObserveView(int64_t keyframe_id, int64_t t_ns, const KeyframeView& view,
                            const std::vector<int64_t>& observed_ids,
                            std::vector<ObjectChange>* changes) {
  std::unordered_set<int64_t> observed;
  for (int64_t id : observed_ids) observed.insert(Resolve(id));
  const double remove = std::log(options_.remove_belief / (1 - options_.remove_belief));
  std::vector<int64_t> gone;
  for (auto& [id, object] : objects_) {
    if (observed.count(id)) continue;
    if (!ExpectedInView(object.sample_m(), object.half_size_m(), view, options_.visibility)) {
      continue;
    }
    object.Miss(keyframe_id, t_ns);
    const bool was_confirmed = object.confirmed();
    const double log_odds = Judge(&object);
    // Gone at remove_belief; sooner when a thing like it has newly appeared elsewhere, since
    // one thing is in one place and the move explains both sightings.
    const bool doubted = was_confirmed && !object.confirmed() && history_.count(id);
    if (log_odds <= remove || (doubted && FreshTwinOf(object) != 0)) {
      gone.push_back(id);
    } else if (object.confirmed() != was_confirmed) {
      changes->push_back(ChangeOf(ObjectChange::Kind::kUpdated, id));
    }
  }
  for (int64_t id : gone) {
    if (!objects_.count(id)) continue;  // adopted by an object gone before it
    if (history_.count(id)) {  // a confirmed object: its place is empty
      OnGone(id, changes);
      continue;
    }
    const FusedObject& object = objects_.at(id);
    spdlog::debug("object {} ({}, {} views, {} missed) removed: too many views missed it", id,
                  object.labels().Argmax(), object.observation_count(), object.misses());
    ObjectChange removed = ChangeOf(ObjectChange::Kind::kRemoved, id);
    removed.removed_state = object.Snapshot();
    removed.evidence_t_ns = object.MissesSinceLastHit(&removed.evidence_keyframe_ids);
    changes->push_back(std::move(removed));
    objects_.erase(id);
  }
  TrackPlaces(changes);
}

std::vector<MapObject> ObjectMap::Snapshot(bool confirmed_only) const {
  std::vector<MapObject> out;
  for (const auto& [id, object] : objects_) {
    if (!confirmed_only || object.confirmed()) out.push_back(SnapshotWithHistory(object));
  }
  return out;
}

std::optional<MapObject> ObjectMap::SnapshotOf(int64_t id) const {
  const FusedObject* object = Find(id);
  if (object == nullptr) return std::nullopt;
  return SnapshotWithHistory(*object);
}

std::vector<std::optional<MapObject>> ObjectMap::SnapshotsOf(
    const std::vector<int64_t>& ids) const {
  std::vector<std::optional<MapObject>> out;
  out.reserve(ids.size());
  for (int64_t id : ids) out.push_back(SnapshotOf(id));
  return out;
}

int64_t ObjectMap::Resolve(int64_t id) const {
  auto it = merged_into_.find(id);
  while (it != merged_into_.end()) {
    id = it->second;
    it = merged_into_.find(id);
  }
  return id;
}

const FusedObject* ObjectMap::Find(int64_t id) const {
  auto it = objects_.find(id);
  return it == objects_.end() ? nullptr : &it->second;
}

size_t ObjectMap::confirmed_count() const {
  return std::count_if(objects_.begin(), objects_.end(),
                       [](const auto& kv) { return kv.second.confirmed(); });
}

Status ObjectMap::SetFirstId(int64_t first_id) {
  if (first_id < 1) return absl::InvalidArgumentError("object ids start at 1 or above");
  if (!objects_.empty() || next_id_ != 1) {
    return absl::FailedPreconditionError("object ids can only be set before the first object");
  }
  next_id_ = first_id;
  return absl::OkStatus();
}

}  // namespace loci::server

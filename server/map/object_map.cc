#include "server/map/object_map.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <set>

namespace loci::server {

double VoxelOverlap(const VoxelSet& a, const VoxelSet& b) {
  if (a.empty() && b.empty()) return 0.0;
  const auto& small = a.size() < b.size() ? a : b;
  const auto& large = a.size() < b.size() ? b : a;
  size_t inter = 0;
  for (VoxelKey k : small) inter += large.count(k);
  return static_cast<double>(inter) / static_cast<double>(a.size() + b.size() - inter);
}

double VoxelContainment(const VoxelSet& a, const VoxelSet& b) {
  if (a.empty() || b.empty()) return 0.0;
  const auto& small = a.size() < b.size() ? a : b;
  const auto& large = a.size() < b.size() ? b : a;
  size_t inter = 0;
  for (VoxelKey k : small) inter += large.count(k);
  return static_cast<double>(inter) / static_cast<double>(small.size());
}

double Within(const VoxelSet& a, const VoxelSet& b) {
  if (a.empty()) return 0.0;
  size_t inter = 0;
  for (VoxelKey k : a) inter += b.count(k);
  return static_cast<double>(inter) / static_cast<double>(a.size());
}

ObjectMap::ObjectMap(const FusionOptions& options, double voxel_m)
    : options_(options), voxel_m_(voxel_m) {}

FusedObject ObjectMap::NewObject(int64_t id) const {
  return FusedObject(
      id, voxel_m_, options_.centroid_from_box,
      LabelDistribution(options_.label_universe, options_.min_likelihood),
      {options_.support_cell_m, options_.min_support_fraction, options_.centroid_min_part,
       options_.flat_top_classes, options_.flat_top_margin_m, options_.shape_min_label_views,
       options_.bottom_quantile});
}

namespace {

// Volume of the intersection of two boxes over the smaller box's volume (0 when either is flat).
double BoxContainment(const MapObject& a, const MapObject& b) {
  const Eigen::Vector3d lo = a.aabb_min_m.cwiseMax(b.aabb_min_m);
  const Eigen::Vector3d hi = a.aabb_max_m.cwiseMin(b.aabb_max_m);
  if ((hi.array() <= lo.array()).any()) return 0.0;
  const double smaller =
      std::min((a.aabb_max_m - a.aabb_min_m).prod(), (b.aabb_max_m - b.aabb_min_m).prod());
  return smaller > 0 ? (hi - lo).prod() / smaller : 0.0;
}

}  // namespace

bool ObjectMap::FitsClass(const std::string& class_name, double size_m) const {
  if (options_.class_size_slack <= 0) return true;
  const auto it = options_.max_size_m.find(class_name);
  return it == options_.max_size_m.end() || size_m <= options_.class_size_slack * it->second;
}

bool ObjectMap::FitsClassShape(const FusedObject& object) const {
  const std::string class_name = object.labels().Argmax();
  if (!FitsClass(class_name, 2.0 * object.half_size_m())) return false;
  const auto it = options_.max_thickness_m.find(class_name);
  return it == options_.max_thickness_m.end() || 2.0 * object.obb_half_m().minCoeff() <= it->second;
}

bool ObjectMap::ClassesFit(const std::string& class_a, double size_a_m, const std::string& class_b,
                           double size_b_m) const {
  if (class_a == class_b) return true;
  // Furniture and what stands on it are two things, whatever their sizes: part of a desk top
  // seen beside a book is not that book.
  if (IsFlatTopClass(options_.flat_top_classes, class_a) !=
      IsFlatTopClass(options_.flat_top_classes, class_b)) {
    return false;
  }
  return FitsClass(class_a, size_b_m) && FitsClass(class_b, size_a_m);
}

double ObjectMap::AssociationScore(const FusedObject& object, const MapObservation& obs,
                                   const VoxelSet& obs_keys) const {
  const double d = (object.centroid_m() - obs.centroid_m).norm();
  double score = 0;
  if (d < options_.track_gate_m && object.HasTrack(obs.session_row, obs.track_id)) {
    score += options_.weight_track;
  }
  if (d < options_.max_centroid_distance_m &&
      SizeCompatible(object.half_size_m(), obs.half_size_m)) {
    score += options_.weight_centroid;
  }
  // The overlap is only worth computing for objects that can be near. A partial view (cut by
  // the image border, half hidden) lies inside the object without overlapping most of it: it
  // counts when it is contained and of a compatible size.
  if (options_.weight_overlap > 0 && d < options_.track_gate_m) {
    const VoxelSet keys = object.KeysAt(options_.overlap_voxel_m);
    const bool overlap = VoxelOverlap(keys, obs_keys) > options_.min_overlap;
    const bool contained = options_.assoc_containment < 1 &&
                           SizeCompatible(object.half_size_m(), obs.half_size_m) &&
                           Within(obs_keys, keys) > options_.assoc_containment;
    if (overlap || contained) score += options_.weight_overlap;
  }
  return score;
}

double ObjectMap::RangeMergeGate(const FusedObject& a, const FusedObject& b) const {
  const double ra = a.nearest_range_m(), rb = b.nearest_range_m();
  if (options_.merge_sigmas <= 0 || ra <= 0 || rb <= 0) return 0.0;
  // Both objects at the nearer one's range: a well-placed near object does not take in whatever
  // a far view put beside it (the far blob's own uncertainty would let it).
  const double r = std::min(ra, rb);
  const double depth = options_.depth_sigma_at_1m * r * r, view = options_.view_sigma_rad * r;
  return options_.merge_sigmas * std::sqrt(2 * (depth * depth + view * view));
}

bool ObjectMap::SizeCompatible(double half_a_m, double half_b_m) const {
  const double lo = std::max(std::min(half_a_m, half_b_m), 0.02);
  return std::max(half_a_m, half_b_m) / lo <= options_.max_size_ratio;
}

void ObjectMap::HitWithoutPoints(const MapObservation& obs, const std::vector<int64_t>& object_ids,
                                 const ClassDetectionRates& rates,
                                 std::vector<ObjectChange>* changes) {
  for (int64_t id : object_ids) {
    FusedObject& object = objects_.at(id);
    for (int64_t other : object_ids) {
      if (other != id) object.AddStraddled(other);
    }
    object.Observe(obs.class_name, obs.score, obs.session_row, obs.track_id, obs.robot,
                   obs.keyframe_id, obs.t_ns);
    Judge(&object, rates);
    changes->push_back({ObjectChange::Kind::kUpdated, id, 0, {}});
  }
}

std::vector<int64_t> ObjectMap::Integrate(const std::vector<MapObservation>& observations,
                                          std::vector<ObjectChange>* changes,
                                          std::vector<int64_t>* straddled_ids) {
  std::vector<int64_t> ids;
  ids.reserve(observations.size());
  const ClassDetectionRates rates = Rates();
  for (const MapObservation& obs : observations) {
    VoxelSet keys;
    for (const ColoredPoint& p : obs.points_m) {
      keys.insert(KeyOf(p.p_m.cast<double>(), options_.overlap_voxel_m));
    }
    if (const std::vector<int64_t> held = StraddledFurniture(obs, keys); !held.empty()) {
      HitWithoutPoints(obs, held, rates, changes);
      if (straddled_ids != nullptr)
        straddled_ids->insert(straddled_ids->end(), held.begin(), held.end());
      ids.push_back(0);  // in no object: its points stay unlabelled cloud
      continue;
    }
    int64_t best_id = 0;
    double best_score = 0, best_d = 0;
    for (const auto& [id, object] : objects_) {
      if (!ClassesFit(object.labels().Argmax(), 2 * object.half_size_m(), obs.class_name,
                      2 * obs.half_size_m)) {
        continue;
      }
      const double s = AssociationScore(object, obs, keys);
      const double d = (object.centroid_m() - obs.centroid_m).norm();
      if (s >= options_.score_threshold && (s > best_score || (s == best_score && d < best_d))) {
        best_id = id;
        best_score = s;
        best_d = d;
      }
    }
    ObjectChange::Kind kind = ObjectChange::Kind::kUpdated;
    if (best_id == 0) {
      best_id = next_id_++;
      objects_.emplace(best_id, NewObject(best_id));
      kind = ObjectChange::Kind::kCreated;
    }
    FusedObject& object = objects_.at(best_id);
    object.AddPoints(obs.points_m, obs.class_name);
    object.Observe(obs.class_name, obs.score, obs.session_row, obs.track_id, obs.robot,
                   obs.keyframe_id, obs.t_ns);
    object.ObserveRange(obs.range_m);
    Judge(&object, rates);
    changes->push_back({kind, best_id, 0, {}});
    const int64_t id = MergeDuplicates(best_id, changes);
    JudgeParts(id, rates, changes);
    JudgeStraddlers(id, rates, changes);
    ids.push_back(id);
  }
  for (int64_t& id : ids) id = Resolve(id);
  return ids;
}

const char* ObjectMap::Duplicates(const FusedObject& self, const FusedObject& other,
                                  VoxelSet* self_keys, std::optional<MapObject>* self_box) const {
  // Other classes merge only with an object of a compatible size (a monitor labelled "laptop"
  // on blurred frames), never a keyboard with the desk it lies on; the label distributions then
  // settle the class.
  const std::string cls = self.labels().Argmax(), other_cls = other.labels().Argmax();
  const bool same_class = other_cls == cls;
  if (!same_class &&
      (!options_.merge_across_classes || !SizeCompatible(self.half_size_m(), other.half_size_m()) ||
       !ClassesFit(cls, 2 * self.half_size_m(), other_cls, 2 * other.half_size_m()))) {
    return nullptr;
  }
  if (same_class && options_.straddle_apart_views > 0 &&
      self.StraddledWith(other.id(), [this](int64_t id) { return Resolve(id); }) >=
          options_.straddle_apart_views) {
    return nullptr;  // a view left out because the map held these two apart
  }
  const double d = (other.centroid_m() - self.centroid_m()).norm();
  if (d < options_.merge_centroid_m) return "centroids";
  if (d >= options_.track_gate_m + 1.0) return nullptr;
  if (same_class && d < RangeMergeGate(self, other)) return "range uncertainty";
  // Objects compare the voxels that shape them (a keyboard that took in "laptop" views of the
  // monitor behind it does not hold the monitor); furniture, pieced together from partial views,
  // compares all of its voxels, with its own stricter containment.
  const bool furniture = IsFlatTopClass(options_.flat_top_classes, cls);
  auto keys_of = [&](const FusedObject& o) {
    return furniture ? o.KeysAt(options_.overlap_voxel_m) : o.ShapeKeysAt(options_.overlap_voxel_m);
  };
  if (self_keys->empty()) *self_keys = keys_of(self);
  const double containment = same_class && furniture && options_.furniture_merge_containment > 0
                                 ? options_.furniture_merge_containment
                                 : options_.merge_containment;
  if (VoxelContainment(*self_keys, keys_of(other)) > containment) {
    return "voxel containment";
  }
  if (same_class && options_.furniture_footprint_containment > 0 &&
      IsFlatTopClass(options_.flat_top_classes, cls) &&
      VoxelContainment(FootprintOf(self, options_.overlap_voxel_m),
                       FootprintOf(other, options_.overlap_voxel_m)) >
          options_.furniture_footprint_containment &&
      !LiesAcrossTables(self) && !LiesAcrossTables(other)) {
    return "footprint containment";
  }
  // Not for tables: their map-frame boxes are no solids. Two desks back to back that lie
  // diagonally to the map's axes have boxes that hold each other (fr1_rpy, session 26).
  if (!same_class || options_.merge_box_containment >= 1 ||
      IsFlatTopClass(options_.flat_top_classes, cls)) {
    return nullptr;
  }
  if (!*self_box) *self_box = self.Snapshot();
  return BoxContainment(**self_box, other.Snapshot()) > options_.merge_box_containment
             ? "box containment"
             : nullptr;
}

int64_t ObjectMap::MergeDuplicates(int64_t id, std::vector<ObjectChange>* changes) {
  bool merged = true;
  while (merged) {
    merged = false;
    const FusedObject& self = objects_.at(id);
    VoxelSet self_keys;
    std::optional<MapObject> self_box;
    for (const auto& [other_id, other] : objects_) {
      if (other_id == id) continue;
      const char* rule = Duplicates(self, other, &self_keys, &self_box);
      if (rule == nullptr) continue;
      id = Merge(id, other_id, rule, changes);
      merged = true;
      break;
    }
  }
  return id;
}

int64_t ObjectMap::Merge(int64_t a, int64_t b, const char* rule,
                         std::vector<ObjectChange>* changes) {
  const FusedObject& first = objects_.at(a);
  const FusedObject& second = objects_.at(b);
  spdlog::debug("objects {} ({}, {} views) and {} ({}, {} views) merged by {}, {:.2f} m apart", a,
                first.labels().Argmax(), first.observation_count(), b, second.labels().Argmax(),
                second.observation_count(), rule,
                (second.centroid_m() - first.centroid_m()).norm());
  // The older object survives, so ids handed out earlier stay valid where possible.
  const int64_t keep = std::min(a, b), drop = std::max(a, b);
  objects_.at(keep).Absorb(objects_.at(drop));
  Judge(&objects_.at(keep), Rates());
  ObjectChange removed{ObjectChange::Kind::kRemoved, drop, 0, objects_.at(drop).Snapshot()};
  objects_.erase(drop);
  merged_into_[drop] = keep;
  changes->push_back({ObjectChange::Kind::kMerged, keep, drop, {}});
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
    changes->push_back({ObjectChange::Kind::kUpdated, id, 0, {}});
  }
  for (int64_t object_id : moved) {
    const int64_t id = Resolve(object_id);
    if (objects_.count(id)) MergeDuplicates(id, changes);
  }
  // Parts, stands and straddling pieces are judged by where things lie, which the move changed:
  // judged again as after an observation.
  const ClassDetectionRates rates = Rates();
  std::set<int64_t> judged;
  for (int64_t object_id : moved) {
    const int64_t id = Resolve(object_id);
    auto it = objects_.find(id);
    if (it == objects_.end() || !judged.insert(id).second) continue;
    const bool was_confirmed = it->second.confirmed();
    Judge(&it->second, rates);
    if (it->second.confirmed() != was_confirmed) {
      changes->push_back({ObjectChange::Kind::kUpdated, id, 0, {}});
    }
    JudgeParts(id, rates, changes);
    JudgeStraddlers(id, rates, changes);
  }
}

void ObjectMap::ObserveView(int64_t keyframe_id, const KeyframeView& view,
                            const std::vector<int64_t>& observed_ids,
                            std::vector<ObjectChange>* changes) {
  std::unordered_set<int64_t> observed;
  for (int64_t id : observed_ids) observed.insert(Resolve(id));
  std::vector<int64_t> gone;
  const ClassDetectionRates rates = Rates();
  for (auto& [id, object] : objects_) {
    if (observed.count(id)) continue;
    if (!ExpectedInView(object.sample_m(), object.half_size_m(), view, options_.visibility)) {
      continue;
    }
    object.Miss(keyframe_id);
    if (Judge(&object, rates) <= options_.remove_llr) {
      gone.push_back(id);
    }
  }
  for (int64_t id : gone) {
    const FusedObject& object = objects_.at(id);
    spdlog::debug("object {} ({}, {} views, {} missed) removed: too many views missed it", id,
                  object.labels().Argmax(), object.observation_count(), object.misses());
    changes->push_back({ObjectChange::Kind::kRemoved, id, 0, object.Snapshot()});
    objects_.erase(id);
  }
}

ClassDetectionRates ObjectMap::Rates() const {
  ClassDetectionRates rates({options_.existence_p_real, options_.existence_p_false},
                            options_.existence_class_prior_views);
  for (const auto& [id, object] : objects_) {
    if (object.confirmed()) rates.Add(object);
  }
  return rates;
}

double ObjectMap::Judge(FusedObject* object, const ClassDetectionRates& rates) const {
  const auto min_span_ns = static_cast<int64_t>(options_.confirm_min_span_s * 1e9);
  // A fused 0.4 m "mouse" is a wrong label or a box smeared over what lies around it, and a
  // 0.4 m thick "tv" is the wall around a screen without depth: it stays a candidate (its
  // evidence kept) while its size or shape does not fit its class.
  const bool size_fits = FitsClassShape(*object);
  object->UpdateConfirmed(options_.confirm_observations, min_span_ns, rates.For(*object),
                          options_.confirm_llr, size_fits);
  // A piece of furniture carrying things is a real top however rarely it is boxed
  // (TopLoadOptions::confirm_loads): views and span as above, no existence test, no removal.
  const bool held_up = !object->confirmed() && size_fits && HeldUpByLoads(*object);
  if (held_up) {
    object->UpdateConfirmed(options_.confirm_observations, min_span_ns, rates.For(*object),
                            -std::numeric_limits<double>::infinity(), size_fits);
  }
  // So does a part of another object (object_parts.cc) and a piece of furniture lying across two
  // others (object_straddlers.cc); only asked of an object that would be confirmed, the tests
  // read voxels.
  if (object->confirmed() && (WholeOf(*object) != 0 || LiesAcrossTables(*object))) {
    object->UpdateConfirmed(options_.confirm_observations, min_span_ns, rates.For(*object),
                            options_.confirm_llr, false);
  }
  return held_up ? std::numeric_limits<double>::infinity() : object->ExistenceLlr(rates.base());
}

bool ObjectMap::HeldUpByLoads(const FusedObject& piece) const {
  const TopLoadOptions& o = options_.top_loads;
  const int min_views = std::max(options_.confirm_observations, o.rival_min_views);
  if (o.confirm_loads <= 0 || static_cast<int>(piece.observation_count()) < min_views ||
      !IsFlatTopClass(options_.flat_top_classes, piece.labels().Argmax())) {
    return false;
  }
  // Only what comes within reach of the piece can rest on it, and only tables within reach of
  // such a thing compete for it (RestsOn): the rest of the map is not copied.
  const auto near = [&](const FusedObject& a, const FusedObject& b) {
    return FootprintDistanceM(a.aabb_min_m(), a.aabb_max_m(), b.aabb_min_m(), b.aabb_max_m()) <=
           o.reach_m;
  };
  std::vector<const FusedObject*> loads;
  for (const auto& [id, object] : objects_) {
    if (near(object, piece)) loads.push_back(&object);
  }
  std::vector<MapObject> nearby;
  for (const auto& [id, object] : objects_) {
    const auto near_object = [&](const FusedObject* load) { return near(object, *load); };
    if (std::any_of(loads.begin(), loads.end(), near_object)) nearby.push_back(object.Snapshot());
  }
  return LoadsHeldBy(piece.id(), options_.flat_top_classes, o, nearby) >= o.confirm_loads;
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

std::vector<MapObject> ObjectMap::WidenedSnapshot(bool confirmed_only) const {
  std::vector<MapObject> out;
  for (const auto& [id, object] : objects_) {
    // Unconfirmed furniture takes part in the widening of tables (TopLoadOptions).
    if (confirmed_only && !object.confirmed() &&
        !IsFlatTopClass(options_.flat_top_classes, object.labels().Argmax())) {
      continue;
    }
    out.push_back(object.Snapshot());
  }
  ExtendTopsUnderLoads(options_.flat_top_classes, options_.top_loads, &out);
  return out;
}

std::vector<MapObject> ObjectMap::Snapshot(bool confirmed_only) const {
  std::vector<MapObject> out = WidenedSnapshot(confirmed_only);
  LowerLoadsOntoTops(options_.flat_top_classes, options_.top_loads, &out);
  if (confirmed_only) {
    const auto unconfirmed = [](const MapObject& o) { return !o.confirmed; };
    out.erase(std::remove_if(out.begin(), out.end(), unconfirmed), out.end());
  }
  return out;
}

std::optional<MapObject> ObjectMap::SnapshotOf(int64_t id) const {
  std::vector<std::optional<MapObject>> one = SnapshotsOf({id});
  return std::move(one[0]);
}

std::vector<std::optional<MapObject>> ObjectMap::SnapshotsOf(
    const std::vector<int64_t>& ids) const {
  std::vector<std::optional<MapObject>> out(ids.size());
  bool whole_map = false;  // tables widen under their loads, loads reach down to their tables
  for (size_t i = 0; i < ids.size(); ++i) {
    const FusedObject* object = Find(ids[i]);
    if (object == nullptr) continue;
    out[i] = object->Snapshot();
    const bool table = IsFlatTopClass(options_.flat_top_classes, out[i]->class_name);
    whole_map |= out[i]->confirmed && (table || options_.top_loads.lower_loads);
  }
  if (!whole_map) return out;
  std::unordered_map<int64_t, MapObject> shown;
  for (MapObject& o : Snapshot(/*confirmed_only=*/true)) shown.emplace(o.id, std::move(o));
  for (size_t i = 0; i < ids.size(); ++i) {
    const auto it = out[i] ? shown.find(ids[i]) : shown.end();
    if (it != shown.end()) out[i] = it->second;
  }
  return out;
}

std::vector<MapObject> ObjectMap::TablesUnder(const std::vector<MapObject>& loads) const {
  std::vector<MapObject> tables;
  if (loads.empty() || options_.top_loads.reach_m <= 0) return tables;
  std::vector<MapObject> all = Snapshot(/*confirmed_only=*/true);
  const std::vector<int64_t> ids =
      TablesUnderLoads(options_.flat_top_classes, options_.top_loads, loads, all);
  for (MapObject& o : all) {
    if (std::find(ids.begin(), ids.end(), o.id) != ids.end()) tables.push_back(std::move(o));
  }
  return tables;
}

std::vector<MapObject> ObjectMap::LoadsOnTables(const std::vector<MapObject>& changed) const {
  std::vector<MapObject> loads;
  std::vector<int64_t> table_ids;
  for (const MapObject& o : changed) {
    if (IsFlatTopClass(options_.flat_top_classes, o.class_name)) table_ids.push_back(o.id);
  }
  if (table_ids.empty() || !options_.top_loads.lower_loads) return loads;
  std::vector<MapObject> all = WidenedSnapshot(/*confirmed_only=*/true);
  const std::vector<int64_t> ids =
      LoadsLoweredOnto(table_ids, options_.flat_top_classes, options_.top_loads, all);
  if (ids.empty()) return loads;
  LowerLoadsOntoTops(options_.flat_top_classes, options_.top_loads, &all);
  for (MapObject& o : all) {
    if (std::find(ids.begin(), ids.end(), o.id) != ids.end()) loads.push_back(std::move(o));
  }
  return loads;
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

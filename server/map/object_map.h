// Object database of the map: associates each keyframe's object observations with fused objects
// and merges duplicates by one rule set (object_association.h; paper 000 3.3), and keeps each
// object's existence belief from the keyframes that saw it and those that should have
// (FusedObject::ExistenceLogOdds). server/map/README.md explains the model.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "common/map_object.h"
#include "server/map/fused_object.h"
#include "server/map/map_options.h"
#include "server/map/object_association.h"
#include "server/map/visibility.h"

namespace loci::store::v1 {
class ObjectMapState;
}  // namespace loci::store::v1

namespace loci::server {

// One object observation moved into the map frame.
struct MapObservation {
  int64_t session_row = 0;
  std::string robot;
  int64_t keyframe_id = 0;
  int64_t t_ns = 0;
  int64_t track_id = 0;  // 0 = untracked
  std::string class_name;
  double score = 0;
  std::vector<ColoredPoint> points_m;  // map frame
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
  double half_size_m = 0;  // half the longest side of its points' box
  double range_m = 0;      // distance from the keyframe's camera to the centroid (0: unknown)
};

struct ObjectChange {
  enum class Kind { kCreated, kUpdated, kMerged, kRemoved, kMoved };
  Kind kind = Kind::kUpdated;
  int64_t object_id = 0;
  int64_t merged_from_id = 0;  // kMerged: the absorbed object
  // kRemoved: the object's last state before it went (object_id = its id, which now resolves to
  // the object that absorbed it).
  MapObject removed_state;
  // kRemoved by its existence belief: the keyframes that should have seen it since it was last
  // seen and did not, oldest first, and the newest one's time.
  std::vector<int64_t> evidence_keyframe_ids;
  int64_t evidence_t_ns = 0;
  // kMoved (object_id seen again at a new place; evidence as for kRemoved): its earlier place.
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero();
};

// A change with its kind and ids set, the rest empty.
ObjectChange ChangeOf(ObjectChange::Kind kind, int64_t object_id, int64_t merged_from_id = 0);

class ObjectMap {
 public:
  // voxel_m: edge of the fused object clouds (ObservationOptions::voxel_m).
  ObjectMap(const FusionOptions& options, double voxel_m);

  // Integrates one keyframe's observations; returns the object id of each (after merges) and
  // appends the changes.
  std::vector<int64_t> Integrate(const std::vector<MapObservation>& observations,
                                 std::vector<ObjectChange>* changes);

  // Negative evidence of one keyframe (stamped t_ns): every object not observed in it
  // (observed_ids) that the view should have shown takes a miss; objects whose existence falls
  // are unconfirmed (kUpdated), or removed (kRemoved).
  void ObserveView(int64_t keyframe_id, int64_t t_ns, const KeyframeView& view,
                   const std::vector<int64_t>& observed_ids, std::vector<ObjectChange>* changes);

  // A keyframe moved: its observation of `object_id` (merges followed) takes its points out
  // (old_m, as added) and back in at new_m. False when the object is gone (removed for lack of
  // evidence). Call MergeMoved after the last move.
  // class_name: the observation's detected class.
  bool MoveObservation(int64_t object_id, const std::vector<ColoredPoint>& old_m,
                       const std::vector<ColoredPoint>& new_m, const std::string& class_name);
  // After moves: recomputes the moved objects' geometry (one kUpdated each), merges those that
  // now coincide with others (kMerged + kRemoved) and judges the moved objects again.
  void MergeMoved(const std::vector<int64_t>& object_ids, std::vector<ObjectChange>* changes);

  // Forgets every object (the map is re-derived); ids keep counting up.
  void Clear() {
    objects_.clear();
    merged_into_.clear();
    gone_.clear();
    history_.clear();
  }

  // Follows merges: the id an object id lives on as (0 stays 0).
  int64_t Resolve(int64_t id) const;
  const FusedObject* Find(int64_t id) const;
  // Every object (or the confirmed ones) as queries and exports see it.
  std::vector<MapObject> Snapshot(bool confirmed_only) const;
  // One object as Snapshot shows it; nullopt when there is no such object (ids not resolved).
  std::optional<MapObject> SnapshotOf(int64_t id) const;
  // Several objects as Snapshot shows them.
  std::vector<std::optional<MapObject>> SnapshotsOf(const std::vector<int64_t>& ids) const;
  // The confirmed objects found gone (removed_t_ns set), with their history, oldest id first.
  std::vector<MapObject> Removed() const;
  // One of them (ids not resolved).
  std::optional<MapObject> RemovedOf(int64_t id) const;
  size_t size() const { return objects_.size(); }
  size_t confirmed_count() const;

  // Ids of new objects start here (default 1). Only before the first object: a map island's
  // objects (server/runtime/island_maps.h) take ids that no shared-map object takes.
  Status SetFirstId(int64_t first_id);

  // Checkpoint state (map_checkpoint.cc); LoadState replaces every object.
  void SaveState(loci::store::v1::ObjectMapState* out) const;
  Status LoadState(const loci::store::v1::ObjectMapState& in);

 private:
  // An empty object with the map's options.
  FusedObject NewObject(int64_t id) const;
  FusedObject::ExistenceModel Existence(const FusedObject& object) const;
  // Sets whether `object` is confirmed: its belief reaches confirm_belief and its fused shape
  // fits its most likely class (class data; a fused 0.4 m "mouse" is a smeared mask). Returns
  // its existence log-odds, which decides removal.
  double Judge(FusedObject* object) const;
  // The object's size and thickness fit its most likely class (class_size_slack).
  bool FitsClassShape(const FusedObject& object) const;
  // What the association rules read of an object; keys and footprint are filled into the given
  // sets, which must outlive the view.
  AssociationView ViewOf(const FusedObject& object, VoxelSet* keys, VoxelSet* footprint) const;
  // The best object for an observation (object_association.h), or 0.
  int64_t BestObjectFor(const MapObservation& obs, const VoxelSet& obs_keys) const;
  // Merges duplicates of `id` into the older object (a kMerged change for the survivor, then a
  // kRemoved one for the absorbed object); returns the surviving id.
  int64_t MergeDuplicates(int64_t id, std::vector<ObjectChange>* changes);
  // Merges objects a and b into the older one (the changes as above); returns the survivor.
  int64_t Merge(int64_t a, int64_t b, std::vector<ObjectChange>* changes);

  // Place history (object_history.cc). A confirmed object without history appears, or is a
  // gone one seen again at a new place; a confirmed one whose belief falls is gone, or moved to
  // a new one. Both append their changes.
  void TrackPlaces(std::vector<ObjectChange>* changes);
  void OnConfirmed(int64_t id, std::vector<ObjectChange>* changes);
  void OnGone(int64_t id, std::vector<ObjectChange>* changes);
  // `after` may be `before` seen again at a new place: the same likely class and size, first
  // seen after `before` was last seen. Of several, the nearest is taken.
  bool CouldBeMoved(const FusedObject& before, const FusedObject& after) const;
  // The removed or doubted object that `object` is at a new place (0: none), and the newly
  // confirmed object that a doubted `object` is at its new place (0: none).
  int64_t MovedFrom(const FusedObject& object) const;
  int64_t FreshTwinOf(const FusedObject& object) const;
  // Moves a live object to the removed ones; returns its removal, not yet in its history.
  ObjectPlaceChange Withdraw(int64_t id);
  // `fresh_id` becomes `old_id` at its new place (`moved`: kMoved, or kAppeared when it is
  // back where it was): kRemoved of the provisional id, then kMoved (kCreated) of old_id with
  // the evidence that the old place was empty.
  void Adopt(int64_t old_id, int64_t fresh_id, ObjectPlaceChange moved,
             std::vector<ObjectChange>* changes);
  MapObject SnapshotWithHistory(const FusedObject& object) const;

  FusionOptions options_;
  ObjectAssociation association_;
  double voxel_m_;
  int64_t next_id_ = 1;
  std::map<int64_t, FusedObject> objects_;
  std::unordered_map<int64_t, int64_t> merged_into_;
  std::map<int64_t, FusedObject> gone_;  // confirmed objects found gone, by id
  std::map<int64_t, std::vector<ObjectPlaceChange>> history_;  // by id, of objects_ and gone_
};

}  // namespace loci::server

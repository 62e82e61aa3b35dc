// Object database of the map: associates each keyframe's object observations with fused objects
// (same session + track id, centroid distance, voxel overlap M; paper 000 3.3), creates
// candidates, confirms them after enough keyframes and merges duplicates.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "common/map_object.h"
#include "server/map/class_detection_rates.h"
#include "server/map/fused_object.h"
#include "server/map/map_options.h"
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
  enum class Kind { kCreated, kUpdated, kMerged, kRemoved };
  Kind kind = Kind::kUpdated;
  int64_t object_id = 0;
  int64_t merged_from_id = 0;  // kMerged: the absorbed object
  // kRemoved: the object's last state before it went (object_id = its id, which now resolves to
  // the object that absorbed it).
  MapObject removed_state;
};

// M = |A∩B| / (|A| + |B| - |A∩B|) of two voxel sets (0 when both are empty).
double VoxelOverlap(const VoxelSet& a, const VoxelSet& b);
// |A∩B| / min(|A|, |B|).
double VoxelContainment(const VoxelSet& a, const VoxelSet& b);
// |A∩B| / |A|: the share of A inside B (0 when A is empty).
double Within(const VoxelSet& a, const VoxelSet& b);
// The cells of a horizontal grid (the map frame is z-up) under the object's voxels.
VoxelSet FootprintOf(const FusedObject& object, double cell_m);

class ObjectMap {
 public:
  // voxel_m: edge of the fused object clouds (ObservationOptions::voxel_m).
  ObjectMap(const FusionOptions& options, double voxel_m);

  // Weighted association score of an observation with an object (see FusionOptions).
  double AssociationScore(const FusedObject& object, const MapObservation& obs,
                          const VoxelSet& obs_keys) const;

  // Integrates one keyframe's observations; returns the object id of each (after merges; 0 for
  // a view of furniture that straddles two objects, StraddledFurniture) and appends the changes.
  // straddled_ids (may be null) receives the objects such views saw: a hit each, no points.
  std::vector<int64_t> Integrate(const std::vector<MapObservation>& observations,
                                 std::vector<ObjectChange>* changes,
                                 std::vector<int64_t>* straddled_ids = nullptr);

  // Negative evidence of one keyframe: every object not observed in it (observed_ids) that
  // the view should have shown takes a miss; objects whose existence falls are unconfirmed, or
  // removed (kRemoved changes).
  void ObserveView(int64_t keyframe_id, const KeyframeView& view,
                   const std::vector<int64_t>& observed_ids, std::vector<ObjectChange>* changes);

  // A keyframe moved: its observation of `object_id` (merges followed) takes its points out
  // (old_m, as added) and back in at new_m. False when the object is gone (removed for lack of
  // evidence). Call MergeMoved after the last move.
  // class_name: the observation's detected class.
  bool MoveObservation(int64_t object_id, const std::vector<ColoredPoint>& old_m,
                       const std::vector<ColoredPoint>& new_m, const std::string& class_name);
  // After moves: recomputes the moved objects' geometry (one kUpdated each), merges those that
  // now coincide with others (kMerged + kRemoved), then judges the moved objects and the parts
  // and pieces near them again (kUpdated for each whose confirmation changed).
  void MergeMoved(const std::vector<int64_t>& object_ids, std::vector<ObjectChange>* changes);

  // Forgets every object (the map is re-derived); ids keep counting up.
  void Clear() {
    objects_.clear();
    merged_into_.clear();
  }

  // Follows merges: the id an object id lives on as (0 stays 0).
  int64_t Resolve(int64_t id) const;
  const FusedObject* Find(int64_t id) const;
  // Every object (or the confirmed ones) as queries and exports see it: tables widened under
  // what rests on them, and what rests on them reaching down to their tops
  // (FusionOptions::top_loads).
  std::vector<MapObject> Snapshot(bool confirmed_only) const;
  // One object as Snapshot shows it; nullopt when there is no such object (ids not resolved).
  std::optional<MapObject> SnapshotOf(int64_t id) const;
  // Several objects as Snapshot shows them, from one snapshot of the map (an event batch).
  std::vector<std::optional<MapObject>> SnapshotsOf(const std::vector<int64_t>& ids) const;
  // The confirmed tables that one of `loads` rests on, as Snapshot shows them (TablesUnderLoads).
  std::vector<MapObject> TablesUnder(const std::vector<MapObject>& loads) const;
  // The confirmed loads lowered onto one of the tables among `changed`, as Snapshot shows them
  // (LoadsLoweredOnto): they move with their table's top.
  std::vector<MapObject> LoadsOnTables(const std::vector<MapObject>& changed) const;
  size_t size() const { return objects_.size(); }
  size_t confirmed_count() const;

  // Ids of new objects start here (default 1). Only before the first object: a map island's
  // objects (server/service/island_maps.h) take ids that no shared-map object takes.
  Status SetFirstId(int64_t first_id);

  // Checkpoint state (map_checkpoint.cc); LoadState replaces every object.
  void SaveState(loci::store::v1::ObjectMapState* out) const;
  Status LoadState(const loci::store::v1::ObjectMapState& in);

 private:
  // Snapshot before loads are lowered onto their tables (LowerLoadsOntoTops).
  std::vector<MapObject> WidenedSnapshot(bool confirmed_only) const;
  // An empty object with the map's options.
  FusedObject NewObject(int64_t id) const;
  // The existence models of this moment: per-class detection rates of the confirmed objects.
  ClassDetectionRates Rates() const;
  // Re-decides whether `object` is confirmed by the model `rates` gives it, or by the loads it
  // holds up (HeldUpByLoads). Returns its LLR by the base model (infinite when held up), which
  // decides removal: an object its class's rate leaves unconfirmed stays as a candidate and
  // keeps its evidence (removed, a box recurring at one spot would come back as a new object and
  // be confirmed again before its misses add up).
  double Judge(FusedObject* object, const ClassDetectionRates& rates) const;
  // Flat-topped furniture that TopLoadOptions::confirm_loads confirmed things rest on.
  bool HeldUpByLoads(const FusedObject& piece) const;
  // Flat-topped furniture (FusionOptions::straddle_share): the objects a view of it lies on by at
  // least that share of its voxels each, when there are two or more and two of them lie apart
  // (one detector box over two desks back to back), else none. Its points would join them: such a
  // view counts as a hit for each and adds no points.
  std::vector<int64_t> StraddledFurniture(const MapObservation& obs,
                                          const VoxelSet& obs_keys) const;
  // The observation counts as a hit for each object (labels, keyframes, existence), without
  // its points.
  void HitWithoutPoints(const MapObservation& obs, const std::vector<int64_t>& object_ids,
                        const ClassDetectionRates& rates, std::vector<ObjectChange>* changes);
  // Whether the two are one object (MergeDuplicates' rules): the rule that says so, else null;
  // self_keys and self_box cache self's voxel keys and box.
  const char* Duplicates(const FusedObject& self, const FusedObject& other, VoxelSet* self_keys,
                         std::optional<MapObject>* self_box) const;
  // An object of size_m (longest side) can be of the class (FusionOptions::class_size_slack).
  bool FitsClass(const std::string& class_name, double size_m) const;
  // The object's size and thickness fit its most likely class (FusionOptions::max_thickness_m).
  bool FitsClassShape(const FusedObject& object) const;
  // Same class, or each one's size fits the other's class and neither or both are flat-topped
  // furniture (FusionOptions::flat_top_classes).
  bool ClassesFit(const std::string& class_a, double size_a_m, const std::string& class_b,
                  double size_b_m) const;
  // Largest half extents within FusionOptions::max_size_ratio of each other.
  bool SizeCompatible(double half_a_m, double half_b_m) const;
  // Centroid distance under which two objects are one by their range uncertainty
  // (FusionOptions::merge_sigmas); 0 when off or a range is unknown.
  double RangeMergeGate(const FusedObject& a, const FusedObject& b) const;
  // Merges duplicates of `id` into the older object (a kMerged change for the survivor, then a
  // kRemoved one for the absorbed object); returns the surviving id.
  int64_t MergeDuplicates(int64_t id, std::vector<ObjectChange>* changes);
  // Merges objects a and b into the older one (the changes as above; `rule` is logged); returns
  // the surviving id.
  int64_t Merge(int64_t a, int64_t b, const char* rule, std::vector<ObjectChange>* changes);

  // Parts (object_parts.cc, FusionOptions::part_containment). `whole` can hold `part`:
  // another class, larger, seen at least as often, near, not flat-topped furniture nor a
  // never_part_of class.
  bool CanHoldPart(const FusedObject& whole, const FusedObject& part) const;
  // `part` lies under the middle of `whole`, a stand class: its stand (object_parts.cc).
  bool StandsUnder(const FusedObject& whole, const FusedObject& part) const;
  // The object holding at least part_containment of `part`'s voxels, or standing it, else 0.
  int64_t WholeOf(const FusedObject& part) const;
  // Judges again the objects that `id` (just observed) can hold: whether they are its parts may
  // have changed (a kUpdated change for each whose confirmation changed).
  void JudgeParts(int64_t id, const ClassDetectionRates& rates,
                  std::vector<ObjectChange>* changes);
  // Straddling pieces (object_straddlers.cc, FusionOptions::straddle_pieces): `piece` is
  // flat-topped furniture lying across two confirmed such objects apart from each other.
  bool LiesAcrossTables(const FusedObject& piece) const;
  // Whether two of these pieces of furniture lie apart: neither's footprint lies by
  // straddle_share on the other.
  bool HoldsPiecesApart(const std::vector<int64_t>& piece_ids) const;
  // Judges again the flat-topped furniture near `id` (just observed), as JudgeParts does.
  void JudgeStraddlers(int64_t id, const ClassDetectionRates& rates,
                       std::vector<ObjectChange>* changes);

  FusionOptions options_;
  double voxel_m_;
  int64_t next_id_ = 1;
  std::map<int64_t, FusedObject> objects_;
  std::unordered_map<int64_t, int64_t> merged_into_;
};

}  // namespace loci::server

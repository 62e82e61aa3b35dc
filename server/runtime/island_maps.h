// Map islands: the object maps of robot sessions that place recognition has not
// aligned to the shared map yet. Each such session's keyframes are mapped by a Mapper of its
// own, in the session's own frame (its odometry frame, levelled z-up from its own gravity or
// planes, origin at its first keyframe), so a robot that starts in a room nobody else has seen
// can still be asked what it has seen. An island map has objects, a cloud and, with
// align.island_octomap, an OctoMap (GetOctomap with the island's name).
//
// When the session is aligned, its island is dropped (its objects are REMOVED) and its
// keyframes enter the shared map, where fusion gives each physical object one id.
//
// Sessions whose islands overlap join into one island (server/align/robot_aligner.h): the
// joining island is dropped and its keyframes are mapped again into the other.
//
// Object ids of an island start at its first session's row * 2^32 + 1 (kIslandIdStride), so
// they never meet a shared-map id or another island's. Integrate and Drop are called on the mapping
// thread; the readers from any thread.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "server/map/mapper.h"

namespace loci::server {

inline constexpr int64_t kIslandIdStride = int64_t{1} << 32;

class IslandMaps {
 public:
  // `options`: the shared map's; islands use them, with the OctoMap only when `octomap` (a
  // thread and a tree per island). `listener` receives every island's object events (the
  // objects carry their island).
  IslandMaps(const MapOptions& options, bool octomap,
             std::function<void(const std::vector<ObjectEventOut>&)> listener);

  // Maps one keyframe of an unaligned session into island `island_row` (made on its first
  // keyframe; `island` names it: its first session's id) from the keyframe's products, at
  // T_island_odom * T_odom_kf: an island's base frame is its first session's odometry frame, and
  // T_island_odom places the keyframe's session in it (identity for that first session).
  // T_island_kf, when given, is the keyframe's pose in the island as its loop closure corrected
  // it (stored), and replaces T_island_odom * T_odom_kf.
  void Integrate(int64_t island_row, const std::string& island, const MapperKeyframe& keyframe,
                 const KeyframeProducts& products, const SE3d& T_island_odom = SE3d::Identity(),
                 const std::optional<SE3d>& T_island_kf = std::nullopt);
  // Moves keyframes of island `island_row` to corrected poses in its base frame (the island's
  // own loop closure) and re-derives what they touch (Mapper::UpdateKeyframePoses; its object
  // events go to the listener). Mapping thread. NOT_FOUND: no such island.
  // rebuild_octomap: as Mapper's (false for a chunk of a larger move but its last).
  StatusOr<size_t> UpdateKeyframePoses(int64_t island_row,
                                       const std::vector<Mapper::KeyframePoseUpdate>& updates,
                                       const Mapper::ProductSource& source,
                                       bool rebuild_octomap = true);
  // Forgets an island (it was aligned, or joined another); REMOVED events for its objects.
  std::vector<ObjectEventOut> Drop(int64_t island_row);

  struct Island {
    int64_t session_row = 0;  // the island's first session
    std::string name;         // its session id
    std::vector<std::string> robots;  // robots whose keyframes it maps, in order of arrival
    std::shared_ptr<const Mapper> map;
  };
  std::vector<Island> List() const;
  std::optional<Island> Find(int64_t session_row) const;
  // The island named `name` (its first session's id).
  std::optional<Island> FindByName(const std::string& name) const;
  // The island holding object `id` (by its id range), if that island exists.
  std::optional<Island> FindByObjectId(int64_t id) const;

  // Every island's objects, tagged with their island.
  std::vector<MapObject> Snapshot(bool confirmed_only) const;

 private:
  MapOptions options_;
  std::function<void(const std::vector<ObjectEventOut>&)> listener_;
  mutable std::mutex mu_;  // guards islands_ (the maps themselves are thread-safe)
  std::map<int64_t, Island> islands_;
};

// The island's objects with MapObject::island set.
std::vector<MapObject> IslandObjects(const IslandMaps::Island& island, bool confirmed_only);

}  // namespace loci::server

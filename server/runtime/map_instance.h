// The shared map and each island, as the pose graph sees them: a map with a graph of its own,
// whose sessions are placed in its base frame and whose keyframes a solution moves. The graph
// stage (graph_stage.h) solves and applies both kinds the same way through this interface.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/se3.h"
#include "common/status.h"
#include "server/map/mapper.h"
#include "server/runtime/map_context.h"
#include "server/runtime/map_worker.h"

namespace loci::server {

class MapInstance {
 public:
  virtual ~MapInstance() = default;
  // LoopCloser's graph key: kSharedGraph, or the island's row.
  virtual int64_t graph() const = 0;
  // Mapping lock held: the map (null: gone, an island aligned or joined another); the same
  // pointer while it is the same map.
  virtual std::shared_ptr<const Mapper> map() const = 0;
  // Mapping lock held: a session follows its newest keyframe's correction: its odometry frame's
  // new placement in the map's base frame (T_base_odom, or T_island_odom).
  virtual void Place(int64_t session_row, const SE3d& T_base_odom) = 0;
  // Mapping lock held: moves one chunk of keyframes (`last`: the OctoMap is rebuilt after it,
  // and every keyframe's pose is stored).
  virtual StatusOr<size_t> Move(const std::vector<Mapper::KeyframePoseUpdate>& chunk,
                                bool last) = 0;
};

// The shared map, in the shared base frame.
std::unique_ptr<MapInstance> SharedMapInstance(const MapContext& ctx, MapWorker* worker);
// An unaligned robot's island (island_maps.h), in its own frame.
std::unique_ptr<MapInstance> IslandInstance(const MapContext& ctx, MapWorker* worker,
                                            int64_t island_row);

}  // namespace loci::server

#include "server/runtime/island_maps.h"

#include <absl/strings/str_cat.h>
#include <spdlog/spdlog.h>

#include <algorithm>

namespace loci::server {

IslandMaps::IslandMaps(const MapOptions& options, bool octomap,
                       std::function<void(const std::vector<ObjectEventOut>&)> listener)
    : options_(options), listener_(std::move(listener)) {
  options_.octomap.enabled = options_.octomap.enabled && octomap;
}

void IslandMaps::Integrate(int64_t session_row, const std::string& island,
                           const MapperKeyframe& keyframe, const KeyframeProducts& products,
                           const SE3d& T_island_odom, const std::optional<SE3d>& T_island_kf) {
  std::shared_ptr<Mapper> map;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = islands_.find(session_row);
    if (it == islands_.end()) {
      auto fresh = std::make_shared<Mapper>(options_);
      if (Status s = fresh->SetFirstObjectId(session_row * kIslandIdStride + 1); !s.ok()) {
        spdlog::warn("island {}: {}", island, s.ToString());
        return;
      }
      if (listener_) {
        fresh->SetEventListener([this, island](const std::vector<ObjectEventOut>& events) {
          std::vector<ObjectEventOut> tagged = events;
          for (ObjectEventOut& e : tagged) e.object.island = island;
          listener_(tagged);
        });
      }
      it = islands_.emplace(session_row, Island{session_row, island, {}, fresh}).first;
    }
    std::vector<std::string>& robots = it->second.robots;
    if (std::find(robots.begin(), robots.end(), keyframe.robot) == robots.end()) {
      robots.push_back(keyframe.robot);
    }
    // Only the mapping thread integrates, so the map is not dropped under this call.
    map = std::const_pointer_cast<Mapper>(it->second.map);
  }
  MapperKeyframe in_island = keyframe;
  in_island.T_base_kf = T_island_kf ? *T_island_kf : T_island_odom * keyframe.T_odom_kf;
  map->Integrate(in_island, products);
}

StatusOr<size_t> IslandMaps::UpdateKeyframePoses(
    int64_t island_row, const std::vector<Mapper::KeyframePoseUpdate>& updates,
    const Mapper::ProductSource& source, bool rebuild_octomap) {
  std::shared_ptr<Mapper> map;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = islands_.find(island_row);
    if (it == islands_.end()) {
      return absl::NotFoundError(absl::StrCat("no island of session row ", island_row));
    }
    // Only the mapping thread changes a map, so it is not dropped under this call.
    map = std::const_pointer_cast<Mapper>(it->second.map);
  }
  return map->UpdateKeyframePoses(updates, source, rebuild_octomap);
}

std::vector<ObjectEventOut> IslandMaps::Drop(int64_t session_row) {
  std::optional<Island> island;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = islands_.find(session_row);
    if (it == islands_.end()) return {};
    island = std::move(it->second);
    islands_.erase(it);
  }
  std::vector<ObjectEventOut> removed;
  for (MapObject& o : IslandObjects(*island, /*confirmed_only=*/false)) {
    ObjectEventOut e;
    e.kind = ObjectChange::Kind::kRemoved;
    e.object = std::move(o);
    removed.push_back(std::move(e));
  }
  return removed;
}

std::vector<IslandMaps::Island> IslandMaps::List() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<Island> out;
  for (const auto& [row, island] : islands_) out.push_back(island);
  return out;
}

std::optional<IslandMaps::Island> IslandMaps::Find(int64_t session_row) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = islands_.find(session_row);
  if (it == islands_.end()) return std::nullopt;
  return it->second;
}

std::optional<IslandMaps::Island> IslandMaps::FindByName(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [row, island] : islands_) {
    if (island.name == name) return island;
  }
  return std::nullopt;
}

std::optional<IslandMaps::Island> IslandMaps::FindByObjectId(int64_t id) const {
  if (id <= kIslandIdStride) return std::nullopt;
  return Find((id - 1) / kIslandIdStride);
}

std::vector<MapObject> IslandMaps::Snapshot(bool confirmed_only) const {
  std::vector<MapObject> out;
  for (const Island& island : List()) {
    for (MapObject& o : IslandObjects(island, confirmed_only)) out.push_back(std::move(o));
  }
  return out;
}

std::vector<MapObject> IslandObjects(const IslandMaps::Island& island, bool confirmed_only) {
  std::vector<MapObject> objects = island.map->Snapshot(confirmed_only);
  for (MapObject& o : objects) o.island = island.name;
  return objects;
}

}  // namespace loci::server

#include "server/runtime/map_instance.h"

#include <spdlog/spdlog.h>

namespace loci::server {
namespace {

class SharedMap : public MapInstance {
 public:
  SharedMap(const MapContext& ctx, MapWorker* worker) : ctx_(ctx), worker_(worker) {}

  int64_t graph() const override { return kSharedGraph; }
  std::shared_ptr<const Mapper> map() const override {
    // Not owned: the server outlives its solves.
    return std::shared_ptr<const Mapper>(std::shared_ptr<const Mapper>(), ctx_.mapper.get());
  }
  void Place(int64_t row, const SE3d& T_base_odom) override {
    std::optional<SessionRecord> s = ctx_.sessions.ByRow(row);
    if (!s) return;
    s->T_base_odom = T_base_odom;
    ctx_.aligner->SetAlignment(row, T_base_odom);
    if (Status st = ctx_.store.SetSessionAlignment(row, T_base_odom); !st.ok()) {
      spdlog::warn("session {}: corrected placement not stored: {}", s->session_id, st.ToString());
    }
    ctx_.sessions.Put(*s);
  }
  StatusOr<size_t> Move(const std::vector<Mapper::KeyframePoseUpdate>& chunk,
                        bool last) override {
    StatusOr<size_t> moved = worker_->Move(chunk, /*rebuild_octomap=*/last);
    // After the last chunk every keyframe's pose, those the solution left in place too (its
    // anchor): their session's placement has moved, so a replay from the first keyframe (no
    // usable checkpoint) would put them at the new placement x odometry.
    if (moved.ok() && last) {
      if (Status st = worker_->StoreCorrectedPoses(ctx_.mapper->KeyframePoses(), kSharedGraph);
          !st.ok()) {
        spdlog::warn("keyframe poses after the solve not all stored: {}", st.ToString());
      }
    }
    return moved;
  }

 private:
  MapContext ctx_;
  MapWorker* worker_;
};

class Island : public MapInstance {
 public:
  Island(const MapContext& ctx, MapWorker* worker, int64_t island_row)
      : ctx_(ctx), worker_(worker), island_row_(island_row) {}

  int64_t graph() const override { return island_row_; }
  std::shared_ptr<const Mapper> map() const override {
    const std::optional<IslandMaps::Island> island = ctx_.islands->Find(island_row_);
    return island ? island->map : nullptr;
  }
  void Place(int64_t row, const SE3d& T_island_odom) override {
    std::optional<SessionRecord> s = ctx_.sessions.ByRow(row);
    if (!s) return;
    s->island_row = island_row_;
    s->T_island_odom = T_island_odom;
    ctx_.aligner->SetIsland(row, island_row_, T_island_odom);
    if (Status st = ctx_.store.SetSessionIsland(row, island_row_, T_island_odom); !st.ok()) {
      spdlog::warn("session {}: corrected island placement not stored: {}", s->session_id,
                   st.ToString());
    }
    ctx_.sessions.Put(*s);
  }
  StatusOr<size_t> Move(const std::vector<Mapper::KeyframePoseUpdate>& chunk,
                        bool last) override {
    StatusOr<size_t> moved =
        ctx_.islands->UpdateKeyframePoses(island_row_, chunk, worker_->ProductsFromStore(), last);
    // After the last chunk every keyframe's pose in the island's frame, those the solution left
    // in place too (its anchor): their session's T_island_odom has moved, so a restart, which
    // maps the island again, would otherwise put them at the new placement x odometry.
    if (moved.ok() && last) worker_->StoreIslandPoses(island_row_, island_row_, SE3d::Identity());
    return moved;
  }

 private:
  MapContext ctx_;
  MapWorker* worker_;
  int64_t island_row_;
};

}  // namespace

std::unique_ptr<MapInstance> SharedMapInstance(const MapContext& ctx, MapWorker* worker) {
  return std::make_unique<SharedMap>(ctx, worker);
}

std::unique_ptr<MapInstance> IslandInstance(const MapContext& ctx, MapWorker* worker,
                                            int64_t island_row) {
  return std::make_unique<Island>(ctx, worker, island_row);
}

}  // namespace loci::server

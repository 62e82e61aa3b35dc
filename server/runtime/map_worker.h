// The mapping worker: one thread that takes accepted keyframes from a bounded queue and maps
// each into the shared map (or, for a robot not aligned yet, stores its products and maps it
// into the robot's island), then hands it on to place recognition (align_stage.h). It owns the
// mapping lock: every change of the shared map or an island, the worker's per keyframe and the
// other stages' moves and merges per chunk (chunked_move.h), is made with it held, so a reader of
// the map sees it between two keyframes.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common/bounded_queue.h"
#include "common/fifo_mutex.h"
#include "common/status.h"
#include "server/map/mapper.h"
#include "server/runtime/ingest_times.h"
#include "server/runtime/map_context.h"
#include "server/runtime/pipeline_progress.h"

namespace loci::server {

class MapWorker {
 public:
  // `store`: ctx.store, shared with the OctoMap rebuild threads that read products after a move.
  MapWorker(const MapContext& ctx, std::shared_ptr<MapStore> store, IngestTimes* times,
            PipelineProgress* progress);
  ~MapWorker() { Stop(); }
  MapWorker(const MapWorker&) = delete;
  MapWorker& operator=(const MapWorker&) = delete;

  // Starts the thread; the keyframes it maps go on to `to_recognise` (null: no place recognition).
  void Start(BoundedQueue<MapperKeyframe>* to_recognise);
  // Maps what is queued, then ends the thread.
  void Stop();
  // Blocks while the queue is full (back-pressure); false once stopping.
  bool Push(MapperKeyframe kf) { return queue_.Push(std::move(kf)); }
  size_t waiting() const { return queue_.size(); }

  FifoMutex& mapping_mutex() { return mapping_mu_; }
  // The last keyframe the worker mapped or held in an island.
  int64_t last_id() const { return last_id_; }
  // Whether the keyframe came in since this start (place recognition has it from the worker).
  bool LiveKeyframe(int64_t keyframe_id) const;

  // Mapping lock held: moves mapped keyframes of the shared map to corrected poses and
  // re-derives what they touch (Mapper::UpdateKeyframePoses, products read from the store), and
  // stores the poses. How many moved.
  StatusOr<size_t> Move(const std::vector<Mapper::KeyframePoseUpdate>& updates,
                        bool rebuild_octomap = true);
  // Stores keyframes' corrected poses in the frame of the map holding them (map_row:
  // kSharedGraph, or an island's row) and gives them to the aligner.
  Status StoreCorrectedPoses(const std::vector<Mapper::KeyframePoseUpdate>& updates,
                             int64_t map_row);
  // Before an island is dropped (aligned, or joined another), or after its solve: stores its
  // keyframes' poses in the frame of the map that takes them (T_to_island * T_island_kf; to_map_row
  // as in StoreCorrectedPoses), so they enter it corrected. False when there is no such island or
  // the poses were not stored.
  bool StoreIslandPoses(int64_t island_row, int64_t to_map_row, const SE3d& T_to_island);
  // Reads a keyframe's stored products (for moves; the store outlives every reader).
  Mapper::ProductSource ProductsFromStore() const;
  // An island's name: its first session's id.
  std::string IslandName(int64_t island_row);

  // Tells the aligner about a session on its first keyframe; the map's first keyframe makes its
  // session the origin.
  void DeclareSession(int64_t session_row);
  // After the map is loaded: every stored session with keyframes is declared, with its placement
  // or island, before a keyframe or a join can need it (loading thread, before Start).
  void DeclareStoredSessions();

 private:
  void Loop();
  // Maps (or holds back in its island) one keyframe, mapping lock held; whether it was mapped
  // into the shared map.
  bool MapOne(MapperKeyframe& kf);

  MapContext ctx_;
  std::shared_ptr<MapStore> store_;
  IngestTimes* times_;
  PipelineProgress* progress_;
  FifoMutex mapping_mu_;
  BoundedQueue<MapperKeyframe> queue_;
  BoundedQueue<MapperKeyframe>* to_recognise_ = nullptr;
  std::thread thread_;
  std::atomic<int64_t> last_id_{0};
  std::atomic<int64_t> first_live_id_{0};  // the first keyframe mapped since the start
};

}  // namespace loci::server

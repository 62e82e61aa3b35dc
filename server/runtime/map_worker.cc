#include "server/runtime/map_worker.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "common/thread_name.h"
#include "common/time.h"
#include "server/map/product_codec.h"
#include "server/runtime/replay.h"

namespace loci::server {

MapWorker::MapWorker(const MapContext& ctx, std::shared_ptr<MapStore> store, IngestTimes* times,
                     PipelineProgress* progress)
    : ctx_(ctx),
      store_(std::move(store)),
      times_(times),
      progress_(progress),
      queue_(static_cast<size_t>(ctx.options.queue_capacity)) {}

void MapWorker::Start(BoundedQueue<MapperKeyframe>* to_recognise) {
  to_recognise_ = to_recognise;
  thread_ = NamedThread("loci-worker", [this] { Loop(); });
}

void MapWorker::Stop() {
  queue_.Close();
  if (thread_.joinable()) thread_.join();
}

void MapWorker::Loop() {
  while (std::optional<MapperKeyframe> kf = queue_.Pop()) {
    const auto t0 = std::chrono::steady_clock::now();
    {
      std::lock_guard<FifoMutex> mapping(mapping_mu_);
      times_->NoteWorkerWait(MsSince(t0));
      const bool shared_map = MapOne(*kf);
      times_->AddMapped(MsSince(t0));
      ctx_.checkpointer.MaybeWrite(shared_map);
    }
    if (to_recognise_) {  // outside the lock: place recognition takes it after each keyframe
      progress_->ToRecognise();
      if (!to_recognise_->Push(std::move(*kf))) progress_->NotRecognised();  // shutting down
    }
    progress_->Mapped();
  }
}

bool MapWorker::MapOne(MapperKeyframe& kf) {
  last_id_ = kf.keyframe_id;
  int64_t none = 0;
  first_live_id_.compare_exchange_strong(none, kf.keyframe_id);
  if (!ctx_.aligner) {
    MapAndStoreProducts(*ctx_.mapper, kf, ctx_.detection, &ctx_.store);
    return true;
  }
  DeclareSession(kf.session_row);
  const std::optional<SE3d> T_base_odom = ctx_.aligner->Alignment(kf.session_row);
  if (T_base_odom) {
    kf.T_base_kf = *T_base_odom * kf.T_odom_kf;  // the session may have been aligned since
    MapAndStoreProducts(*ctx_.mapper, kf, ctx_.detection, &ctx_.store);
  } else {  // held back from the shared map, mapped in its island
    const KeyframeProducts products =
        BuildAndStoreProducts(*ctx_.mapper, kf, ctx_.detection, &ctx_.store);
    const auto [island_row, T_island_odom] = ctx_.aligner->IslandOf(kf.session_row);
    ctx_.islands->Integrate(island_row, IslandName(island_row), kf, products, T_island_odom);
  }
  if (ctx_.closer) {
    ctx_.closer->AddKeyframe({kf.keyframe_id, kf.session_row, kf.segment, kf.t_ns, kf.T_odom_kf,
                              kf.tracking_inliers,
                              kf.has_gravity ? kf.gravity_cam : Vec3d::Zero()});
  }
  return T_base_odom.has_value();
}

bool MapWorker::LiveKeyframe(int64_t keyframe_id) const {
  const int64_t first_live = first_live_id_;
  return first_live != 0 && keyframe_id >= first_live;
}

Mapper::ProductSource MapWorker::ProductsFromStore() const {
  // By value: the OctoMap rebuild reads products on its own thread after a move returns (the
  // store is shared with it).
  return [store = store_, fingerprint = ctx_.mapper->options().ProductsFingerprint()](
             int64_t id) -> StatusOr<KeyframeProducts> {
    LOCI_ASSIGN_OR_RETURN(std::optional<std::string> bytes, store->GetProducts(id, fingerprint));
    if (!bytes) {
      return absl::FailedPreconditionError(
          absl::StrCat("keyframe ", id, " has no stored products (run loci reprocess)"));
    }
    return DecodeProducts(*bytes, fingerprint, /*with_visibility=*/false);
  };
}

StatusOr<size_t> MapWorker::Move(const std::vector<Mapper::KeyframePoseUpdate>& updates,
                                 bool rebuild_octomap) {
  auto moved = ctx_.mapper->UpdateKeyframePoses(updates, ProductsFromStore(), rebuild_octomap);
  if (!moved.ok()) return moved;
  ctx_.checkpointer.Changed(*moved);  // the next checkpoint keeps the moved map
  // The poses themselves, so that a restart from an older checkpoint, a replay and a reprocess
  // all map these keyframes where they are now.
  LOCI_RETURN_IF_ERROR(StoreCorrectedPoses(updates, kSharedGraph));
  return moved;
}

Status MapWorker::StoreCorrectedPoses(const std::vector<Mapper::KeyframePoseUpdate>& updates,
                                      int64_t map_row) {
  std::vector<KeyframePoseRecord> poses;
  poses.reserve(updates.size());
  std::vector<std::pair<int64_t, SE3d>> mapped;
  mapped.reserve(updates.size());
  for (const Mapper::KeyframePoseUpdate& u : updates) {
    poses.push_back({u.keyframe_id, u.T_base_kf});
    mapped.emplace_back(u.keyframe_id, u.T_base_kf);
  }
  // Where the keyframes are mapped now, stored or not: later merges and joins start from it.
  if (ctx_.aligner) ctx_.aligner->SetMappedPoses(map_row, mapped);
  return ctx_.store.PutKeyframePoses(poses);
}

bool MapWorker::StoreIslandPoses(int64_t island_row, int64_t to_map_row,
                                 const SE3d& T_to_island) {
  const std::optional<IslandMaps::Island> island =
      ctx_.islands ? ctx_.islands->Find(island_row) : std::nullopt;
  if (!island) return false;
  const auto start = std::chrono::steady_clock::now();
  std::vector<Mapper::KeyframePoseUpdate> poses = island->map->KeyframePoses();
  for (Mapper::KeyframePoseUpdate& kf : poses) kf.T_base_kf = T_to_island * kf.T_base_kf;
  if (Status st = StoreCorrectedPoses(poses, to_map_row); !st.ok()) {
    spdlog::warn("island {}: corrected keyframe poses not stored ({}); where its keyframes are "
                 "mapped next (a restart, an alignment, a join) they are placed by odometry",
                 island->name, st.ToString());
    return false;
  }
  spdlog::info("island {}: {} corrected keyframe poses stored in {:.0f} ms", island->name,
               poses.size(), MsSince(start));
  return true;
}

std::string MapWorker::IslandName(int64_t island_row) {
  const std::optional<SessionRecord> s = ctx_.sessions.ByRow(island_row);
  return s ? s->session_id : std::to_string(island_row);
}

void MapWorker::DeclareSession(int64_t session_row) {
  RobotAligner& aligner = *ctx_.aligner;
  if (aligner.Known(session_row)) return;
  std::optional<SessionRecord> s = ctx_.sessions.ByRow(session_row);
  if (!s) {
    aligner.AddSession(session_row, std::nullopt);
    return;
  }
  if (!s->aligned && ctx_.mapper->last_keyframe_id() == 0 && !aligner.AnyAligned()) {
    // The map's first keyframe: its session defines the base frame.
    s->aligned = true;
    if (Status st = ctx_.store.SetSessionAlignment(s->row_id, s->T_base_odom); !st.ok()) {
      spdlog::warn("session {}: alignment not stored: {}", s->session_id, st.ToString());
    }
    ctx_.sessions.Put(*s);
    spdlog::info("session {} of robot {} defines the map frame", s->session_id, s->robot_name);
  }
  aligner.AddSession(session_row,
                     s->aligned ? std::optional<SE3d>(s->T_base_odom) : std::nullopt);
  if (!s->aligned && s->island_row != 0) {
    aligner.SetIsland(session_row, s->island_row, s->T_island_odom);
  }
}

void MapWorker::DeclareStoredSessions() {
  if (!ctx_.aligner) return;
  auto sessions = ctx_.store.ListSessions();
  if (!sessions.ok()) {
    spdlog::warn("sessions not declared at load ({}); each is on its next keyframe",
                 sessions.status().ToString());
    return;
  }
  // Aligned sessions first: an unaligned one never becomes the map's origin here.
  for (const bool aligned : {true, false}) {
    for (const SessionRecord& s : *sessions) {
      if (s.aligned != aligned) continue;
      auto keyframes = ctx_.store.CountKeyframes(s.row_id);
      // A session without keyframes is declared on its first (which may make it the origin).
      if (!keyframes.ok() || *keyframes == 0) continue;
      DeclareSession(s.row_id);
    }
  }
}

}  // namespace loci::server

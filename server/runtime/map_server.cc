#include "server/runtime/map_server.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "common/malloc_tuning.h"
#include "common/thread_name.h"
#include "common/time.h"
#include "server/map/keyframe_products.h"
#include "server/map/product_codec.h"
#include "server/runtime/keyframe_decoder.h"
#include "server/runtime/proto_convert.h"
#include "server/runtime/replay.h"
#include "server/storage/sqlite_store.h"

namespace loci::server {

MapServer::MapServer(const ServerOptions& options, std::shared_ptr<MapStore> store,
                     std::shared_ptr<KeyframeDetection> detection)
    : options_(options),
      store_(std::move(store)),
      detection_(std::move(detection)),
      mapper_(std::make_unique<Mapper>(options.map)),
      features_(
          std::make_unique<StoreFeatureStore>(store_.get(), options.place.features.Fingerprint())),
      images_(std::make_unique<StoreImageSource>(store_.get())),
      aligner_(options.align.enabled
                   ? std::make_unique<RobotAligner>(options.place, options.align, features_.get(),
                                                    images_.get())
                   : nullptr),
      closer_(options.align.enabled && options.align.loops.enabled
                  ? std::make_unique<LoopCloser>(options.graph, options.align.loops)
                  : nullptr),
      islands_(options.align.enabled
                   ? std::make_unique<IslandMaps>(
                         options.map, options.align.island_octomap,
                         [this](const std::vector<ObjectEventOut>& events) {
                           // Not while a restart re-derives them.
                           if (readiness_.ready()) events_.Publish(events);
                         })
                   : nullptr),
      events_(options_.max_watchers),
      sessions_(store_.get()),
      gate_(options_, store_.get(), &sessions_, &times_),
      checkpointer_(options_, mapper_, store_.get()),
      publisher_(mapper_, store_.get(), readiness_, options.publish_interval_s),
      queue_(static_cast<size_t>(options.queue_capacity)),
      align_queue_(static_cast<size_t>(options.queue_capacity)) {}

StatusOr<std::unique_ptr<MapServer>> MapServer::OpenAsync(
    const ServerOptions& options, std::shared_ptr<MapStore> store,
    std::shared_ptr<KeyframeDetection> detection) {
  LOCI_RETURN_IF_ERROR(options.map.Validate());
  LOCI_RETURN_IF_ERROR(options.ValidateLimits());
  LOCI_RETURN_IF_ERROR(options.place.Validate());
  LOCI_RETURN_IF_ERROR(options.align.Validate());
  LOCI_RETURN_IF_ERROR(options.graph.Validate());
  KeepLargeBlocksOnMmap();  // decoded images cross threads (common/malloc_tuning.h)
  LimitHeapArenas();        // arenas created from here on (main() calls it before any thread)
  if (!store) {
    LOCI_ASSIGN_OR_RETURN(std::unique_ptr<SqliteStore> sqlite, SqliteStore::Open(options.db_path));
    store = std::move(sqlite);
  }
  std::unique_ptr<MapServer> server(new MapServer(options, std::move(store), std::move(detection)));
  server->loader_ = NamedThread("loci-load", [s = server.get()] { s->LoadLoop(); });
  return server;
}

StatusOr<std::unique_ptr<MapServer>> MapServer::Open(
    const ServerOptions& options, std::shared_ptr<MapStore> store,
    std::shared_ptr<KeyframeDetection> detection) {
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<MapServer> server,
                        OpenAsync(options, std::move(store), std::move(detection)));
  LOCI_RETURN_IF_ERROR(server->WaitReady());
  return server;
}

void MapServer::LoadLoop() {
  const auto t0 = std::chrono::steady_clock::now();
  LoadOptions load;
  load.stop = &stop_loading_;
  load.progress = [this](uint64_t done, uint64_t total) { readiness_.Progress(done, total); };
  StatusOr<LoadReport> report = LoadMap(*store_, &mapper_, detection_.get(), load);
  if (report.ok()) {
    load_report_ = *report;
    replayed_ = report->keyframes();
    spdlog::info(
        "loaded the map in {:.2f} s: checkpoint at keyframe {}, then {} keyframes from products, "
        "{} from images, {} skipped",
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
        report->checkpoint_keyframe_id, report->from_products, report->from_raw, report->skipped);
    // A restart after many keyframes should not re-derive them again.
    if (report->keyframes() >= static_cast<uint64_t>(options_.checkpoint_keyframes)) {
      if (Status s = Checkpoint(); !s.ok()) spdlog::warn("checkpoint: {}", s.ToString());
    }
    LoadIslands();
    DeclareStoredSessions();
    mapper_->SetEventListener(
        [this](const std::vector<ObjectEventOut>& events) { events_.Publish(events); });
    worker_ = NamedThread("loci-worker", [this] { WorkerLoop(); });
    if (aligner_) align_thread_ = NamedThread("loci-align", [this] { AlignLoop(); });
  } else {
    spdlog::error("the map failed to load: {}", report.status().ToString());
  }
  readiness_.Finish(report.status());
  if (report.ok()) {
    Reindex();  // the stored keyframes into place recognition
  }
}

StatusOr<size_t> MapServer::UpdateKeyframePoses(
    const std::vector<Mapper::KeyframePoseUpdate>& updates) {
  LOCI_RETURN_IF_ERROR(CheckReady());
  std::lock_guard<FifoMutex> lock(mapping_mu_);
  return UpdateKeyframePosesLocked(updates);
}

Mapper::ProductSource MapServer::ProductsFromStore() const {
  // By value: the OctoMap rebuild reads products on its own thread after a move returns (the
  // store is shared with it).
  return [store = store_, fingerprint = mapper_->options().ProductsFingerprint()](
             int64_t id) -> StatusOr<KeyframeProducts> {
    LOCI_ASSIGN_OR_RETURN(std::optional<std::string> bytes, store->GetProducts(id, fingerprint));
    if (!bytes) {
      return absl::FailedPreconditionError(
          absl::StrCat("keyframe ", id, " has no stored products (run loci reprocess)"));
    }
    return DecodeProducts(*bytes, fingerprint, /*with_visibility=*/false);
  };
}

StatusOr<size_t> MapServer::UpdateKeyframePosesLocked(
    const std::vector<Mapper::KeyframePoseUpdate>& updates, bool rebuild_octomap) {
  auto moved = mapper_->UpdateKeyframePoses(updates, ProductsFromStore(), rebuild_octomap);
  if (!moved.ok()) return moved;
  checkpointer_.Changed(*moved);  // the next checkpoint keeps the moved map
  // The poses themselves, so that a restart from an older checkpoint, a replay and a reprocess
  // all map these keyframes where they are now.
  LOCI_RETURN_IF_ERROR(StoreCorrectedPoses(updates, kSharedGraph));
  return moved;
}

Status MapServer::StoreCorrectedPoses(const std::vector<Mapper::KeyframePoseUpdate>& updates,
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
  if (aligner_) aligner_->SetMappedPoses(map_row, mapped);
  return store_->PutKeyframePoses(poses);
}

Status MapServer::Checkpoint() { return checkpointer_.Write(); }

MapServer::~MapServer() {
  stop_loading_ = true;
  if (loader_.joinable()) loader_.join();
  queue_.Close();
  if (worker_.joinable()) worker_.join();
  align_queue_.Close();  // after the worker: it drains what the worker handed over
  if (align_thread_.joinable()) align_thread_.join();
  if (readiness_.ready() && checkpointer_.dirty()) {
    if (Status s = Checkpoint(); !s.ok()) spdlog::warn("checkpoint at shutdown: {}", s.ToString());
  }
  events_.CloseAll();
}

StatusOr<loci::v1::OpenSessionResponse> MapServer::OpenSession(
    const loci::v1::OpenSessionRequest& req) {
  LOCI_RETURN_IF_ERROR(CheckReady());
  return gate_.OpenSession(req);
}

StatusOr<loci::v1::CloseSessionResponse> MapServer::CloseSession(
    const loci::v1::CloseSessionRequest& req, const std::string* only_robot) {
  return gate_.CloseSession(req, only_robot);
}

loci::v1::KeyframeAck MapServer::Ingest(const loci::v1::Keyframe& kf,
                                        const std::string* only_robot) {
  if (Status ready = CheckReady(); !ready.ok()) return MakeAck(kf.seq(), ready);
  IngestGate::Admitted admitted = gate_.Admit(kf, only_robot);
  if (!admitted.keyframe) return admitted.ack;
  progress_.Queued();
  OfferAhead(*admitted.keyframe);
  // Detected on the detection threads while the worker maps the keyframes before it.
  if (detection_) detection_->Prefetch(*admitted.keyframe);
  // Blocks while the mapping worker is behind: back-pressure on this client's stream.
  if (!queue_.Push(std::move(*admitted.keyframe))) {
    progress_.Unqueued();  // shutting down; the keyframe is stored and will be mapped on restart
  }
  return admitted.ack;
}

void MapServer::WorkerLoop() {
  while (std::optional<MapperKeyframe> kf = queue_.Pop()) {
    const auto t0 = std::chrono::steady_clock::now();
    bool recognise = false;
    {
      std::lock_guard<FifoMutex> mapping(mapping_mu_);
      times_.NoteWorkerWait(MsSince(t0));
      const Queued queued = MapQueued(*kf);
      recognise = queued.recognise;
      times_.AddMapped(MsSince(t0));
      checkpointer_.MaybeWrite(queued.shared_map);
    }
    if (recognise) {  // outside mapping_mu_: the aligning thread takes it after each keyframe
      progress_.ToRecognise();
      if (!align_queue_.Push(std::move(*kf))) progress_.NotRecognised();  // shutting down
    }
    progress_.Mapped();
  }
}

void MapServer::AlignLoop() {
  while (true) {
    if (std::optional<MapperKeyframe> ahead = ahead_.Take(align_queue_.size() == 0)) {
      QueryAhead(*ahead);
      continue;
    }
    // A short wait: a keyframe offered ahead meanwhile is taken within it.
    std::optional<MapperKeyframe> kf = align_queue_.PopFor(std::chrono::milliseconds(20));
    if (!kf) {
      if (align_queue_.closed()) return;
      continue;
    }
    ahead_.NoteRecognised();
    RecognisePlace(*kf);
    progress_.Recognised();
  }
}

void MapServer::Flush() {
  progress_.WaitDrained();
  if (Status s = publisher_.Flush(); !s.ok()) {
    spdlog::warn("publishing the object table: {}", s.ToString());
  }
}

std::optional<LoopStats> MapServer::loop_stats() const {
  if (!closer_) return std::nullopt;
  return closer_->Stats();
}

std::optional<AlignStats> MapServer::align_stats() const {
  if (!aligner_) return std::nullopt;
  return aligner_->Stats();
}

}  // namespace loci::server

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
      checkpointer_(options_, mapper_, store_.get()),
      ctx_{options_,        *store_,        detection_.get(), sessions_,
           events_,         checkpointer_,  mapper_,          aligner_.get(),
           closer_.get(),   islands_.get(), features_.get(),  stop_loading_},
      gate_(options_, store_.get(), &sessions_, &times_),
      worker_(ctx_, store_, &times_, &progress_),
      graph_(ctx_, &worker_),
      align_(ctx_, &worker_, &graph_, &progress_),
      reindexer_(ctx_, &worker_, &graph_, &align_),
      publisher_(mapper_, store_.get(), readiness_, options.publish_interval_s) {}

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
  LOCI_RETURN_IF_ERROR(server->readiness().Wait());
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
    align_.LoadIslands();
    worker_.DeclareStoredSessions();
    mapper_->SetEventListener(
        [this](const std::vector<ObjectEventOut>& events) { events_.Publish(events); });
    worker_.Start(aligner_ ? &align_.input() : nullptr);
    if (aligner_) align_.Start();
  } else {
    spdlog::error("the map failed to load: {}", report.status().ToString());
  }
  readiness_.Finish(report.status());
  if (report.ok()) {
    reindexer_.Run();  // the stored keyframes into place recognition
  }
}

StatusOr<size_t> MapServer::UpdateKeyframePoses(
    const std::vector<Mapper::KeyframePoseUpdate>& updates) {
  LOCI_RETURN_IF_ERROR(CheckReady());
  std::lock_guard<FifoMutex> lock(worker_.mapping_mutex());
  return worker_.Move(updates);
}

MapServer::~MapServer() {
  stop_loading_ = true;
  if (loader_.joinable()) loader_.join();
  worker_.Stop();
  align_.Stop();  // after the worker: it drains what the worker handed over
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
  align_.OfferAhead(*admitted.keyframe);
  // Detected on the detection threads while the worker maps the keyframes before it.
  if (detection_) detection_->Prefetch(*admitted.keyframe);
  // Blocks while the mapping worker is behind: back-pressure on this client's stream.
  if (!worker_.Push(std::move(*admitted.keyframe))) {
    progress_.Unqueued();  // shutting down; the keyframe is stored and will be mapped on restart
  }
  return admitted.ack;
}

void MapServer::Flush() {
  progress_.WaitDrained();
  if (Status s = publisher_.Flush(); !s.ok()) {
    spdlog::warn("publishing the object table: {}", s.ToString());
  }
}

RuntimeStats MapServer::stats() const {
  RuntimeStats s;
  s.queue_depth = worker_.waiting() + progress_.recognition_pending();
  s.replayed_keyframes = replayed_;
  s.reindexed = graph_.indexed();
  s.checkpoints_written = checkpointer_.written();
  s.held_merge = align_.held_merge_stats();
  if (aligner_) s.align = aligner_->Stats();
  if (closer_) s.loops = closer_->Stats();
  return s;
}

}  // namespace loci::server

#include "server/service/map_server.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <regex>

#include "common/malloc_tuning.h"
#include "common/thread_name.h"
#include "common/time.h"
#include "server/map/keyframe_products.h"
#include "server/map/product_codec.h"
#include "server/service/keyframe_decoder.h"
#include "server/service/proto_convert.h"
#include "server/service/replay.h"
#include "server/storage/sqlite_store.h"

namespace loci::server {
namespace {

constexpr char kServerVersion[] = "loci-server 0.1.0";

loci::v1::KeyframeAck MakeAck(int64_t seq, const Status& status) {
  loci::v1::KeyframeAck ack;
  ack.set_seq(seq);
  ToProto(status, ack.mutable_status());
  return ack;
}

}  // namespace

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
                           if (ready_) Publish(events);  // not while a restart re-derives them
                         })
                   : nullptr),
      decode_slots_(options.decode_slots),
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
  load.progress = [this](uint64_t done, uint64_t total) {
    load_done_ = done;
    load_total_ = total;
  };
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
        [this](const std::vector<ObjectEventOut>& events) { Publish(events); });
    worker_ = NamedThread("loci-worker", [this] { WorkerLoop(); });
    if (aligner_) align_thread_ = NamedThread("loci-align", [this] { AlignLoop(); });
  } else {
    spdlog::error("the map failed to load: {}", report.status().ToString());
  }
  FinishLoad(report.status());
  if (report.ok()) {
    Reindex();  // the stored keyframes into place recognition
  }
}

void MapServer::FinishLoad(const Status& status) {
  std::vector<std::function<void()>> callbacks;
  {
    std::lock_guard<std::mutex> lock(ready_mu_);
    load_finished_ = true;
    load_status_ = status;
    ready_ = status.ok();
    if (ready_) callbacks = std::move(ready_callbacks_);
  }
  ready_cv_.notify_all();
  for (auto& fn : callbacks) fn();
}

Status MapServer::CheckReady() const {
  if (ready_) return absl::OkStatus();
  std::lock_guard<std::mutex> lock(ready_mu_);
  if (load_finished_) {
    return absl::UnavailableError(
        absl::StrCat("loci-server could not load its map: ", load_status_.message()));
  }
  // Progress comes once the checkpoint is restored and the keyframes counted (replay.cc).
  const uint64_t total = load_total_.load();
  const std::string progress =
      total == 0 ? std::string("reading the stored map")
                 : absl::StrCat(load_done_.load(), " keyframes replayed after the checkpoint, ",
                                total, " stored");
  return absl::UnavailableError(absl::StrCat("loci-server is loading its map (", progress,
                                             "); retry when the gRPC health service reports "
                                             "SERVING"));
}

Status MapServer::WaitReady() {
  std::unique_lock<std::mutex> lock(ready_mu_);
  ready_cv_.wait(lock, [&] { return load_finished_; });
  return load_status_;
}

void MapServer::OnReady(std::function<void()> fn) {
  {
    std::lock_guard<std::mutex> lock(ready_mu_);
    if (!ready_) {
      ready_callbacks_.push_back(std::move(fn));
      return;
    }
  }
  fn();
}

StatusOr<size_t> MapServer::UpdateKeyframePoses(
    const std::vector<Mapper::KeyframePoseUpdate>& updates) {
  LOCI_RETURN_IF_ERROR(CheckReady());
  std::lock_guard<HandoffMutex> lock(mapping_mu_);
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
  since_checkpoint_ += *moved;  // the next checkpoint keeps the moved map
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

Status MapServer::Checkpoint() {
  std::lock_guard<std::mutex> lock(checkpoint_mu_);
  const auto t0 = std::chrono::steady_clock::now();
  CheckpointRecord record;
  record.last_keyframe_id = mapper_->last_keyframe_id();
  record.data = mapper_->SaveCheckpoint();
  if (record.data.empty()) return absl::OkStatus();  // the map frame is not settled yet
  LOCI_RETURN_IF_ERROR(store_->PutCheckpoint(record));
  ++checkpoints_written_;
  spdlog::info("checkpoint at keyframe {}: {:.1f} MB in {:.2f} s", record.last_keyframe_id,
               static_cast<double>(record.data.size()) / 1e6,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  // Free the checkpoint's bytes, then give back every page freed since the last solve or
  // checkpoint (a map without loop closure has no solves to trim after).
  record = {};
  ReleaseFreeHeapPages();
  return ApplyRetention();
}

Status MapServer::ApplyRetention() {
  if (options_.raw_keep_days < 0 && options_.raw_keep_last < 0) return absl::OkStatus();
  const int64_t before_ns = options_.raw_keep_days < 0
                                ? std::numeric_limits<int64_t>::min()
                                : NowNs() - SecondsToNs(options_.raw_keep_days * 86'400.0);
  LOCI_ASSIGN_OR_RETURN(const uint64_t dropped,
                        store_->DropRawImages(before_ns, options_.raw_keep_last));
  if (dropped > 0) spdlog::info("retention: dropped the images of {} keyframes", dropped);
  return absl::OkStatus();
}

void MapServer::MaybeCheckpoint(bool shared_map_changed) {
  if (shared_map_changed) ++since_checkpoint_;
  if (merging_held_) return;  // MapHeldKeyframes checkpoints when they are all in
  if (since_checkpoint_ == 0 && !checkpoint_due_) return;  // the last checkpoint holds the map
  const auto now = std::chrono::steady_clock::now();
  if (!checkpoint_due_ &&
      since_checkpoint_ < static_cast<uint64_t>(options_.checkpoint_keyframes) &&
      now - last_checkpoint_ < std::chrono::duration<double>(options_.checkpoint_interval_s)) {
    return;
  }
  // A checkpoint holds the OctoMap as rebuilt after the last pose update: the worker does not
  // wait for that rebuild with the mapping lock held (about 9 ms per keyframe: 11 s at 1250,
  // every robot's stream stopped meanwhile). It checkpoints on its first keyframe after.
  if (mapper_->OctomapRebuilding()) {
    checkpoint_due_ = true;
    return;
  }
  checkpoint_due_ = false;
  if (Status s = Checkpoint(); !s.ok()) spdlog::warn("checkpoint: {}", s.ToString());
  since_checkpoint_ = 0;
  last_checkpoint_ = now;
}

MapServer::~MapServer() {
  stop_loading_ = true;
  if (loader_.joinable()) loader_.join();
  queue_.Close();
  if (worker_.joinable()) worker_.join();
  align_queue_.Close();  // after the worker: it drains what the worker handed over
  if (align_thread_.joinable()) align_thread_.join();
  if (ready_ && since_checkpoint_ > 0) {
    if (Status s = Checkpoint(); !s.ok()) spdlog::warn("checkpoint at shutdown: {}", s.ToString());
  }
  std::lock_guard<std::mutex> lock(watchers_mu_);
  for (auto& w : watchers_) w->Close();
}

StatusOr<loci::v1::OpenSessionResponse> MapServer::OpenSession(
    const loci::v1::OpenSessionRequest& req) {
  LOCI_RETURN_IF_ERROR(CheckReady());
  static const std::regex kRobotName("[A-Za-z0-9_.-]{1,64}");
  if (!std::regex_match(req.robot_name(), kRobotName)) {
    return absl::InvalidArgumentError(
        absl::StrCat("robot_name '", req.robot_name(), "' must match [A-Za-z0-9_.-]{1,64}"));
  }
  loci::v1::OpenSessionResponse resp;
  resp.set_server_version(kServerVersion);
  if (req.resume()) {
    LOCI_ASSIGN_OR_RETURN(std::optional<SessionRecord> s,
                          store_->LatestOpenSession(req.robot_name()));
    if (s) {
      LOCI_ASSIGN_OR_RETURN(int64_t last, store_->LastStoredSeq(s->row_id));
      resp.set_session_id(s->session_id);
      resp.set_last_stored_seq(last);
      std::lock_guard<std::mutex> lock(sessions_mu_);
      sessions_[s->session_id] = *s;
      return resp;
    }
  }
  SessionRecord s;
  s.robot_name = req.robot_name();
  s.client_version = req.client_version();
  const auto& k = req.intrinsics();
  s.camera = {k.fx(),
              k.fy(),
              k.cx(),
              k.cy(),
              static_cast<int>(k.width_px()),
              static_cast<int>(k.height_px())};
  if (Status st = s.camera.Validate(); !st.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics: ", st.message()));
  }
  s.depth_scale = req.depth_scale();
  if (!std::isfinite(s.depth_scale) || s.depth_scale <= 0 || s.depth_scale > 1e6) {
    return absl::InvalidArgumentError("depth_scale must be in (0, 1e6]");
  }
  if (auto it = options_.T_base_odom.find(s.robot_name); it != options_.T_base_odom.end()) {
    s.T_base_odom = it->second;
  } else {
    // Placed by place recognition (server/align/), or the map's origin if its first keyframe
    // is the map's first (map_server_align.cc).
    s.aligned = !options_.align.enabled;
  }
  s.opened_ns = NowNs();
  LOCI_ASSIGN_OR_RETURN(s, store_->CreateSession(s));
  resp.set_session_id(s.session_id);
  resp.set_last_stored_seq(-1);
  std::lock_guard<std::mutex> lock(sessions_mu_);
  sessions_[s.session_id] = s;
  spdlog::info("session {} opened for robot {}", s.session_id, s.robot_name);
  return resp;
}

StatusOr<SessionRecord> MapServer::FindSession(const std::string& session_id,
                                               const std::string* only_robot) {
  std::optional<SessionRecord> found;
  {
    std::lock_guard<std::mutex> lock(sessions_mu_);
    auto it = sessions_.find(session_id);
    if (it != sessions_.end()) found = it->second;
  }
  if (!found) {
    LOCI_ASSIGN_OR_RETURN(found, store_->FindSession(session_id));
    if (found) {
      std::lock_guard<std::mutex> lock(sessions_mu_);
      sessions_[session_id] = *found;
    }
  }
  if (!found) {
    return absl::NotFoundError(
        absl::StrCat("unknown session '", session_id, "' (call OpenSession first)"));
  }
  if (only_robot != nullptr && found->robot_name != *only_robot) {
    return absl::PermissionDeniedError(absl::StrCat(
        "session '", session_id, "' belongs to another robot than '", *only_robot, "'"));
  }
  return *found;
}

loci::v1::KeyframeAck MapServer::Ingest(const loci::v1::Keyframe& kf,
                                        const std::string* only_robot) {
  if (Status ready = CheckReady(); !ready.ok()) return MakeAck(kf.seq(), ready);
  auto session = FindSession(kf.session_id(), only_robot);
  if (!session.ok()) return MakeAck(kf.seq(), session.status());
  if (!session->open) {
    return MakeAck(kf.seq(), absl::FailedPreconditionError(
                                 absl::StrCat("session ", kf.session_id(), " is closed")));
  }
  MapperKeyframe decoded;
  const double cpu0 = ThreadCpuMs();
  auto record = Validate(kf, *session, &decoded);
  const double cpu1 = ThreadCpuMs();
  const auto t1 = std::chrono::steady_clock::now();
  if (!record.ok()) {
    spdlog::warn("keyframe {} of {} rejected: {}", kf.seq(), kf.session_id(),
                 record.status().ToString());
    return MakeAck(kf.seq(), record.status());
  }
  // Stored and queued under one lock: the worker maps keyframes in id order.
  std::unique_lock<std::mutex> order(ingest_order_mu_);
  auto inserted = store_->InsertKeyframe(*record);
  const auto t2 = std::chrono::steady_clock::now();
  // fetch_add: `x = x + y` on an atomic loses updates when several streams ingest at once.
  validate_ms_total_.fetch_add(cpu1 - cpu0);
  store_ms_total_.fetch_add(std::chrono::duration<double, std::milli>(t2 - t1).count());
  ++accepted_count_;
  if (!inserted.ok()) {
    spdlog::error("keyframe {} of {} not stored: {}", kf.seq(), kf.session_id(),
                  inserted.status().ToString());
    return MakeAck(kf.seq(), absl::UnavailableError(
                                 absl::StrCat("storage failed: ", inserted.status().message())));
  }
  if (inserted->conflict) {
    loci::v1::KeyframeAck ack =
        MakeAck(kf.seq(), absl::AlreadyExistsError(absl::StrCat(
                              "seq ", kf.seq(), " of ", kf.session_id(),
                              " is already stored with a different stamp, pose or images; kept the "
                              "stored one")));
    ack.set_keyframe_id(inserted->keyframe_id);
    ack.set_duplicate(true);
    return ack;
  }
  loci::v1::KeyframeAck ack = MakeAck(kf.seq(), absl::OkStatus());
  ack.set_keyframe_id(inserted->keyframe_id);
  ack.set_duplicate(inserted->duplicate);
  if (!inserted->duplicate) {
    NoteStored(*record);
    decoded.keyframe_id = inserted->keyframe_id;
    {
      std::lock_guard<std::mutex> lock(progress_mu_);
      ++enqueued_;
    }
    OfferAhead(decoded);
    // Detected on the detection threads while the worker maps the keyframes before it.
    if (detection_) detection_->Prefetch(decoded);
    // Blocks while the mapping worker is behind: back-pressure on this client's stream.
    if (!queue_.Push(std::move(decoded))) {
      std::lock_guard<std::mutex> lock(progress_mu_);
      --enqueued_;  // shutting down; the keyframe is stored and will be mapped on restart
    }
  }
  return ack;
}

StatusOr<KeyframeRecord> MapServer::Validate(const loci::v1::Keyframe& kf,
                                             const SessionRecord& session,
                                             MapperKeyframe* decoded) {
  ValidationLimits limits;
  limits.max_detections = options_.max_detections;
  limits.max_image_px = options_.max_image_px;
  limits.map_extent_m = options_.map_extent_m;
  limits.max_future_ns = SecondsToNs(options_.max_future_s);
  decode_slots_.acquire();  // bounds the memory of concurrent image decodes
  auto record = ValidateKeyframe(kf, session, limits, decoded);
  decode_slots_.release();
  if (!record.ok()) return record;
  LOCI_RETURN_IF_ERROR(CheckStampOrder(*record));
  return record;
}

Status MapServer::CheckStampOrder(const KeyframeRecord& rec) {
  std::unique_lock<std::mutex> lock(sessions_mu_);
  auto it = last_stamp_.find(rec.session_row);
  if (it == last_stamp_.end()) {
    lock.unlock();
    LOCI_ASSIGN_OR_RETURN(LastStamp stored, store_->LastStoredStamp(rec.session_row));
    lock.lock();
    it = last_stamp_.emplace(rec.session_row, stored).first;
  }
  const LastStamp last = it->second;
  const int64_t tolerance_ns = SecondsToNs(1e-3 * options_.stamp_backwards_ms);
  if (rec.seq > last.seq && rec.t_ns < last.t_ns - tolerance_ns) {
    return absl::InvalidArgumentError(absl::StrCat(
        "t_ns ", rec.t_ns, " of seq ", rec.seq, " is ", (last.t_ns - rec.t_ns) / 1'000'000,
        " ms before seq ", last.seq, "'s (stamps must not go back more than ",
        options_.stamp_backwards_ms, " ms)"));
  }
  return absl::OkStatus();
}

void MapServer::NoteStored(const KeyframeRecord& rec) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  LastStamp& last = last_stamp_[rec.session_row];
  if (rec.seq > last.seq) last = {rec.seq, rec.t_ns};
}

StatusOr<loci::v1::CloseSessionResponse> MapServer::CloseSession(
    const loci::v1::CloseSessionRequest& req, const std::string* only_robot) {
  LOCI_ASSIGN_OR_RETURN(SessionRecord s, FindSession(req.session_id(), only_robot));
  LOCI_RETURN_IF_ERROR(store_->CloseSession(s.row_id, NowNs()));
  {
    std::lock_guard<std::mutex> lock(sessions_mu_);
    sessions_[s.session_id].open = false;
  }
  LOCI_ASSIGN_OR_RETURN(uint64_t n, store_->CountKeyframes(s.row_id));
  loci::v1::CloseSessionResponse resp;
  resp.set_keyframes_stored(n);
  return resp;
}

void MapServer::WorkerLoop() {
  while (std::optional<MapperKeyframe> kf = queue_.Pop()) {
    const auto t0 = std::chrono::steady_clock::now();
    bool recognise = false;
    {
      std::lock_guard<HandoffMutex> mapping(mapping_mu_);
      // Written by this thread only: a plain load and store keep the maximum.
      worker_longest_wait_ms_ = std::max(worker_longest_wait_ms_.load(), MsSince(t0));
      const Queued queued = MapQueued(*kf);
      recognise = queued.recognise;
      mapping_ms_total_.fetch_add(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      ++mapping_count_;
      MaybeCheckpoint(queued.shared_map);
    }
    mapping_mu_.LetWaitersIn();  // a chunked pose-graph move waiting for the lock goes next
    if (recognise) {  // outside mapping_mu_: the aligning thread takes it after each keyframe
      {
        std::lock_guard<std::mutex> lock(progress_mu_);
        ++align_enqueued_;
      }
      ++align_pending_;
      if (!align_queue_.Push(std::move(*kf))) {  // closed: shutting down
        --align_pending_;
        std::lock_guard<std::mutex> lock(progress_mu_);
        --align_enqueued_;
      }
    }
    std::lock_guard<std::mutex> lock(progress_mu_);
    ++mapped_;
    progress_cv_.notify_all();
  }
}

void MapServer::AlignLoop() {
  while (true) {
    if (std::optional<MapperKeyframe> ahead = TakeAhead()) {
      QueryAhead(*ahead);
      continue;
    }
    // A short wait: a keyframe offered ahead meanwhile is taken within it.
    std::optional<MapperKeyframe> kf = align_queue_.PopFor(std::chrono::milliseconds(20));
    if (!kf) {
      if (align_queue_.closed()) return;
      continue;
    }
    ++recognised_since_ahead_;
    RecognisePlace(*kf);
    --align_pending_;
    std::lock_guard<std::mutex> lock(progress_mu_);
    ++aligned_through_;
    progress_cv_.notify_all();
  }
}

void MapServer::Flush() {
  std::unique_lock<std::mutex> lock(progress_mu_);
  progress_cv_.wait(lock,
                    [&] { return mapped_ >= enqueued_ && aligned_through_ >= align_enqueued_; });
}

std::optional<LoopStats> MapServer::loop_stats() const {
  if (!closer_) return std::nullopt;
  return closer_->Stats();
}

std::optional<AlignStats> MapServer::align_stats() const {
  if (!aligner_) return std::nullopt;
  return aligner_->Stats();
}

double MapServer::ingest_ms_mean() const {
  const uint64_t n = mapping_count_;
  return n == 0 ? 0.0 : mapping_ms_total_ / static_cast<double>(n);
}

double MapServer::validate_ms_mean() const {
  const uint64_t n = accepted_count_;
  return n == 0 ? 0.0 : validate_ms_total_ / static_cast<double>(n);
}

double MapServer::store_ms_mean() const {
  const uint64_t n = accepted_count_;
  return n == 0 ? 0.0 : store_ms_total_ / static_cast<double>(n);
}

Status MapServer::Subscribe(std::shared_ptr<ObjectEventQueue> queue) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  if (watchers_.size() >= static_cast<size_t>(options_.max_watchers)) {
    return absl::ResourceExhaustedError(
        absl::StrCat("already ", watchers_.size(),
                     " WatchObjects streams (server.max_watchers); each holds a "
                     "server thread"));
  }
  watchers_.push_back(std::move(queue));
  return absl::OkStatus();
}

void MapServer::Unsubscribe(const std::shared_ptr<ObjectEventQueue>& queue) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  std::erase(watchers_, queue);
}

void MapServer::Publish(const std::vector<ObjectEventOut>& events) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  for (auto& w : watchers_) {
    for (const auto& e : events) w->TryPush(e);  // a slow watcher loses events, never blocks
  }
}

}  // namespace loci::server

// MapServer: robots that start anywhere (server/align/). The mapping worker maps a keyframe of
// an aligned session as before; a keyframe of an unaligned session only gets its products
// made and stored. Every keyframe then goes to the aligning thread, whose RobotAligner does
// place recognition off the mapping worker; when it aligns a session, the session's placement
// is stored and its held keyframes enter the map at their new poses, in id order, from their
// stored products (under mapping_mu_, between two keyframes of the worker).
#include <spdlog/spdlog.h>

#include <limits>
#include <map>
#include <set>

#include "server/service/keyframe_decoder.h"
#include "server/service/map_server.h"
#include "server/service/replay.h"

namespace loci::server {

bool MapServer::MapQueued(MapperKeyframe& kf) {
  if (!aligner_) {
    MapAndStoreProducts(*mapper_, kf, detector_.get(), store_.get());
    return false;
  }
  DeclareSession(kf.session_row);
  const std::optional<SE3d> T_base_odom = aligner_->Alignment(kf.session_row);
  if (T_base_odom) {
    kf.T_base_kf = *T_base_odom * kf.T_odom_kf;  // the session may have been aligned since
    MapAndStoreProducts(*mapper_, kf, detector_.get(), store_.get());
  } else {  // held back from the shared map, mapped in its island
    const KeyframeProducts products =
        BuildAndStoreProducts(*mapper_, kf, detector_.get(), store_.get());
    const auto [island_row, T_island_odom] = aligner_->IslandOf(kf.session_row);
    islands_->Integrate(island_row, IslandName(island_row), kf, products, T_island_odom);
  }
  RecordForLoops(kf);
  worker_last_id_ = kf.keyframe_id;
  int64_t none = 0;
  first_live_id_.compare_exchange_strong(none, kf.keyframe_id);
  return true;
}

void MapServer::RecognisePlace(const MapperKeyframe& kf) {
  AlignKeyframe in{kf.keyframe_id, kf.session_row, kf.t_ns, kf.T_odom_kf, std::nullopt};
  if (kf.has_gravity) in.gravity_cam = kf.gravity_cam;
  StatusOr<AlignOutcome> outcome = AlignOutcome();
  try {  // OpenCV asserts by throwing; a keyframe's place recognition must not end the server
    outcome = aligner_->AddKeyframe(in, kf.bgr, kf.depth_m, kf.camera);
  } catch (const std::exception& e) {
    outcome = absl::InternalError(e.what());
  }
  if (!outcome.ok()) {
    spdlog::warn("place recognition skipped keyframe {}: {}", kf.keyframe_id,
                 outcome.status().ToString());
    outcome = AlignOutcome();
  }
  {
    std::lock_guard<HandoffMutex> mapping(mapping_mu_);
    RecordMatches(outcome->matches);
    if (outcome->alignment) ApplyAlignment(*outcome->alignment);
    for (const SessionAlignment& a : outcome->island_alignments) ApplyAlignment(a);
    if (outcome->join) ApplyJoin(*outcome->join);
  }
  MaybeCloseLoops();  // takes mapping_mu_ itself, but not while the graph solves
}

std::optional<SessionRecord> MapServer::SessionByRow(int64_t session_row) {
  {
    std::lock_guard<std::mutex> lock(sessions_mu_);
    for (const auto& [id, s] : sessions_) {
      if (s.row_id == session_row) return s;
    }
  }
  // Not cached (a session read back after a restart): from the store.
  auto all = store_->ListSessions();
  if (!all.ok()) return std::nullopt;
  for (const SessionRecord& r : *all) {
    if (r.row_id != session_row) continue;
    SetSessionCache(r);
    return r;
  }
  return std::nullopt;
}

void MapServer::SetSessionCache(const SessionRecord& session) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  sessions_[session.session_id] = session;
}

void MapServer::DeclareSession(int64_t session_row) {
  if (aligner_->Known(session_row)) return;
  std::optional<SessionRecord> s = SessionByRow(session_row);
  if (!s) {
    aligner_->AddSession(session_row, std::nullopt);
    return;
  }
  if (!s->aligned && mapper_->last_keyframe_id() == 0 && !aligner_->AnyAligned()) {
    // The map's first keyframe: its session defines the base frame.
    s->aligned = true;
    if (Status st = store_->SetSessionAlignment(s->row_id, s->T_base_odom); !st.ok()) {
      spdlog::warn("session {}: alignment not stored: {}", s->session_id, st.ToString());
    }
    SetSessionCache(*s);
    spdlog::info("session {} of robot {} defines the map frame", s->session_id, s->robot_name);
  }
  aligner_->AddSession(session_row, s->aligned ? std::optional<SE3d>(s->T_base_odom)
                                               : std::nullopt);
  if (!s->aligned && s->island_row != 0) {
    aligner_->SetIsland(session_row, s->island_row, s->T_island_odom);
  }
}

std::string MapServer::IslandName(int64_t island_row) {
  const std::optional<SessionRecord> s = SessionByRow(island_row);
  return s ? s->session_id : std::to_string(island_row);
}

void MapServer::ApplyJoin(const IslandJoin& join) {
  for (const auto& [row, T] : join.T_island_odom) {
    if (Status st = store_->SetSessionIsland(row, join.island_row, T); !st.ok()) {
      spdlog::warn("session row {}: island join not stored ({}); it joins again after a restart "
                   "when it matches again", row, st.ToString());
    }
    if (std::optional<SessionRecord> s = SessionByRow(row)) {
      s->island_row = join.island_row;
      s->T_island_odom = T;
      SetSessionCache(*s);
    }
  }
  Publish(islands_->Drop(join.from_island_row));
  uint64_t remapped = 0;
  // The keyframes the worker has seen (it may have mapped one there since the aligner decided).
  for (const auto& [row, T] : join.T_island_odom) {
    remapped += MapIntoIsland(row, join.island_row, T, worker_last_id_);
  }
  spdlog::info("island {} joined island {}: {} keyframes mapped again", join.from_island_row,
               join.island_row, remapped);
}

uint64_t MapServer::MapIntoIsland(int64_t session_row, int64_t island_row,
                                  const SE3d& T_island_odom, int64_t upto_keyframe_id) {
  std::optional<SessionRecord> s = SessionByRow(session_row);
  if (!s) return 0;
  const std::string name = IslandName(island_row);
  const std::optional<IslandMaps::Island> target = islands_->Find(island_row);
  KeyframeScan scan;
  scan.products_fingerprint = mapper_->options().ProductsFingerprint();
  scan.session_row = session_row;
  LoadReport report;
  const Status st = store_->ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (stop_loading_) return absl::CancelledError("the server is stopping");
        if (rec.id > upto_keyframe_id || (target && target->map->HasKeyframe(rec.id))) {
          return absl::OkStatus();
        }
        MapperKeyframe meta;
        const std::optional<KeyframeProducts> products =
            StoredProducts(rec, *s, *mapper_, detector_.get(), store_.get(), &report, &meta);
        if (products) islands_->Integrate(island_row, name, meta, *products, T_island_odom);
        return absl::OkStatus();
      },
      scan);
  if (!st.ok()) spdlog::warn("session {}: not all keyframes mapped into its island: {}",
                             s->session_id, st.ToString());
  return report.keyframes();
}

void MapServer::ApplyAlignment(const SessionAlignment& a) {
  std::optional<SessionRecord> s = SessionByRow(a.session_row);
  if (!s) return;
  s->T_base_odom = a.T_base_odom;
  s->aligned = true;
  if (Status st = store_->SetSessionAlignment(s->row_id, s->T_base_odom); !st.ok()) {
    spdlog::warn("session {}: alignment not stored ({}); it aligns again after a restart",
                 s->session_id, st.ToString());
  }
  SetSessionCache(*s);
  // Its island's objects now enter the shared map (with the island's other sessions, which are
  // aligned with it).
  Publish(islands_->Drop(s->island_row != 0 ? s->island_row : s->row_id));
  if (a.refined) {
    MoveSession(a);
    return;
  }
  // The held keyframes: those the worker has seen and not mapped (later ones are still queued
  // and are mapped at the new placement when the worker reaches them; the worker may also have
  // mapped some directly since the aligner set the placement).
  const int64_t upto_keyframe_id = worker_last_id_;
  KeyframeScan scan;
  scan.products_fingerprint = mapper_->options().ProductsFingerprint();
  scan.session_row = s->row_id;
  LoadReport report;
  Status st = store_->ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (rec.id > upto_keyframe_id || mapper_->HasKeyframe(rec.id)) return absl::OkStatus();
        if (!LoadKeyframe(rec, *s, *mapper_, detector_.get(), store_.get(), &report)) {
          ++report.skipped;
        }
        return absl::OkStatus();
      },
      scan);
  if (!st.ok()) spdlog::warn("session {}: held keyframes not all mapped: {}", s->session_id,
                             st.ToString());
  spdlog::info("robot {} (session {}) aligned to the map: {} keyframes mapped, {} skipped",
               s->robot_name, s->session_id, report.keyframes(), report.skipped);
  merged_keyframes_ += report.keyframes();
  // The keyframes just mapped have ids below the checkpoint's last one: checkpoint now, so a
  // restart does not lose them from the map.
  if (Status c = Checkpoint(); !c.ok()) {
    spdlog::warn("checkpoint: {}", c.ToString());
    since_checkpoint_ += report.keyframes();
  } else {
    since_checkpoint_ = 0;
    last_checkpoint_ = std::chrono::steady_clock::now();
  }
}

void MapServer::DeclareStoredSessions() {
  if (!aligner_) return;
  auto sessions = store_->ListSessions();
  if (!sessions.ok()) {
    spdlog::warn("sessions not declared at load ({}); each is on its next keyframe",
                 sessions.status().ToString());
    return;
  }
  // Aligned sessions first: an unaligned one never becomes the map's origin here.
  for (const bool aligned : {true, false}) {
    for (const SessionRecord& s : *sessions) {
      if (s.aligned != aligned) continue;
      auto keyframes = store_->CountKeyframes(s.row_id);
      // A session without keyframes is declared on its first (which may make it the origin).
      if (!keyframes.ok() || *keyframes == 0) continue;
      DeclareSession(s.row_id);
    }
  }
}

void MapServer::LoadIslands() {
  if (!islands_) return;
  auto sessions = store_->ListSessions();
  if (!sessions.ok()) {
    spdlog::warn("islands not loaded: {}", sessions.status().ToString());
    return;
  }
  for (const SessionRecord& s : *sessions) {
    if (s.aligned) continue;
    const uint64_t n = MapIntoIsland(s.row_id, s.island_row != 0 ? s.island_row : s.row_id,
                                     s.T_island_odom, std::numeric_limits<int64_t>::max());
    spdlog::info("island of robot {} (session {}, not aligned): {} keyframes mapped",
                 s.robot_name, s.session_id, n);
  }
}

void MapServer::Reindex() {
  if (!aligner_) {
    reindexed_ = true;
    return;
  }
  LoadPlaceMatches();
  const auto t0 = std::chrono::steady_clock::now();
  ReindexCounts counts;
  // Pass 1: the keyframes with stored features (no images read).
  std::set<int64_t> need_images;
  KeyframeScan metadata;
  metadata.images = false;
  Status st = store_->ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (stop_loading_) return absl::CancelledError("the server is stopping");
        if (closer_) {
          closer_->AddKeyframe({rec.id, rec.session_row, rec.segment, rec.t_ns, rec.T_odom_cam,
                                rec.tracking_inliers,
                                rec.has_gravity ? rec.gravity_cam : Vec3d::Zero()});
        }
        if (!ToReindex(rec)) return absl::OkStatus();
        if (!ReindexFromFeatures(rec, &counts)) need_images.insert(rec.id);
        return absl::OkStatus();
      },
      metadata);
  // Pass 2: the others, from their images (databases written before features were stored, or
  // features of other options).
  if (st.ok() && !need_images.empty()) {
    st = store_->ForEachKeyframe(
        *need_images.begin() - 1,
        [&](KeyframeRecord rec) -> Status {
          if (stop_loading_) return absl::CancelledError("the server is stopping");
          if (need_images.count(rec.id) && ToReindex(rec)) ReindexFromImages(rec, &counts);
          return absl::OkStatus();
        },
        KeyframeScan());
  }
  reindexed_ = st.ok();
  spdlog::info("place recognition: {} stored keyframes re-indexed in {:.1f} s ({} from stored "
               "features, {} without images){}",
               counts.from_features + counts.from_images,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
               counts.from_features, counts.without_images,
               st.ok() ? "" : absl::StrCat("; stopped: ", st.ToString()));
}

namespace {

// What the aligner needs of a stored keyframe.
AlignKeyframe AlignInput(const KeyframeRecord& rec) {
  AlignKeyframe in{rec.id, rec.session_row, rec.t_ns, rec.T_odom_cam, std::nullopt};
  if (rec.has_gravity) in.gravity_cam = rec.gravity_cam;
  return in;
}

}  // namespace

bool MapServer::ToReindex(const KeyframeRecord& rec) {
  const int64_t first_live = first_live_id_;
  if (first_live != 0 && rec.id >= first_live) return false;  // the aligning thread's
  return !aligner_->Indexed(rec.id);
}

bool MapServer::ReindexFromFeatures(const KeyframeRecord& rec, ReindexCounts* counts) {
  StatusOr<std::optional<place::KeyframeFeatures>> stored = features_->Get(rec.id);
  if (!stored.ok()) {
    spdlog::warn("re-indexing keyframe {}: {}; extracting them again", rec.id,
                 stored.status().ToString());
    return false;
  }
  if (!*stored) return false;
  DeclareSession(rec.session_row);
  if (Status st = aligner_->IndexStored(AlignInput(rec), std::move(**stored)); !st.ok()) {
    spdlog::warn("re-indexing keyframe {}: {}", rec.id, st.ToString());
    return true;  // the images would give the same features
  }
  ++counts->from_features;
  return true;
}

void MapServer::ReindexFromImages(const KeyframeRecord& rec, ReindexCounts* counts) {
  if (rec.rgb_jpeg.empty()) {
    ++counts->without_images;  // retention dropped them
    return;
  }
  DeclareSession(rec.session_row);
  std::optional<SessionRecord> session = SessionByRow(rec.session_row);
  if (!session) return;
  auto kf = DecodeKeyframe(rec, *session);
  if (!kf.ok()) return;  // validated on ingest; a corrupt row is skipped
  try {
    if (aligner_->AddKeyframe(AlignInput(rec), kf->bgr, kf->depth_m, kf->camera, /*match=*/false).ok()) {
      ++counts->from_images;
    }
  } catch (const std::exception& e) {
    spdlog::warn("re-indexing keyframe {}: {}", rec.id, e.what());
  }
}

void MapServer::MoveSession(const SessionAlignment& a) {
  // The session's mapped keyframes (place recognition may not have indexed the newest yet).
  std::vector<Mapper::KeyframePoseUpdate> updates;
  KeyframeScan scan;
  scan.images = false;
  scan.session_row = a.session_row;
  const Status st = store_->ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (mapper_->HasKeyframe(rec.id)) updates.push_back({rec.id, a.T_base_odom * rec.T_odom_cam});
        return absl::OkStatus();
      },
      scan);
  if (!st.ok()) {
    spdlog::warn("refined placement of session row {} not applied: {}", a.session_row,
                 st.ToString());
    return;
  }
  auto moved = UpdateKeyframePosesLocked(updates);
  if (!moved.ok()) {
    spdlog::warn("refined placement of session row {} not applied to its mapped keyframes: {}",
                 a.session_row, moved.status().ToString());
  }
}

}  // namespace loci::server

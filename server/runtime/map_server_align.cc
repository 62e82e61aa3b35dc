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

#include "common/time.h"
#include "server/runtime/chunked_move.h"
#include "server/runtime/keyframe_decoder.h"
#include "server/runtime/map_server.h"
#include "server/runtime/replay.h"

namespace loci::server {

MapServer::Queued MapServer::MapQueued(MapperKeyframe& kf) {
  if (!aligner_) {
    MapAndStoreProducts(*mapper_, kf, detection_.get(), store_.get());
    return {.recognise = false, .shared_map = true};
  }
  DeclareSession(kf.session_row);
  const std::optional<SE3d> T_base_odom = aligner_->Alignment(kf.session_row);
  if (T_base_odom) {
    kf.T_base_kf = *T_base_odom * kf.T_odom_kf;  // the session may have been aligned since
    MapAndStoreProducts(*mapper_, kf, detection_.get(), store_.get());
  } else {  // held back from the shared map, mapped in its island
    const KeyframeProducts products =
        BuildAndStoreProducts(*mapper_, kf, detection_.get(), store_.get());
    const auto [island_row, T_island_odom] = aligner_->IslandOf(kf.session_row);
    islands_->Integrate(island_row, IslandName(island_row), kf, products, T_island_odom);
  }
  RecordForLoops(kf);
  worker_last_id_ = kf.keyframe_id;
  int64_t none = 0;
  first_live_id_.compare_exchange_strong(none, kf.keyframe_id);
  return {.recognise = true, .shared_map = T_base_odom.has_value()};
}

AlignOutcome MapServer::Guarded(
    const MapperKeyframe& kf, const char* what,
    const std::function<StatusOr<AlignOutcome>(const AlignKeyframe&)>& recognise) {
  AlignKeyframe in{kf.keyframe_id, kf.session_row, kf.t_ns, kf.T_odom_kf, std::nullopt};
  if (kf.has_gravity) in.gravity_cam = kf.gravity_cam;
  StatusOr<AlignOutcome> outcome = AlignOutcome();
  try {
    outcome = recognise(in);
  } catch (const std::exception& e) {
    outcome = absl::InternalError(e.what());
  }
  if (outcome.ok()) return *std::move(outcome);
  spdlog::warn("{} skipped keyframe {}: {}", what, kf.keyframe_id, outcome.status().ToString());
  return AlignOutcome();
}

void MapServer::RecognisePlace(const MapperKeyframe& kf) {
  const AlignOutcome outcome =
      Guarded(kf, "place recognition", [&](const AlignKeyframe& in) {
        return aligner_->AddKeyframe(in, kf.bgr, kf.depth_m, kf.camera);
      });
  ApplyOutcome(kf, outcome);
  MaybeCloseLoops();  // takes mapping_mu_ itself, but not while the graph solves
}

void MapServer::ApplyOutcome(const MapperKeyframe& kf, const AlignOutcome& outcome) {
  std::vector<HeldKeyframes> held;
  std::optional<JoinedIsland> joined;
  std::vector<Mapper::KeyframePoseUpdate> moves;  // refined placements
  {
    std::lock_guard<FifoMutex> mapping(mapping_mu_);
    RecordMatches(kf.session_row, outcome.matches);
    auto apply = [&](const SessionAlignment& a) {
      if (std::optional<HeldKeyframes> h = ApplyAlignment(a, &moves)) {
        held.push_back(std::move(*h));
      }
    };
    if (outcome.alignment) apply(*outcome.alignment);
    for (const SessionAlignment& a : outcome.island_alignments) apply(a);
    if (outcome.join) joined = ApplyJoin(*outcome.join);
    // No checkpoint until they are all in: one taken between two chunks would hold a later
    // keyframe id than held keyframes it lacks, which a restart would then not map.
    checkpointer_.HoldForMerge(!held.empty());
  }
  if (!held.empty()) MapHeldKeyframes(held);
  if (joined) MapJoinedIsland(*joined);
  if (!moves.empty()) MoveSessions(std::move(moves));
}

void MapServer::DeclareSession(int64_t session_row) {
  if (aligner_->Known(session_row)) return;
  std::optional<SessionRecord> s = sessions_.ByRow(session_row);
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
    sessions_.Put(*s);
    spdlog::info("session {} of robot {} defines the map frame", s->session_id, s->robot_name);
  }
  aligner_->AddSession(session_row, s->aligned ? std::optional<SE3d>(s->T_base_odom)
                                               : std::nullopt);
  if (!s->aligned && s->island_row != 0) {
    aligner_->SetIsland(session_row, s->island_row, s->T_island_odom);
  }
}

std::string MapServer::IslandName(int64_t island_row) {
  const std::optional<SessionRecord> s = sessions_.ByRow(island_row);
  return s ? s->session_id : std::to_string(island_row);
}

MapServer::JoinedIsland MapServer::ApplyJoin(const IslandJoin& join) {
  // Its keyframes enter the other island where its own loop closure put them (their poses
  // carried over by any of its sessions' old and new placements, which differ by one transform).
  if (!join.T_island_odom.empty()) {
    const auto& [row, T_to_odom] = join.T_island_odom.front();
    if (const std::optional<SessionRecord> s = sessions_.ByRow(row)) {
      StoreIslandPoses(join.from_island_row, join.island_row,
                       T_to_odom * s->T_island_odom.inverse());
    }
  }
  for (const auto& [row, T] : join.T_island_odom) {
    if (Status st = store_->SetSessionIsland(row, join.island_row, T); !st.ok()) {
      spdlog::warn("session row {}: island join not stored ({}); it joins again after a restart "
                   "when it matches again", row, st.ToString());
    }
    if (std::optional<SessionRecord> s = sessions_.ByRow(row)) {
      s->island_row = join.island_row;
      s->T_island_odom = T;
      sessions_.Put(*s);
    }
  }
  events_.Publish(islands_->Drop(join.from_island_row));
  // Its loops are edges of the island it joined now.
  if (closer_) closer_->MoveDue(join.from_island_row, join.island_row);
  // The keyframes the worker has seen (it may map newer ones there before these are in).
  return {join, worker_last_id_};
}

void MapServer::MapJoinedIsland(const JoinedIsland& joined) {
  uint64_t remapped = 0;
  for (const auto& [row, T] : joined.join.T_island_odom) {
    remapped += MapIntoIsland(row, joined.join.island_row, T, joined.upto_keyframe_id);
  }
  spdlog::info("island {} joined island {}: {} keyframes mapped again", joined.join.from_island_row,
               joined.join.island_row, remapped);
}

uint64_t MapServer::MapIntoIsland(int64_t session_row, int64_t island_row,
                                  const SE3d& T_island_odom, int64_t upto_keyframe_id) {
  std::optional<SessionRecord> s = sessions_.ByRow(session_row);
  if (!s) return 0;
  const std::string name = IslandName(island_row);
  auto in_island = [&](int64_t id) {
    const std::optional<IslandMaps::Island> target = islands_->Find(island_row);
    return target && target->map->HasKeyframe(id);
  };
  LoadReport report;
  const ChunkedMoveFigures f = MapInChunks(
      UnmappedKeyframeIds(*s, upto_keyframe_id, in_island),
      static_cast<size_t>(options_.align.held_chunk_keyframes), mapping_mu_,
      [&](int64_t first_id, int64_t last_id) -> StatusOr<std::vector<LoadedKeyframe>> {
        // An island is mapped again on every start: it can stop part-way at shutdown.
        if (stop_loading_) return absl::CancelledError("the server is stopping");
        return LoadStored(*s, first_id, last_id, &report);
      },
      [&](const LoadedKeyframe& kf) {
        if (in_island(kf.meta.keyframe_id)) return false;
        islands_->Integrate(island_row, name, kf.meta, kf.products, T_island_odom,
                            kf.T_kf_corrected);
        return true;
      });
  if (!f.status.ok()) {
    spdlog::warn("session {}: not all keyframes mapped into its island: {}", s->session_id,
                 f.status.ToString());
  }
  return f.moved;
}

void MapServer::OfferAhead(const MapperKeyframe& kf) {
  const int backlog = options_.align.query_ahead_backlog;
  if (!aligner_ || backlog <= 0) return;
  if (queue_.size() + align_queue_.size() < static_cast<size_t>(backlog)) return;
  if (!aligner_->Known(kf.session_row) || aligner_->Alignment(kf.session_row)) return;
  ahead_.Offer(kf);
}

void MapServer::QueryAhead(const MapperKeyframe& kf) {
  const AlignOutcome outcome =
      Guarded(kf, "place recognition ahead of the backlog", [&](const AlignKeyframe& in) {
        return aligner_->QueryAhead(in, kf.bgr, kf.depth_m, kf.camera);
      });
  ahead_.NoteOutcome(kf.session_row, !outcome.matches.empty() && !outcome.alignment);
  if (outcome.alignment) {
    spdlog::info("session row {} aligned at keyframe {}, recognised ahead of {} waiting keyframes",
                 kf.session_row, kf.keyframe_id, queue_.size() + align_queue_.size());
  }
  if (outcome.alignment || !outcome.matches.empty()) ApplyOutcome(kf, outcome);
}

std::optional<MapServer::HeldKeyframes> MapServer::ApplyAlignment(
    const SessionAlignment& a, std::vector<Mapper::KeyframePoseUpdate>* moves) {
  std::optional<SessionRecord> s = sessions_.ByRow(a.session_row);
  if (!s) return std::nullopt;
  s->T_base_odom = a.T_base_odom;
  s->aligned = true;
  if (Status st = store_->SetSessionAlignment(s->row_id, s->T_base_odom); !st.ok()) {
    spdlog::warn("session {}: alignment not stored ({}); it aligns again after a restart",
                 s->session_id, st.ToString());
  }
  sessions_.Put(*s);
  // Its island's objects now enter the shared map (with the island's other sessions, which are
  // aligned with it).
  const int64_t island_row = s->island_row != 0 ? s->island_row : s->row_id;
  if (!a.refined) {
    StoreIslandPoses(island_row, kSharedGraph, s->T_base_odom * s->T_island_odom.inverse());
  }
  events_.Publish(islands_->Drop(island_row));
  // The island's loops are edges of the shared map's pose graph now.
  if (closer_) closer_->MoveDue(island_row, kSharedGraph);
  if (a.refined) {
    std::vector<Mapper::KeyframePoseUpdate> m = SessionMoves(a);
    moves->insert(moves->end(), m.begin(), m.end());
    return std::nullopt;
  }
  // The held keyframes: those the worker has seen and not mapped (later ones are still queued
  // and are mapped at the new placement when the worker reaches them; the worker may also map
  // some directly before the held ones are in).
  return HeldKeyframes{*s, worker_last_id_};
}

bool MapServer::StoreIslandPoses(int64_t island_row, int64_t to_map_row,
                                 const SE3d& T_to_island) {
  const std::optional<IslandMaps::Island> island = islands_ ? islands_->Find(island_row)
                                                            : std::nullopt;
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

void MapServer::MapHeldKeyframes(const std::vector<HeldKeyframes>& sessions) {
  const auto start = std::chrono::steady_clock::now();
  ChunkedMoveFigures all;
  for (const HeldKeyframes& h : sessions) {
    LoadReport report;
    const ChunkedMoveFigures f = MapInChunks(
        UnmappedKeyframeIds(h.session, h.upto_keyframe_id,
                            [&](int64_t id) { return mapper_->HasKeyframe(id); }),
        static_cast<size_t>(options_.align.held_chunk_keyframes), mapping_mu_,
        [&](int64_t first_id, int64_t last_id) {
          return LoadStored(h.session, first_id, last_id, &report);
        },
        [&](const LoadedKeyframe& kf) {
          if (mapper_->HasKeyframe(kf.meta.keyframe_id)) return false;
          mapper_->Integrate(kf.meta, kf.products);
          return true;
        });
    if (!f.status.ok()) {
      spdlog::warn("session {}: held keyframes not all mapped: {}", h.session.session_id,
                   f.status.ToString());
    }
    spdlog::info("robot {} (session {}) aligned to the map: {} held keyframes mapped ({} skipped) "
                 "in {:.0f} ms, {} chunks, mapping paused at most {:.0f} ms",
                 h.session.robot_name, h.session.session_id, f.moved, report.skipped, f.total_ms,
                 f.chunks, f.longest_hold_ms);
    merged_keyframes_ += f.moved;
    all.moved += f.moved;
    all.chunks += f.chunks;
    all.longest_hold_ms = std::max(all.longest_hold_ms, f.longest_hold_ms);
  }
  {
    // The keyframes just mapped have ids below the last checkpoint's: checkpoint now, so a
    // restart does not lose them from the map (a restart also maps those a checkpoint lacks).
    std::lock_guard<FifoMutex> mapping(mapping_mu_);
    checkpointer_.WriteAfterMerge(all.moved);
  }
  std::lock_guard<std::mutex> lock(held_merge_mu_);
  held_merge_stats_.last_ms = MsSince(start);
  held_merge_stats_.last_chunks = all.chunks;
  held_merge_stats_.last_keyframes = all.moved;
  held_merge_stats_.last_longest_hold_ms = all.longest_hold_ms;
  held_merge_stats_.longest_hold_ms =
      std::max(held_merge_stats_.longest_hold_ms, all.longest_hold_ms);
}

std::vector<int64_t> MapServer::UnmappedKeyframeIds(
    const SessionRecord& session, int64_t upto_keyframe_id,
    const std::function<bool(int64_t)>& mapped) {
  std::vector<int64_t> ids;
  KeyframeScan scan;
  scan.images = false;
  scan.session_row = session.row_id;
  scan.last_id = upto_keyframe_id;
  const Status st = store_->ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (!mapped(rec.id)) ids.push_back(rec.id);
        return absl::OkStatus();
      },
      scan);
  if (!st.ok()) {
    spdlog::warn("session {}: keyframes to map not all listed: {}", session.session_id,
                 st.ToString());
  }
  return ids;
}

StatusOr<std::vector<LoadedKeyframe>> MapServer::LoadStored(const SessionRecord& session,
                                                             int64_t first_id, int64_t last_id,
                                                             LoadReport* report) {
  std::vector<LoadedKeyframe> out;
  KeyframeScan scan;
  scan.products_fingerprint = mapper_->options().ProductsFingerprint();
  scan.session_row = session.row_id;
  scan.last_id = last_id;
  LOCI_RETURN_IF_ERROR(store_->ForEachKeyframe(
      first_id - 1,
      [&](KeyframeRecord rec) -> Status {
        LoadedKeyframe kf;
        std::optional<KeyframeProducts> products = StoredProducts(
            rec, session, *mapper_, detection_.get(), store_.get(), report, &kf.meta);
        if (!products) {
          ++report->skipped;
          return absl::OkStatus();
        }
        kf.products = std::move(*products);
        kf.T_kf_corrected = rec.T_base_kf_corrected;
        out.push_back(std::move(kf));
        return absl::OkStatus();
      },
      scan));
  return out;
}

MapServer::HeldMergeStats MapServer::held_merge_stats() const {
  std::lock_guard<std::mutex> lock(held_merge_mu_);
  return held_merge_stats_;
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
  const auto t0 = std::chrono::steady_clock::now();
  ReindexCounts counts;
  // Keyframes without a stored pose came after their graph's last solve (which stores every
  // keyframe's): with their matches they count towards its next one.
  std::map<int64_t, int64_t> unsolved;  // keyframe id -> graph
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
        const int64_t graph = GraphOf(rec.session_row);
        if (rec.T_base_kf_corrected) {  // in the frame of the map holding it
          aligner_->SetMappedPoses(graph, {{rec.id, *rec.T_base_kf_corrected}});
        } else if (closer_ && !LiveKeyframe(rec.id)) {  // a live one counts as it comes
          unsolved[rec.id] = graph;
          closer_->NoteRecognised(graph);
        }
        if (!ToReindex(rec)) return absl::OkStatus();
        if (!ReindexFromFeatures(rec, &counts)) need_images.insert(rec.id);
        return absl::OkStatus();
      },
      metadata);
  if (st.ok()) LoadPlaceMatches(unsolved);
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
  // Matches found after a graph's last solve are solved now, not when new keyframes come.
  if (reindexed_) MaybeCloseLoops();
}

namespace {

// What the aligner needs of a stored keyframe.
AlignKeyframe AlignInput(const KeyframeRecord& rec) {
  AlignKeyframe in{rec.id, rec.session_row, rec.t_ns, rec.T_odom_cam, std::nullopt};
  if (rec.has_gravity) in.gravity_cam = rec.gravity_cam;
  return in;
}

}  // namespace

bool MapServer::LiveKeyframe(int64_t keyframe_id) const {
  const int64_t first_live = first_live_id_;
  return first_live != 0 && keyframe_id >= first_live;
}

bool MapServer::ToReindex(const KeyframeRecord& rec) {
  if (LiveKeyframe(rec.id)) return false;  // the aligning thread's
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
  std::optional<SessionRecord> session = sessions_.ByRow(rec.session_row);
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

std::vector<Mapper::KeyframePoseUpdate> MapServer::SessionMoves(const SessionAlignment& a) {
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
    return {};
  }
  return updates;
}

void MapServer::MoveSessions(std::vector<Mapper::KeyframePoseUpdate> moves) {
  const ChunkedMoveFigures moved = MoveInChunks(
      std::move(moves), static_cast<size_t>(options_.align.loops.apply_chunk_keyframes),
      mapping_mu_, [] { return absl::OkStatus(); },
      [this](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) {
        return UpdateKeyframePosesLocked(chunk, /*rebuild_octomap=*/last);
      });
  if (!moved.status.ok()) {
    spdlog::warn("refined placement applied to {} mapped keyframes only: {}", moved.moved,
                 moved.status.ToString());
  }
}

}  // namespace loci::server

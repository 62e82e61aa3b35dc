#include "server/runtime/align_stage.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <limits>

#include "common/thread_name.h"
#include "common/time.h"
#include "server/runtime/keyframe_decoder.h"

namespace loci::server {

AlignStage::AlignStage(const MapContext& ctx, MapWorker* worker, GraphStage* graph,
                       PipelineProgress* progress)
    : ctx_(ctx),
      worker_(worker),
      graph_(graph),
      progress_(progress),
      queue_(static_cast<size_t>(ctx.options.queue_capacity)) {}

void AlignStage::Start() { thread_ = NamedThread("loci-align", [this] { Loop(); }); }

void AlignStage::Stop() {
  queue_.Close();
  if (thread_.joinable()) thread_.join();
}

void AlignStage::Loop() {
  while (true) {
    if (std::optional<MapperKeyframe> ahead = ahead_.Take(queue_.size() == 0)) {
      QueryAhead(*ahead);
      continue;
    }
    // A short wait: a keyframe offered ahead meanwhile is taken within it.
    std::optional<MapperKeyframe> kf = queue_.PopFor(std::chrono::milliseconds(20));
    if (!kf) {
      if (queue_.closed()) return;
      continue;
    }
    ahead_.NoteRecognised();
    RecognisePlace(*kf);
    progress_->Recognised();
  }
}

AlignOutcome AlignStage::Guarded(
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

void AlignStage::RecognisePlace(const MapperKeyframe& kf) {
  const AlignOutcome outcome =
      Guarded(kf, "place recognition", [&](const AlignKeyframe& in) {
        return ctx_.aligner->AddKeyframe(in, kf.bgr, kf.depth_m, kf.camera);
      });
  ApplyOutcome(kf, outcome);
  graph_->MaybeCloseLoops(queue_.size() > 0);  // takes worker_->mapping_mutex() itself, but not while the graph solves
}

void AlignStage::ApplyOutcome(const MapperKeyframe& kf, const AlignOutcome& outcome) {
  std::vector<HeldKeyframes> held;
  std::optional<JoinedIsland> joined;
  std::vector<Mapper::KeyframePoseUpdate> moves;  // refined placements
  {
    std::lock_guard<FifoMutex> mapping(worker_->mapping_mutex());
    graph_->RecordMatches(kf.session_row, outcome.matches);
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
    ctx_.checkpointer.HoldForMerge(!held.empty());
  }
  if (!held.empty()) MapHeldKeyframes(held);
  if (joined) MapJoinedIsland(*joined);
  if (!moves.empty()) MoveSessions(std::move(moves));
}

AlignStage::JoinedIsland AlignStage::ApplyJoin(const IslandJoin& join) {
  // Its keyframes enter the other island where its own loop closure put them (their poses
  // carried over by any of its sessions' old and new placements, which differ by one transform).
  if (!join.T_island_odom.empty()) {
    const auto& [row, T_to_odom] = join.T_island_odom.front();
    if (const std::optional<SessionRecord> s = ctx_.sessions.ByRow(row)) {
      worker_->StoreIslandPoses(join.from_island_row, join.island_row,
                       T_to_odom * s->T_island_odom.inverse());
    }
  }
  for (const auto& [row, T] : join.T_island_odom) {
    if (Status st = ctx_.store.SetSessionIsland(row, join.island_row, T); !st.ok()) {
      spdlog::warn("session row {}: island join not stored ({}); it joins again after a restart "
                   "when it matches again", row, st.ToString());
    }
    if (std::optional<SessionRecord> s = ctx_.sessions.ByRow(row)) {
      s->island_row = join.island_row;
      s->T_island_odom = T;
      ctx_.sessions.Put(*s);
    }
  }
  ctx_.events.Publish(ctx_.islands->Drop(join.from_island_row));
  // Its loops are edges of the island it joined now.
  if (ctx_.closer) ctx_.closer->MoveDue(join.from_island_row, join.island_row);
  // The keyframes the worker has seen (it may map newer ones there before these are in).
  return {join, worker_->last_id()};
}

void AlignStage::MapJoinedIsland(const JoinedIsland& joined) {
  uint64_t remapped = 0;
  for (const auto& [row, T] : joined.join.T_island_odom) {
    remapped += MapIntoIsland(row, joined.join.island_row, T, joined.upto_keyframe_id);
  }
  spdlog::info("island {} joined island {}: {} keyframes mapped again", joined.join.from_island_row,
               joined.join.island_row, remapped);
}

uint64_t AlignStage::MapIntoIsland(int64_t session_row, int64_t island_row,
                                  const SE3d& T_island_odom, int64_t upto_keyframe_id) {
  std::optional<SessionRecord> s = ctx_.sessions.ByRow(session_row);
  if (!s) return 0;
  const std::string name = worker_->IslandName(island_row);
  auto in_island = [&](int64_t id) {
    const std::optional<IslandMaps::Island> target = ctx_.islands->Find(island_row);
    return target && target->map->HasKeyframe(id);
  };
  LoadReport report;
  const ChunkedMoveFigures f = MapInChunks(
      UnmappedKeyframeIds(*s, upto_keyframe_id, in_island),
      static_cast<size_t>(ctx_.options.align.held_chunk_keyframes), worker_->mapping_mutex(),
      [&](int64_t first_id, int64_t last_id) -> StatusOr<std::vector<LoadedKeyframe>> {
        // An island is mapped again on every start: it can stop part-way at shutdown.
        if (ctx_.stopping) return absl::CancelledError("the server is stopping");
        return LoadStored(*s, first_id, last_id, &report);
      },
      [&](const LoadedKeyframe& kf) {
        if (in_island(kf.meta.keyframe_id)) return false;
        ctx_.islands->Integrate(island_row, name, kf.meta, kf.products, T_island_odom,
                            kf.T_kf_corrected);
        return true;
      });
  if (!f.status.ok()) {
    spdlog::warn("session {}: not all keyframes mapped into its island: {}", s->session_id,
                 f.status.ToString());
  }
  return f.moved;
}

void AlignStage::OfferAhead(const MapperKeyframe& kf) {
  const int backlog = ctx_.options.align.query_ahead_backlog;
  if (!ctx_.aligner || backlog <= 0) return;
  if (worker_->waiting() + queue_.size() < static_cast<size_t>(backlog)) return;
  if (!ctx_.aligner->Known(kf.session_row) || ctx_.aligner->Alignment(kf.session_row)) return;
  ahead_.Offer(kf);
}

void AlignStage::QueryAhead(const MapperKeyframe& kf) {
  const AlignOutcome outcome =
      Guarded(kf, "place recognition ahead of the backlog", [&](const AlignKeyframe& in) {
        return ctx_.aligner->QueryAhead(in, kf.bgr, kf.depth_m, kf.camera);
      });
  ahead_.NoteOutcome(kf.session_row, !outcome.matches.empty() && !outcome.alignment);
  if (outcome.alignment) {
    spdlog::info("session row {} aligned at keyframe {}, recognised ahead of {} waiting keyframes",
                 kf.session_row, kf.keyframe_id, worker_->waiting() + queue_.size());
  }
  if (outcome.alignment || !outcome.matches.empty()) ApplyOutcome(kf, outcome);
}

std::optional<AlignStage::HeldKeyframes> AlignStage::ApplyAlignment(
    const SessionAlignment& a, std::vector<Mapper::KeyframePoseUpdate>* moves) {
  std::optional<SessionRecord> s = ctx_.sessions.ByRow(a.session_row);
  if (!s) return std::nullopt;
  s->T_base_odom = a.T_base_odom;
  s->aligned = true;
  if (Status st = ctx_.store.SetSessionAlignment(s->row_id, s->T_base_odom); !st.ok()) {
    spdlog::warn("session {}: alignment not stored ({}); it aligns again after a restart",
                 s->session_id, st.ToString());
  }
  ctx_.sessions.Put(*s);
  // Its island's objects now enter the shared map (with the island's other sessions, which are
  // aligned with it).
  const int64_t island_row = s->island_row != 0 ? s->island_row : s->row_id;
  if (!a.refined) {
    worker_->StoreIslandPoses(island_row, kSharedGraph, s->T_base_odom * s->T_island_odom.inverse());
  }
  ctx_.events.Publish(ctx_.islands->Drop(island_row));
  // The island's loops are edges of the shared map's pose graph now.
  if (ctx_.closer) ctx_.closer->MoveDue(island_row, kSharedGraph);
  if (a.refined) {
    std::vector<Mapper::KeyframePoseUpdate> m = SessionMoves(a);
    moves->insert(moves->end(), m.begin(), m.end());
    return std::nullopt;
  }
  // The held keyframes: those the worker has seen and not mapped (later ones are still queued
  // and are mapped at the new placement when the worker reaches them; the worker may also map
  // some directly before the held ones are in).
  return HeldKeyframes{*s, worker_->last_id()};
}

void AlignStage::MapHeldKeyframes(const std::vector<HeldKeyframes>& sessions) {
  const auto start = std::chrono::steady_clock::now();
  ChunkedMoveFigures all;
  for (const HeldKeyframes& h : sessions) {
    LoadReport report;
    const ChunkedMoveFigures f = MapInChunks(
        UnmappedKeyframeIds(h.session, h.upto_keyframe_id,
                            [&](int64_t id) { return ctx_.mapper->HasKeyframe(id); }),
        static_cast<size_t>(ctx_.options.align.held_chunk_keyframes), worker_->mapping_mutex(),
        [&](int64_t first_id, int64_t last_id) {
          return LoadStored(h.session, first_id, last_id, &report);
        },
        [&](const LoadedKeyframe& kf) {
          if (ctx_.mapper->HasKeyframe(kf.meta.keyframe_id)) return false;
          ctx_.mapper->Integrate(kf.meta, kf.products);
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
    all.moved += f.moved;
    all.chunks += f.chunks;
    all.longest_hold_ms = std::max(all.longest_hold_ms, f.longest_hold_ms);
  }
  {
    // The keyframes just mapped have ids below the last checkpoint's: checkpoint now, so a
    // restart does not lose them from the map (a restart also maps those a checkpoint lacks).
    std::lock_guard<FifoMutex> mapping(worker_->mapping_mutex());
    ctx_.checkpointer.WriteAfterMerge(all.moved);
  }
  std::lock_guard<std::mutex> lock(stats_mu_);
  stats_.merged_keyframes += all.moved;
  stats_.last_ms = MsSince(start);
  stats_.last_chunks = all.chunks;
  stats_.last_keyframes = all.moved;
  stats_.last_longest_hold_ms = all.longest_hold_ms;
  stats_.longest_hold_ms =
      std::max(stats_.longest_hold_ms, all.longest_hold_ms);
}

std::vector<int64_t> AlignStage::UnmappedKeyframeIds(
    const SessionRecord& session, int64_t upto_keyframe_id,
    const std::function<bool(int64_t)>& mapped) {
  std::vector<int64_t> ids;
  KeyframeScan scan;
  scan.images = false;
  scan.session_row = session.row_id;
  scan.last_id = upto_keyframe_id;
  const Status st = ctx_.store.ForEachKeyframe(
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

StatusOr<std::vector<LoadedKeyframe>> AlignStage::LoadStored(const SessionRecord& session,
                                                             int64_t first_id, int64_t last_id,
                                                             LoadReport* report) {
  std::vector<LoadedKeyframe> out;
  KeyframeScan scan;
  scan.products_fingerprint = ctx_.mapper->options().ProductsFingerprint();
  scan.session_row = session.row_id;
  scan.last_id = last_id;
  LOCI_RETURN_IF_ERROR(ctx_.store.ForEachKeyframe(
      first_id - 1,
      [&](KeyframeRecord rec) -> Status {
        LoadedKeyframe kf;
        std::optional<KeyframeProducts> products = StoredProducts(
            rec, session, *ctx_.mapper, ctx_.detection, &ctx_.store, report, &kf.meta);
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

HeldMergeStats AlignStage::held_merge_stats() const {
  std::lock_guard<std::mutex> lock(stats_mu_);
  return stats_;
}

void AlignStage::LoadIslands() {
  if (!ctx_.islands) return;
  auto sessions = ctx_.store.ListSessions();
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

std::vector<Mapper::KeyframePoseUpdate> AlignStage::SessionMoves(const SessionAlignment& a) {
  // The session's mapped keyframes (place recognition may not have indexed the newest yet).
  std::vector<Mapper::KeyframePoseUpdate> updates;
  KeyframeScan scan;
  scan.images = false;
  scan.session_row = a.session_row;
  const Status st = ctx_.store.ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (ctx_.mapper->HasKeyframe(rec.id)) {
          updates.push_back({rec.id, a.T_base_odom * rec.T_odom_cam});
        }
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

void AlignStage::MoveSessions(std::vector<Mapper::KeyframePoseUpdate> moves) {
  const ChunkedMoveFigures moved = MoveInChunks(
      std::move(moves), static_cast<size_t>(ctx_.options.align.loops.apply_chunk_keyframes),
      worker_->mapping_mutex(), [] { return absl::OkStatus(); },
      [this](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) {
        return worker_->Move(chunk, /*rebuild_octomap=*/last);
      });
  if (!moved.status.ok()) {
    spdlog::warn("refined placement applied to {} mapped keyframes only: {}", moved.moved,
                 moved.status.ToString());
  }
}

}  // namespace loci::server

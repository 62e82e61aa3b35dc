// `loci bench merge [--views 60] [--objects 8] [--start 30] [--robot-hz 5] [--held N]
// [--config FILE] [--query-ahead-backlog N]`: how fast a robot that starts anywhere joins the
// shared map. An in-process loci-server on loopback gRPC; robot A streams a
// rendered synthetic room (a `loci synth` scene) and is mapped; then robot B, under its own
// name, streams the same room from view --start on with its own odometry (identity at its
// first view), paced at --robot-hz. With
// --held N, B first streams N keyframes of another room (its views cycled, 100 m away in B's
// odometry; unpaced, a backlog), which the server holds back until B is aligned and then maps
// while B's next keyframes in A's room arrive at --robot-hz. B's first keyframe
// in A's room is the first overlapping one. Prints B's keyframes and wall time from that
// keyframe to its session aligned (GetStats, polled every 10 ms), the capture time the server
// reports, the alignment's error against the truth, how the held keyframes entered the map
// (time, chunks, the longest hold of the mapping lock), the server's place-recognition and
// pose-graph figures, and GetOctomap's time at once and with wait_for_rebuild (the rebuild
// after the last pose update). Place-recognition time at 1k and
// 10k keyframes: `loci bench place`; solve time at 1k and 10k keyframes: `loci bench graph`.
#include <grpcpp/create_channel.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "cli/bench_views.h"
#include "cli/commands.h"
#include "common/config.h"
#include "common/time.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/convert.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/service/query_adapter.h"
#include "server/runtime/server_options.h"

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchMergeArgs {
  int views = 60;
  int objects = 8;
  int start = 30;                // B's first view
  double robot_hz = 5.0;         // B's keyframes per second (0 = as fast as acknowledged)
  std::string config;            // "" = config/server.yaml
  uint64_t other_room = 0;       // B streams a room rendered with this seed instead (0 = A's room)
  int held = 0;                  // B's keyframes in another room before it enters A's
  int query_ahead_backlog = -1;  // align.query_ahead_backlog (-1: the config's)
};

// A session of robot `robot` streaming `views` as they are, from view `paced_from` on paced at
// `hz` (0, and before it: as fast as acknowledged); `on_sent(i)` after each write. Returns the
// session id.
StatusOr<std::string> Stream(loci::v1::Mapping::Stub& stub, const std::string& robot, double hz,
                             size_t paced_from, const std::vector<loci::v1::Keyframe>& views,
                             const std::function<void(size_t)>& on_sent) {
  grpc::ClientContext open_ctx;
  loci::v1::OpenSessionResponse session;
  const grpc::Status opened =
      stub.OpenSession(&open_ctx, BenchOpenRequest(robot, 5000.0), &session);
  if (!opened.ok()) return absl::UnavailableError("OpenSession: " + opened.error_message());
  grpc::ClientContext ctx;
  auto stream = stub.StreamKeyframes(&ctx);
  std::thread reader([&] {
    loci::v1::KeyframeAck ack;
    while (stream->Read(&ack)) {
    }
  });
  const auto period = std::chrono::duration<double>(hz > 0 ? 1.0 / hz : 0.0);
  auto next = Clock::now();
  for (size_t i = 0; i < views.size(); ++i) {
    loci::v1::Keyframe kf = views[i];
    kf.set_session_id(session.session_id());
    kf.set_seq(static_cast<int64_t>(i));
    if (!stream->Write(kf)) break;
    on_sent(i);
    if (i < paced_from) continue;
    if (i == paced_from) next = Clock::now();
    next += std::chrono::duration_cast<Clock::duration>(period);
    std::this_thread::sleep_until(next);  // a robot's keyframe rate
  }
  stream->WritesDone();
  reader.join();
  const grpc::Status done = stream->Finish();
  if (!done.ok()) return absl::UnavailableError("stream: " + done.error_message());
  return session.session_id();
}

StatusOr<loci::v1::GetStatsResponse> GetStats(loci::v1::Query::Stub& query) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  loci::v1::GetStatsResponse resp;
  const grpc::Status s = query.GetStats(&ctx, {}, &resp);
  if (!s.ok()) return absl::UnavailableError("GetStats: " + s.error_message());
  return resp;
}

const loci::v1::SessionAlignment* SessionOf(const loci::v1::GetStatsResponse& stats,
                                            const std::string& robot) {
  for (const auto& s : stats.session_alignments()) {
    if (s.robot() == robot) return &s;
  }
  return nullptr;
}

void PrintFigures(const loci::v1::GetStatsResponse& stats, const SE3d& T_map_odomB_true) {
  const loci::v1::SessionAlignment* b = SessionOf(stats, "B");
  if (b == nullptr || !b->aligned()) {
    std::printf(
        "  B was NOT aligned (%llu keyframes stored); its island map holds %llu confirmed "
        "objects\n",
        b ? static_cast<unsigned long long>(b->keyframes()) : 0ULL,
        b ? static_cast<unsigned long long>(b->island_objects()) : 0ULL);
  } else {
    const SE3d T_err = T_map_odomB_true.inverse() * PoseFromProto(b->t_map_odom());
    std::printf("  server: aligned after %u keyframes of B, %.2f s of capture time\n",
                b->aligned_after_keyframes(), b->aligned_after_s());
    std::printf("  alignment error against the truth: %.1f mm, %.2f deg\n",
                1000 * T_err.translation().norm(), RotationAngleRad(T_err) * 180 / M_PI);
  }
  const auto& a = stats.alignment();
  std::printf("  mapping worker: %.1f ms per keyframe\n", stats.ingest_ms_mean());
  std::printf(
      "  place recognition: %.1f ms per keyframe, %llu keyframes indexed; %llu verified, "
      "%llu rejected candidates; %llu merges accepted (%llu of them ahead of the "
      "backlog, %llu keyframes queried ahead)\n",
      a.place_ms_mean(), static_cast<unsigned long long>(a.keyframes_indexed()),
      static_cast<unsigned long long>(a.verified()), static_cast<unsigned long long>(a.rejected()),
      static_cast<unsigned long long>(a.merges_accepted()),
      static_cast<unsigned long long>(a.merges_ahead()),
      static_cast<unsigned long long>(a.queries_ahead()));
  const auto& g = stats.pose_graph();
  std::printf(
      "  pose graph: %llu solves, last %.0f ms over %llu keyframes, %llu unconnected "
      "parts\n",
      static_cast<unsigned long long>(g.optimizations()), g.last_solve_ms(),
      static_cast<unsigned long long>(g.nodes()), static_cast<unsigned long long>(g.islands()));
}

// B's keyframes in B's odometry frame (identity at view `start` of A's room): `held` views of
// `other` (cycled, 100 m away along x) first, then `room` from `start` on; stamps 200 ms apart.
std::vector<loci::v1::Keyframe> RobotBViews(const std::vector<loci::v1::Keyframe>& room,
                                            const std::vector<loci::v1::Keyframe>& other,
                                            size_t start, int held) {
  const SE3d T_odom_world = PoseFromProto(room[start].t_odom_cam()).inverse();
  SE3d T_far = SE3d::Identity();
  T_far.translation() = Vec3d(100.0, 0.0, 0.0);
  std::vector<loci::v1::Keyframe> out;
  for (int j = 0; j < held; ++j) {
    out.push_back(other[static_cast<size_t>(j) % other.size()]);
    ToProto(T_far * T_odom_world * PoseFromProto(out.back().t_odom_cam()),
            out.back().mutable_t_odom_cam());
  }
  for (size_t i = start; i < room.size(); ++i) {
    out.push_back(room[i]);
    ToProto(T_odom_world * PoseFromProto(out.back().t_odom_cam()), out.back().mutable_t_odom_cam());
  }
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].set_t_ns(room[start].t_ns() + static_cast<int64_t>(i) * 200'000'000);
  }
  return out;
}

void PrintHeldFigures(const loci::v1::GetStatsResponse& stats) {
  const auto& a = stats.alignment();
  std::printf(
      "  held keyframes mapped on the alignment: %llu in %.0f ms, %llu chunks; the mapping "
      "lock was held at most %.0f ms at a time\n",
      static_cast<unsigned long long>(a.merged_keyframes()), a.last_merge_ms(),
      static_cast<unsigned long long>(a.last_merge_chunks()), a.merge_longest_hold_ms());
  std::printf("  the mapping worker waited at most %.0f ms for the mapping lock\n",
              stats.worker_longest_wait_ms());
}

// GetOctomap at once (the live tree, `rebuilding` when the rebuild after the last pose update is
// still running), then waiting for that rebuild.
Status PrintOctomapFetches(loci::v1::Query::Stub& query) {
  for (const bool wait : {false, true}) {
    grpc::ClientContext ctx;
    loci::v1::GetOctomapRequest req;
    req.set_wait_for_rebuild(wait);
    loci::v1::GetOctomapResponse resp;
    const Clock::time_point t0 = Clock::now();
    const grpc::Status s = query.GetOctomap(&ctx, req, &resp);
    if (!s.ok()) return absl::UnavailableError("GetOctomap: " + s.error_message());
    std::printf("  GetOctomap%s: %.0f ms, %.1f KB%s\n", wait ? " with wait_for_rebuild" : "",
                MsSince(t0), resp.octomap_bt().size() / 1e3,
                resp.rebuilding() ? " (rebuilding: the tree before the last pose update)" : "");
  }
  return absl::OkStatus();
}

// A's views of the room, the views B's room is taken from (A's, or another room's), and B's
// keyframes in B's odometry frame.
struct MergeViews {
  std::vector<loci::v1::Keyframe> a;
  std::vector<loci::v1::Keyframe> b_room;
  std::vector<loci::v1::Keyframe> b;
};

StatusOr<MergeViews> RenderMergeViews(const BenchMergeArgs& a, const std::string& dir) {
  MergeViews v;
  synth::SceneOptions so;
  so.num_frames = a.views;
  so.num_objects = a.objects;
  so.seed = 7;
  LOCI_ASSIGN_OR_RETURN(v.a, RenderViews(so, dir + "/a"));
  v.b_room = v.a;
  if (a.other_room != 0) {
    so.seed = a.other_room;
    LOCI_ASSIGN_OR_RETURN(v.b_room, RenderViews(so, dir + "/b"));
  }
  if (a.start < 0 || static_cast<size_t>(a.start) + 3 > v.a.size()) {
    return absl::InvalidArgumentError("--start must leave B at least 3 views");
  }
  if (a.held < 0) return absl::InvalidArgumentError("--held must be >= 0");
  std::vector<loci::v1::Keyframe> elsewhere;
  if (a.held > 0) {
    so.seed = a.other_room != 0 ? a.other_room + 1 : 8;
    LOCI_ASSIGN_OR_RETURN(elsewhere, RenderViews(so, dir + "/elsewhere"));
  }
  v.b = RobotBViews(v.b_room, elsewhere, static_cast<size_t>(a.start), a.held);
  return v;
}

// The server under test, in process on loopback, with a mapping and a query stub.
struct MergeServer {
  std::unique_ptr<server::MapServer> srv;
  std::unique_ptr<server::GrpcServer> grpc;
  std::unique_ptr<loci::v1::Mapping::Stub> mapping;
  std::unique_ptr<loci::v1::Query::Stub> query;
};

StatusOr<MergeServer> StartMergeServer(const BenchMergeArgs& a, const std::string& dir) {
  server::ServerOptions options;  // the server's own config by default
  LOCI_RETURN_IF_ERROR(
      options.FromYamlFile(a.config.empty() ? SourceDir() + "/config/server.yaml" : a.config));
  options.db_path = dir + "/merge.db";
  if (a.query_ahead_backlog >= 0) options.align.query_ahead_backlog = a.query_ahead_backlog;
  MergeServer m;
  LOCI_ASSIGN_OR_RETURN(m.srv, server::MapServer::Open(options));
  LOCI_ASSIGN_OR_RETURN(m.grpc,
                        server::GrpcServer::Start(
                            m.srv.get(), "127.0.0.1:0", options.max_message_mb,
                            std::make_shared<server::QueryAdapter>(server::QueryAdapterOptions{})));
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(64 << 20);
  args.SetMaxReceiveMessageSize(-1);
  auto channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(m.grpc->port()),
                                           grpc::InsecureChannelCredentials(), args);
  m.mapping = loci::v1::Mapping::NewStub(channel);
  m.query = loci::v1::Query::NewStub(channel);
  return m;
}

// When B was aligned, as the benchmark's poll of GetStats saw it.
struct AlignmentTiming {
  Clock::time_point first_sent, aligned_at;
  size_t sent_at_alignment = 0;   // 0: never aligned
  int64_t queue_at_overlap = -1;  // GetStats.queue_depth at the first poll after B's first
                                  // keyframe in A's room was written
};

// Streams B on its own thread and polls GetStats until B is aligned or has sent everything.
StatusOr<AlignmentTiming> StreamB(const BenchMergeArgs& a, const MergeViews& v, MergeServer* m) {
  AlignmentTiming t;
  std::atomic<size_t> sent{0};
  std::atomic<bool> streaming{true};
  std::thread b([&] {
    auto id = Stream(*m->mapping, "B", a.robot_hz, static_cast<size_t>(a.held), v.b, [&](size_t i) {
      if (i == static_cast<size_t>(a.held)) t.first_sent = Clock::now();  // first in A's room
      sent = i + 1;
    });
    if (!id.ok()) std::cerr << "error: B: " << id.status().message() << "\n";
    streaming = false;
  });
  Status status = absl::OkStatus();
  for (bool done = false; !done;) {
    const bool overlapping = sent > static_cast<size_t>(a.held);
    const bool last_round = !streaming;
    if (last_round) m->srv->Flush();  // B has sent everything: wait until it is all processed
    auto stats = GetStats(*m->query);
    if (!stats.ok()) {
      status = stats.status();
      break;
    }
    if (overlapping && t.queue_at_overlap < 0) {
      t.queue_at_overlap = static_cast<int64_t>(stats->queue_depth());
    }
    const loci::v1::SessionAlignment* s = SessionOf(*stats, "B");
    if (s != nullptr && s->aligned()) {
      t.aligned_at = Clock::now();
      t.sent_at_alignment = sent;
      done = true;
    }
    done |= last_round;
    if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(10));  // poll period
  }
  b.join();
  LOCI_RETURN_IF_ERROR(status);
  return t;
}

void PrintAlignmentTime(const AlignmentTiming& t) {
  if (t.sent_at_alignment == 0) return;
  std::printf(
      "  wall time from B's first keyframe in A's room to aligned: %.2f s (B had sent "
      "%zu keyframes)\n",
      std::chrono::duration<double>(t.aligned_at - t.first_sent).count(), t.sent_at_alignment);
  std::printf(
      "  keyframes waiting for the mapping worker or place recognition when it was "
      "sent: %lld\n",
      static_cast<long long>(t.queue_at_overlap));
}

Status RunMerge(const BenchMergeArgs& a, const std::string& dir) {
  LOCI_ASSIGN_OR_RETURN(const MergeViews v, RenderMergeViews(a, dir));
  LOCI_ASSIGN_OR_RETURN(MergeServer m, StartMergeServer(a, dir));
  std::printf(
      "loci bench merge: %zu synthetic views; A streams all, then B streams %d keyframes "
      "of a room elsewhere and views %d-%zu of %s at %.1f keyframes/s with its own "
      "odometry\n",
      v.a.size(), a.held, a.start, v.a.size() - 1,
      a.other_room != 0 ? "ANOTHER room (a different place: B must stay an island)"
                        : "the same room",
      a.robot_hz);
  LOCI_RETURN_IF_ERROR(Stream(*m.mapping, "A", 0, 0, v.a, [](size_t) {}).status());
  m.srv->Flush();
  LOCI_ASSIGN_OR_RETURN(const AlignmentTiming timing, StreamB(a, v, &m));
  m.srv->Flush();
  LOCI_ASSIGN_OR_RETURN(loci::v1::GetStatsResponse stats, GetStats(*m.query));
  PrintAlignmentTime(timing);
  const loci::v1::SessionAlignment* sa = SessionOf(stats, "A");
  const SE3d T_map_odomA = sa != nullptr ? PoseFromProto(sa->t_map_odom()) : SE3d::Identity();
  PrintFigures(stats,
               T_map_odomA * PoseFromProto(v.b_room[static_cast<size_t>(a.start)].t_odom_cam()));
  PrintHeldFigures(stats);
  const Status fetched = PrintOctomapFetches(*m.query);
  m.grpc.reset();
  m.srv.reset();
  return fetched;
}

}  // namespace

void RegisterBenchMergeCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchMergeArgs>();
  CLI::App* c = bench->add_subcommand(
      "merge", "time for a robot that starts anywhere to join the shared map (synthetic room)");
  c->add_option("--views", args->views, "rendered views of the room")->capture_default_str();
  c->add_option("--objects", args->objects, "objects in the room")->capture_default_str();
  c->add_option("--start", args->start, "robot B's first view")->capture_default_str();
  c->add_option("--robot-hz", args->robot_hz,
                "B's keyframes per second in A's room (0 = unpaced; the --held ones are unpaced)")
      ->capture_default_str();
  c->add_option("--config", args->config, "server YAML (default: config/server.yaml)");
  c->add_option("--held", args->held,
                "keyframes B streams in a room elsewhere before it enters A's (held back until it "
                "is aligned)")
      ->capture_default_str();
  c->add_option("--query-ahead-backlog", args->query_ahead_backlog,
                "align.query_ahead_backlog for this run (0 = B's keyframes recognised in order "
                "only; default: the config's)");
  c->add_option("--other-room", args->other_room,
                "B streams a room rendered with this seed: a different place that must not merge");
  c->callback([args] {
    const std::string dir =
        (std::filesystem::temp_directory_path() / ("loci_bench_merge_" + std::to_string(getpid())))
            .string();
    std::filesystem::create_directories(dir);
    const Status s = RunMerge(*args, dir);
    std::filesystem::remove_all(dir);
    if (!s.ok()) std::cerr << "error: " << s.message() << "\n";
    ExitCode() = s.ok() ? 0 : 1;
  });
}

}  // namespace loci::cli

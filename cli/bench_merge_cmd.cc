// `loci bench merge [--views 60] [--objects 8] [--start 30] [--robot-hz 5] [--config FILE]`:
// how fast a robot that starts anywhere joins the shared map (issue 15). An in-process
// loci-server on loopback gRPC; robot A streams a rendered synthetic room (a `loci synth`
// scene) and is mapped; then robot B, under its own name, streams the same room from view
// --start on with its own odometry (identity at its first view), paced at --robot-hz. Every
// keyframe of B overlaps A's map, so B's first keyframe is the first overlapping one. Prints
// B's keyframes and wall time from its first keyframe to its session aligned (GetStats, polled
// every 10 ms), the capture time the server reports, the alignment's error against the truth,
// and the server's place-recognition and pose-graph figures. Place-recognition time at 1k and
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
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/convert.h"
#include "server/service/grpc_server.h"
#include "server/service/map_server.h"
#include "server/service/query_adapter.h"
#include "server/service/server_options.h"

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchMergeArgs {
  int views = 60;
  int objects = 8;
  int start = 30;         // B's first view
  double robot_hz = 5.0;  // B's keyframes per second (0 = as fast as acknowledged)
  std::string config;  // "" = config/server.yaml
  uint64_t other_room = 0;  // B streams a room rendered with this seed instead (0 = A's room)
};

// A session streaming `views` (from `first`) with poses re-based on view `first`'s pose when
// `own_odometry`; paced at `hz`; `on_sent(i)` after each write. Returns the session id.
struct Robot {
  std::string name;
  size_t first = 0;
  bool own_odometry = false;
  double hz = 0;
};

StatusOr<std::string> Stream(loci::v1::Mapping::Stub& stub, const Robot& r,
                             const std::vector<loci::v1::Keyframe>& views,
                             const std::function<void(size_t)>& on_sent) {
  grpc::ClientContext open_ctx;
  loci::v1::OpenSessionResponse session;
  const grpc::Status opened =
      stub.OpenSession(&open_ctx, BenchOpenRequest(r.name, 5000.0), &session);
  if (!opened.ok()) return absl::UnavailableError("OpenSession: " + opened.error_message());
  const SE3d T_odom_world = r.own_odometry ? PoseFromProto(views[r.first].t_odom_cam()).inverse()
                                           : SE3d::Identity();
  grpc::ClientContext ctx;
  auto stream = stub.StreamKeyframes(&ctx);
  std::thread reader([&] {
    loci::v1::KeyframeAck ack;
    while (stream->Read(&ack)) {
    }
  });
  const auto period = std::chrono::duration<double>(r.hz > 0 ? 1.0 / r.hz : 0.0);
  auto next = Clock::now();
  for (size_t i = r.first; i < views.size(); ++i) {
    loci::v1::Keyframe kf = views[i];
    kf.set_session_id(session.session_id());
    kf.set_seq(static_cast<int64_t>(i - r.first));
    ToProto(T_odom_world * PoseFromProto(kf.t_odom_cam()), kf.mutable_t_odom_cam());
    if (!stream->Write(kf)) break;
    on_sent(i - r.first);
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
    std::printf("  B was NOT aligned (%llu keyframes stored); its island map holds %llu confirmed "
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
  std::printf("  place recognition: %.1f ms per keyframe, %llu keyframes indexed; %llu verified, "
              "%llu rejected candidates; %llu merges accepted\n",
              a.place_ms_mean(), static_cast<unsigned long long>(a.keyframes_indexed()),
              static_cast<unsigned long long>(a.verified()),
              static_cast<unsigned long long>(a.rejected()),
              static_cast<unsigned long long>(a.merges_accepted()));
  const auto& g = stats.pose_graph();
  std::printf("  pose graph: %llu solves, last %.0f ms over %llu keyframes, %llu unconnected "
              "parts\n",
              static_cast<unsigned long long>(g.optimizations()), g.last_solve_ms(),
              static_cast<unsigned long long>(g.nodes()),
              static_cast<unsigned long long>(g.islands()));
}

Status RunMerge(const BenchMergeArgs& a, const std::string& dir) {
  synth::SceneOptions so;
  so.num_frames = a.views;
  so.num_objects = a.objects;
  so.seed = 7;
  LOCI_ASSIGN_OR_RETURN(auto views, RenderViews(so, dir + "/a"));
  auto views_b = views;
  if (a.other_room != 0) {
    so.seed = a.other_room;
    LOCI_ASSIGN_OR_RETURN(views_b, RenderViews(so, dir + "/b"));
  }
  if (a.start < 0 || static_cast<size_t>(a.start) + 3 > views.size()) {
    return absl::InvalidArgumentError("--start must leave B at least 3 views");
  }
  server::ServerOptions options;  // the server's own config by default
  LOCI_RETURN_IF_ERROR(options.FromYamlFile(
      a.config.empty() ? SourceDir() + "/config/server.yaml" : a.config));
  options.db_path = dir + "/merge.db";
  LOCI_ASSIGN_OR_RETURN(auto srv, server::MapServer::Open(options));
  LOCI_ASSIGN_OR_RETURN(
      auto grpc_server,
      server::GrpcServer::Start(srv.get(), "127.0.0.1:0", options.max_message_mb,
                                std::make_shared<server::QueryAdapter>(
                                    server::QueryAdapterOptions{})));
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(64 << 20);
  args.SetMaxReceiveMessageSize(-1);
  auto channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(grpc_server->port()),
                                           grpc::InsecureChannelCredentials(), args);
  auto mapping = loci::v1::Mapping::NewStub(channel);
  auto query = loci::v1::Query::NewStub(channel);
  std::printf("loci bench merge: %zu synthetic views; A streams all, then B streams views %d-%zu "
              "of %s at %.1f keyframes/s with its own odometry\n",
              views.size(), a.start, views.size() - 1,
              a.other_room != 0 ? "ANOTHER room (a different place: B must stay an island)"
                                : "the same room",
              a.robot_hz);

  LOCI_RETURN_IF_ERROR(Stream(*mapping, {"A", 0, false, 0}, views, [](size_t) {}).status());
  srv->Flush();

  Clock::time_point first_sent, aligned_at;
  std::atomic<size_t> sent{0};
  std::atomic<bool> streaming{true};
  std::thread b([&] {
    auto id = Stream(*mapping, {"B", static_cast<size_t>(a.start), true, a.robot_hz}, views_b,
                     [&](size_t i) {
                       if (i == 0) first_sent = Clock::now();
                       sent = i + 1;
                     });
    if (!id.ok()) std::cerr << "error: B: " << id.status().message() << "\n";
    streaming = false;
  });
  size_t sent_at_alignment = 0;
  for (bool done = false; !done;) {
    const bool last_round = !streaming;
    if (last_round) srv->Flush();  // B has sent everything: wait until it is all processed
    LOCI_ASSIGN_OR_RETURN(loci::v1::GetStatsResponse stats, GetStats(*query));
    const loci::v1::SessionAlignment* s = SessionOf(stats, "B");
    if (s != nullptr && s->aligned()) {
      aligned_at = Clock::now();
      sent_at_alignment = sent;
      done = true;
    }
    done |= last_round;
    if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(10));  // poll period
  }
  b.join();
  srv->Flush();
  LOCI_ASSIGN_OR_RETURN(loci::v1::GetStatsResponse stats, GetStats(*query));
  if (sent_at_alignment > 0) {
    std::printf("  wall time from B's first keyframe to aligned: %.2f s (B had sent %zu "
                "keyframes)\n",
                std::chrono::duration<double>(aligned_at - first_sent).count(),
                sent_at_alignment);
  }
  const loci::v1::SessionAlignment* sa = SessionOf(stats, "A");
  const SE3d T_map_odomA = sa != nullptr ? PoseFromProto(sa->t_map_odom()) : SE3d::Identity();
  PrintFigures(stats,
               T_map_odomA * PoseFromProto(views_b[static_cast<size_t>(a.start)].t_odom_cam()));
  grpc_server.reset();
  srv.reset();
  return absl::OkStatus();
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
  c->add_option("--robot-hz", args->robot_hz, "B's keyframes per second (0 = unpaced)")
      ->capture_default_str();
  c->add_option("--config", args->config, "server YAML (default: config/server.yaml)");
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

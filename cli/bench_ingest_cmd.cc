// `loci bench ingest [--keyframes N] [--views V] [--objects K] [--keep DIR] [--config FILE]`:
// end-to-end ingest throughput of the mapping server on loopback gRPC. A `loci synth` scene
// (640x480, K objects, about 8 detections per frame with masks) is rendered once; its V views are
// streamed N times in total with fresh sequence numbers to an in-process server on a temporary
// database. Prints keyframes/s, per-stage milliseconds, memory per 1000 keyframes and DB bytes per
// keyframe. The stream pauses twice (a tenth after a third and after two thirds acknowledged)
// until everything has drained, for the memory the map retains (IngestMemory below).
#include <grpcpp/create_channel.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <thread>

#include "cli/bench_views.h"
#include "cli/commands.h"
#include "common/malloc_tuning.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"

namespace loci::cli {
namespace {

struct BenchIngestArgs {
  int keyframes = 300;
  int views = 30;
  int objects = 8;
  std::string keep_dir;
  std::string config;  // server YAML (map options); "" = defaults
};

// Acknowledgements counted by the reader thread; the writer waits on them at its pauses.
class AckCounter {
 public:
  int Add(bool failed) {
    std::lock_guard<std::mutex> lock(mu_);
    failed_ += failed;
    ++acked_;
    cv_.notify_all();
    return acked_;
  }
  void WaitFor(int n) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [&] { return acked_ >= n; });
  }
  int failed() {
    std::lock_guard<std::mutex> lock(mu_);
    return failed_;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  int acked_ = 0, failed_ = 0;
};

// The RSS at a third and two thirds acknowledged, four ways: at that instant (the queues are
// full), the lowest over the tenth of the run before it (transient peaks such as a pose-graph
// solve left out), the highest so far (those peaks included), and at the writer's pause a
// tenth later with everything drained and the heap's free pages returned (what the map
// retains).
struct IngestMemory {
  double instant[2] = {0, 0};
  double peak[2] = {0, 0};
  double lowest[2] = {1e18, 1e18};
  double drained[2] = {0, 0};
  double live_heap[2] = {0, 0};  // at the pauses too

  void Sample(int acked, int keyframes) {
    const int tenth = std::max(1, keyframes / 10);
    for (int p = 0; p < 2; ++p) {
      const int point = (p + 1) * keyframes / 3;
      if (acked > point - tenth && acked <= point) lowest[p] = std::min(lowest[p], RssMb());
      if (acked == point) {
        instant[p] = RssMb();
        peak[p] = PeakRssMb();
      }
    }
  }

  void Print(int keyframes, int drained_span, double rss_end_mb) const {
    const double per_kkf = 1000.0 / std::max(1, 2 * keyframes / 3 - keyframes / 3);
    std::printf(
        "  memory          %.1f MB per 1000 keyframes with the queues full (a third to two "
        "thirds acknowledged); %.1f MB RSS over the start at the end, queues drained\n",
        (instant[1] - instant[0]) * per_kkf, rss_end_mb);
    std::printf(
        "                  %.1f MB per 1000 keyframes in the lowest RSS (over the tenth of the "
        "run before each of those two points, between transient peaks)\n",
        (lowest[1] - lowest[0]) * per_kkf);
    std::printf(
        "                  %.1f MB per 1000 keyframes in the peak RSS (the highest so far at "
        "those two points: solves and full queues included)\n",
        (peak[1] - peak[0]) * per_kkf);
    std::printf(
        "                  %.1f MB per 1000 keyframes retained (RSS at two pauses a tenth "
        "later, queues and solves drained, free heap pages returned)\n",
        (drained[1] - drained[0]) * 1000.0 / std::max(1, drained_span));
    std::printf(
        "                  %.1f MB per 1000 keyframes in the live heap at those pauses "
        "(allocated, not freed)\n",
        (live_heap[1] - live_heap[0]) * 1000.0 / std::max(1, drained_span));
  }
};

// The server under test: in process, on loopback gRPC, with one open session.
struct BenchServer {
  std::unique_ptr<server::MapServer> srv;
  std::unique_ptr<server::GrpcServer> grpc;
  std::unique_ptr<loci::v1::Mapping::Stub> stub;
  loci::v1::OpenSessionResponse session;
};

// Opens the server on a fresh database in `dir`; the exit code on failure (message printed).
int OpenBenchServer(const BenchIngestArgs& a, const std::string& dir, double depth_scale,
                    BenchServer* b) {
  server::ServerOptions options;
  if (Status cs = a.config.empty() ? options.LoadClasses() : options.FromYamlFile(a.config);
      !cs.ok()) {
    std::cerr << "error: " << cs.message() << "\n";
    return 2;
  }
  options.db_path = dir + "/bench.db";
  for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(options.db_path + s);
  auto srv = server::MapServer::Open(options);
  if (!srv.ok()) {
    std::cerr << "error: " << srv.status().message() << "\n";
    return 1;
  }
  b->srv = std::move(*srv);
  auto grpc_server = server::GrpcServer::Start(b->srv.get(), "127.0.0.1:0", options.max_message_mb);
  if (!grpc_server.ok()) {
    std::cerr << "error: " << grpc_server.status().message() << "\n";
    return 1;
  }
  b->grpc = std::move(*grpc_server);
  b->stub = loci::v1::Mapping::NewStub(grpc::CreateChannel(
      absl::StrCat("127.0.0.1:", b->grpc->port()), grpc::InsecureChannelCredentials()));
  grpc::ClientContext open_ctx;
  if (!b->stub->OpenSession(&open_ctx, BenchOpenRequest("bench", depth_scale), &b->session).ok()) {
    std::cerr << "error: OpenSession failed\n";
    return 1;
  }
  return 0;
}

// How the stream went: wall seconds without the pauses, rejected keyframes, the final status.
struct StreamResult {
  double wall_s = 0;
  int failed = 0;
  grpc::Status status;
  int pauses[2] = {0, 0};  // keyframes written at each pause
};

// Streams a.keyframes keyframes, pausing twice, a tenth of the run after each point the memory
// is sampled: the queues and the solves drain there, and the heap's free pages go back (what the
// server does after a solve).
StreamResult StreamKeyframes(const BenchIngestArgs& a, const std::vector<loci::v1::Keyframe>& views,
                             BenchServer* b, IngestMemory* mem) {
  StreamResult r;
  const int tenth = std::max(1, a.keyframes / 10);
  const auto t0 = std::chrono::steady_clock::now();
  grpc::ClientContext ctx;
  auto stream = b->stub->StreamKeyframes(&ctx);
  AckCounter acks;
  std::thread reader([&] {
    loci::v1::KeyframeAck ack;
    while (stream->Read(&ack)) mem->Sample(acks.Add(ack.status().code() != 0), a.keyframes);
  });
  r.pauses[0] = a.keyframes / 3 + tenth;
  r.pauses[1] = 2 * a.keyframes / 3 + tenth;
  double paused_s = 0;
  for (int i = 0; i < a.keyframes; ++i) {
    if (!stream->Write(NthKeyframe(views, i, b->session.session_id()))) break;
    for (int p = 0; p < 2; ++p) {
      if (i + 1 != r.pauses[p]) continue;
      const auto pause0 = std::chrono::steady_clock::now();
      acks.WaitFor(i + 1);
      b->srv->Flush();
      b->srv->mapper().FlushOctomap();
      ReleaseFreeHeapPages();
      mem->drained[p] = RssMb();
      mem->live_heap[p] = LiveHeapMb();
      paused_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - pause0).count();
    }
  }
  stream->WritesDone();
  reader.join();
  r.failed = acks.failed();
  r.status = stream->Finish();
  b->srv->Flush();
  r.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() - paused_s;
  return r;
}

void PrintIngest(const BenchIngestArgs& a, size_t det_total, size_t view_count,
                 const StreamResult& r, const server::MapperStats& stats, server::MapServer& srv) {
  const double n = static_cast<double>(std::max<uint64_t>(1, stats.keyframes));
  std::printf(
      "loci bench ingest: %d keyframes (640x480, %.1f detections/keyframe, %zu views), "
      "gRPC loopback, %u cores\n",
      a.keyframes, static_cast<double>(det_total) / view_count, view_count,
      std::thread::hardware_concurrency());
  std::printf("  throughput      %.1f keyframes/s (%.2f s wall, stream %s, %d rejected)\n",
              a.keyframes / r.wall_s, r.wall_s,
              r.status.ok() ? "ok" : r.status.error_message().c_str(), r.failed);
  std::printf("  handler stages  validate+decode %.2f ms, store %.2f ms (gRPC thread)\n",
              srv.times().validate_ms_mean(), srv.times().store_ms_mean());
  std::printf(
      "  mapping stages  products %.2f ms, fusion %.2f ms, cloud %.2f ms, octomap %.2f ms "
      "(worker thread CPU; wall incl. waits %.2f ms)\n",
      stats.total.products_ms / n, stats.total.fusion_ms / n, stats.total.cloud_ms / n,
      stats.total.octomap_ms / n, srv.times().mapping_ms_mean());
  std::printf(
      "  products detail labels %.2f, object clouds %.2f, back-projection %.2f, voxel "
      "%.2f, outliers %.2f ms (CPU)\n",
      stats.total.labels_ms / n, stats.total.objects_ms / n, stats.total.backproject_ms / n,
      stats.total.voxel_ms / n, stats.total.outlier_ms / n);
}

void PrintMap(const BenchIngestArgs& a, const server::MapperStats& stats, server::MapServer& srv) {
  const uint64_t db_bytes = srv.store().DbBytes();
  std::printf("  database        %.1f KB per keyframe (%.1f MB total, WAL included)\n",
              db_bytes / 1024.0 / a.keyframes, db_bytes / (1024.0 * 1024.0));
  std::printf(
      "  map             %llu objects (%llu confirmed), %llu cloud points, %llu octomap "
      "nodes\n",
      static_cast<unsigned long long>(stats.objects),
      static_cast<unsigned long long>(stats.confirmed_objects),
      static_cast<unsigned long long>(stats.cloud_points),
      static_cast<unsigned long long>(stats.octomap_nodes));
  std::printf("  octomap         rebuilt after %llu pose updates, %llu others within tolerance\n",
              static_cast<unsigned long long>(stats.octomap_rebuilds),
              static_cast<unsigned long long>(stats.octomap_rebuilds_skipped));
}

int RunBenchIngest(const BenchIngestArgs& a) {
  const std::string dir = a.keep_dir.empty() ? (std::filesystem::temp_directory_path() /
                                                ("loci_bench_ingest_" + std::to_string(getpid())))
                                                   .string()
                                             : a.keep_dir;
  std::filesystem::create_directories(dir);
  synth::SceneOptions so;
  so.num_frames = a.views;
  so.num_objects = a.objects;
  so.seed = 7;
  so.fps_hz = 5.0;  // the views are keyframes: a robot sends about 5 a second, not 30
  std::cout << "rendering " << a.views << " synthetic 640x480 views with " << a.objects
            << " objects into " << dir << " ..." << std::endl;
  auto views = RenderViews(so, dir);
  if (!views.ok()) {
    std::cerr << "error: " << views.status().message() << "\n";
    return 1;
  }
  size_t det_total = 0;
  for (const auto& v : *views) det_total += v.detections_size();
  const double rss0 = RssMb();
  BenchServer b;
  if (const int rc = OpenBenchServer(a, dir, so.depth_scale, &b); rc != 0) return rc;
  IngestMemory mem;
  const StreamResult r = StreamKeyframes(a, *views, &b, &mem);
  const double rss1 = RssMb();
  b.srv->mapper().FlushOctomap();
  const server::MapperStats stats = b.srv->mapper().Stats();
  PrintIngest(a, det_total, views->size(), r, stats, *b.srv);
  mem.Print(a.keyframes, r.pauses[1] - r.pauses[0], rss1 - rss0);
  PrintMap(a, stats, *b.srv);
  b.grpc.reset();
  b.srv.reset();
  if (a.keep_dir.empty()) std::filesystem::remove_all(dir);
  return r.failed == 0 && r.status.ok() ? 0 : 1;
}

}  // namespace

void RegisterBenchIngestCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchIngestArgs>();
  CLI::App* c = bench->add_subcommand(
      "ingest", "mapping server ingest throughput on loopback gRPC (synthetic 640x480 keyframes)");
  c->add_option("--keyframes", args->keyframes, "keyframes to stream")->capture_default_str();
  c->add_option("--views", args->views, "distinct rendered views, cycled")->capture_default_str();
  c->add_option("--objects", args->objects, "objects in the synthetic scene")
      ->capture_default_str();
  c->add_option("--keep", args->keep_dir, "keep the scene and database in this directory");
  c->add_option("--config", args->config, "server YAML (map options; default: built-in)")
      ->check(CLI::ExistingFile);
  c->callback([args] { ExitCode() = RunBenchIngest(*args); });
}

}  // namespace loci::cli

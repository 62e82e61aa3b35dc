// `loci bench restart [--keyframes N] [--tail T] [--small] [--keep DIR]`: how fast loci-server
// is back after a restart. Builds a database of N keyframes the way the server does (raw
// keyframe, its products, the map, a checkpoint after keyframe N - T, so T keyframes are left to
// re-derive from products as after a crash), then starts the loci-server binary on it and prints
// the time from process start to "listening on" and to health SERVING, the server's peak RSS,
// and the database bytes per keyframe; --move N [--chunk K] also times moving the last N
// keyframes (Mapper::UpdateKeyframePoses) in the building process, in chunks of K, while
// another thread maps keyframes (cli/bench_move.h). --small renders 160x120 keyframes (say so when quoting).
#include <grpcpp/create_channel.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include "cli/bench_move.h"
#include "cli/bench_views.h"
#include "cli/commands.h"
#include "common/time.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "server/map/product_codec.h"
#include "server/runtime/checkpointer.h"
#include "server/runtime/keyframe_decoder.h"
#include "server/runtime/server_options.h"
#include "server/storage/sqlite_store.h"

extern char** environ;

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchRestartArgs {
  int64_t keyframes = 1000;
  int64_t tail = 0;
  int64_t move = 0;
  int64_t chunk = 0;
  bool small = false;
  std::string keep_dir;
};

// One distinct view: its stored record, and its products (computed once, reused per cycle).
struct View {
  server::KeyframeRecord record;
  server::MapperKeyframe meta;  // images dropped
  server::KeyframeProducts products;
  std::string products_bytes;
};

StatusOr<std::vector<View>> PrepareViews(const std::vector<loci::v1::Keyframe>& views,
                                         const server::SessionRecord& session,
                                         const server::Mapper& mapper) {
  std::vector<View> out;
  for (size_t i = 0; i < views.size(); ++i) {
    View v;
    LOCI_ASSIGN_OR_RETURN(v.record, server::ValidateKeyframe(NthKeyframe(views, i, "bench"),
                                                             session, {}, &v.meta));
    v.products = mapper.BuildProducts(v.meta);
    v.products_bytes = EncodeProducts(v.products, mapper.options().ProductsFingerprint());
    v.meta.bgr.release();
    v.meta.depth_m.release();
    v.meta.detections.clear();
    out.push_back(std::move(v));
  }
  return out;
}

// Writes N keyframes with products and a checkpoint after keyframe N - tail.
Status BuildDatabase(const BenchRestartArgs& a, const std::vector<loci::v1::Keyframe>& views,
                     const PinholeCamera& camera, const std::string& db) {
  server::ServerOptions options;
  LOCI_RETURN_IF_ERROR(options.LoadClasses());
  LOCI_ASSIGN_OR_RETURN(auto store, server::SqliteStore::Open(db));
  server::SessionRecord session;
  session.robot_name = "bench";
  session.camera = camera;
  session.opened_ns = views.front().t_ns();
  LOCI_ASSIGN_OR_RETURN(session, store->CreateSession(session));
  server::Mapper mapper(options.map);
  LOCI_ASSIGN_OR_RETURN(std::vector<View> prepared, PrepareViews(views, session, mapper));
  const std::string fingerprint = options.map.ProductsFingerprint();
  const auto t0 = Clock::now();
  for (int64_t i = 0; i < a.keyframes; ++i) {
    const View& v = prepared[static_cast<size_t>(i) % prepared.size()];
    server::KeyframeRecord rec = v.record;
    rec.session_row = session.row_id;
    rec.seq = i;
    rec.t_ns = NthKeyframe(views, i, "").t_ns();
    LOCI_ASSIGN_OR_RETURN(server::InsertResult inserted, store->InsertKeyframe(rec));
    server::MapperKeyframe meta = v.meta;
    meta.keyframe_id = inserted.keyframe_id;
    meta.session_row = session.row_id;
    meta.t_ns = rec.t_ns;
    mapper.Integrate(meta, v.products);
    LOCI_RETURN_IF_ERROR(store->PutProducts(inserted.keyframe_id, fingerprint, v.products_bytes));
    if (i + 1 == a.keyframes - a.tail) {
      LOCI_RETURN_IF_ERROR(
          store->PutCheckpoint(server::MakeCheckpoint(mapper)));
    }
    if ((i + 1) % 1000 == 0 || i + 1 == a.keyframes) {
      const double s = std::chrono::duration<double>(Clock::now() - t0).count();
      std::fprintf(stderr, "\rbuilt %lld / %lld keyframes (%.0f s)", static_cast<long long>(i + 1),
                   static_cast<long long>(a.keyframes), s);
    }
  }
  std::fprintf(stderr, "\n");
  if (a.move == 0) return absl::OkStatus();
  // The mapping thread of the move bench maps the views again, as new keyframes.
  int64_t next = a.keyframes;
  auto map_next = [&] {
    const View& v = prepared[static_cast<size_t>(next) % prepared.size()];
    server::MapperKeyframe meta = v.meta;
    meta.keyframe_id = mapper.last_keyframe_id() + 1;
    meta.session_row = session.row_id;
    meta.t_ns = NthKeyframe(views, next++, "").t_ns();
    mapper.Integrate(meta, v.products);
  };
  return TimeMoveWhileMapping(a.move, a.chunk, mapper, *store, fingerprint, map_next);
  return absl::OkStatus();
}

// Peak resident memory of a process, MB (VmHWM).
double PeakRssMb(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") {
      double kb = 0;
      status >> kb;
      return kb / 1024.0;
    }
  }
  return 0;
}

struct RestartFigures {
  double listening_s = 0, serving_s = 0, peak_rss_mb = 0;
};

// Polls the health service every 10 ms until SERVING.
Status WaitServing(int port, const Clock::time_point& deadline) {
  auto stub = grpc::health::v1::Health::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
  while (Clock::now() < deadline) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(1));
    grpc::health::v1::HealthCheckResponse resp;
    if (stub->Check(&ctx, {}, &resp).ok() &&
        resp.status() == grpc::health::v1::HealthCheckResponse::SERVING) {
      return absl::OkStatus();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return absl::DeadlineExceededError("loci-server did not report SERVING within 10 min");
}

StatusOr<RestartFigures> TimeRestart(const std::string& server_bin, const std::string& db) {
  int fds[2];
  if (pipe(fds) != 0) return absl::InternalError("pipe failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  std::vector<std::string> args{server_bin, "--db",        db, "--listen", "127.0.0.1:0",
                                "--log-level", "warn"};
  std::vector<char*> argv;
  for (std::string& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  const auto t0 = Clock::now();
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, server_bin.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (rc != 0) return absl::NotFoundError("cannot start " + server_bin);
  FILE* out = fdopen(fds[0], "r");
  char line[256];
  int port = 0;
  while (port == 0 && fgets(line, sizeof(line), out) != nullptr) {
    std::sscanf(line, "listening on %*[^:]:%d", &port);
  }
  RestartFigures f;
  f.listening_s = std::chrono::duration<double>(Clock::now() - t0).count();
  Status serving = port == 0 ? absl::UnavailableError("loci-server ended before listening")
                             : WaitServing(port, t0 + std::chrono::minutes(10));
  f.serving_s = std::chrono::duration<double>(Clock::now() - t0).count();
  f.peak_rss_mb = PeakRssMb(pid);
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
  fclose(out);
  LOCI_RETURN_IF_ERROR(serving);
  return f;
}

int RunBenchRestart(const BenchRestartArgs& a) {
  const std::string dir = a.keep_dir.empty() ? (std::filesystem::temp_directory_path() /
                                                ("loci_bench_restart_" + std::to_string(getpid())))
                                                   .string()
                                             : a.keep_dir;
  std::filesystem::create_directories(dir);
  synth::SceneOptions so;
  so.num_frames = 30;
  so.num_objects = 8;
  so.seed = 7;
  if (a.small) so.width_px = 160, so.height_px = 120;
  auto views = RenderViews(so, dir);
  const double scale = so.width_px / 640.0;
  const PinholeCamera fr1 = PinholeCamera::TumFr1();
  const PinholeCamera camera{fr1.fx * scale, fr1.fy * scale, fr1.cx * scale, fr1.cy * scale,
                             so.width_px, so.height_px};
  const std::string db = dir + "/restart.db";
  for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(db + s);
  Status st = views.ok() ? BuildDatabase(a, *views, camera, db) : views.status();
  const std::string server_bin =
      (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "loci-server").string();
  StatusOr<RestartFigures> f = st.ok() ? TimeRestart(server_bin, db) : st;
  if (!f.ok()) {
    std::cerr << "error: " << f.status().message() << "\n";
    return 1;
  }
  uint64_t db_bytes = 0;
  for (const char* s : {"", "-wal"}) {
    std::error_code ec;
    const auto n = std::filesystem::file_size(db + s, ec);
    if (!ec) db_bytes += n;
  }
  std::printf("loci bench restart: %lld keyframes (%dx%d%s), checkpoint %lld keyframes before the "
              "end\n", static_cast<long long>(a.keyframes), so.width_px, so.height_px,
              a.small ? ", small synthetic keyframes" : "", static_cast<long long>(a.tail));
  std::printf("  start -> listening   %.3f s\n", f->listening_s);
  std::printf("  start -> SERVING     %.3f s\n", f->serving_s);
  std::printf("  peak RSS             %.1f MB\n", f->peak_rss_mb);
  std::printf("  database             %.1f KB per keyframe (%.1f MB)\n",
              db_bytes / 1024.0 / static_cast<double>(a.keyframes), db_bytes / 1048576.0);
  if (a.keep_dir.empty()) std::filesystem::remove_all(dir);
  return 0;
}

}  // namespace

void RegisterBenchRestartCommand(CLI::App& app) {
  auto args = std::make_shared<BenchRestartArgs>();
  CLI::App* c = BenchGroup(app)->add_subcommand(
      "restart", "loci-server time to SERVING on a database of N keyframes, peak RSS, bytes/kf");
  c->add_option("--keyframes", args->keyframes, "keyframes in the database")->capture_default_str();
  c->add_option("--tail", args->tail,
                "keyframes after the last checkpoint (re-derived on start, as after a crash)")
      ->capture_default_str();
  c->add_flag("--small", args->small, "160x120 keyframes (for 100k-keyframe runs)");
  c->add_option("--move", args->move,
                "after building, move the last N keyframes and time the re-derivation while "
                "another thread maps keyframes under the same lock (cli/bench_move.h)")
      ->capture_default_str();
  c->add_option("--chunk", args->chunk,
                "with --move: keyframes moved per hold of the lock (0 = all at once; the "
                "server's align.loops.apply_chunk_keyframes)")
      ->capture_default_str();
  c->add_option("--keep", args->keep_dir, "keep the scene and database in this directory");
  c->callback([args] {
    if (args->keyframes < 1 || args->tail < 0 || args->tail >= args->keyframes || args->chunk < 0) {
      std::cerr << "error: need --keyframes >= 1, 0 <= --tail < --keyframes, --chunk >= 0\n";
      ExitCode() = 2;
      return;
    }
    ExitCode() = RunBenchRestart(*args);
  });
}

}  // namespace loci::cli

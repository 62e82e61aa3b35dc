// `loci bench load [--robots N] [--clients M] [--seconds T] [--robot-hz H] [--client-hz Q]
// [--config FILE]`: N robots stream synthetic keyframes (a rendered `loci synth` scene, 640x480
// with masks) while M query clients alternate Ask and FindObjects (Q calls per second each, or
// as fast as answered), all over loopback gRPC to an in-process loci server with the query
// engine. The clients share the server's cores: unpaced, they take whatever the server leaves.
// Prints errors, the ingest rate, Ask and FindObjects p50/p99/max, the resident memory every
// 10 s, and the keyframes still queued at the end.
#include <grpcpp/create_channel.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <thread>

#include "absl/strings/str_format.h"
#include "cli/bench_stats.h"
#include "cli/bench_traffic.h"
#include "cli/bench_views.h"
#include "cli/commands.h"
#include "common/config.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/service/query_adapter.h"

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchLoadArgs {
  int robots = 8;
  int clients = 20;
  double seconds = 60;
  double robot_hz = 1.0;  // keyframes per second per robot (0 = as fast as acknowledged)
  double client_hz = 0;   // calls per second per query client (0 = as fast as answered)
  int views = 30;
  int objects = 8;
  std::string config;  // "" = config/server.yaml
};

int RunBenchLoad(const BenchLoadArgs& a) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("loci_bench_load_" + std::to_string(getpid())))
          .string();
  std::filesystem::create_directories(dir);
  synth::SceneOptions so;
  so.num_frames = a.views;
  so.num_objects = a.objects;
  so.seed = 7;
  auto views = RenderViews(so, dir);
  if (!views.ok()) {
    std::cerr << "error: " << views.status().message() << "\n";
    return 1;
  }
  server::ServerOptions options;  // the server's own config by default
  if (Status s = options.FromYamlFile(a.config.empty() ? SourceDir() + "/config/server.yaml"
                                                        : a.config);
      !s.ok()) {
    std::cerr << "error: " << s.message() << "\n";
    return 2;
  }
  options.db_path = dir + "/load.db";
  auto srv = server::MapServer::Open(options);
  if (!srv.ok()) {
    std::cerr << "error: " << srv.status().message() << "\n";
    return 1;
  }
  auto grpc_server = server::GrpcServer::Start(
      srv->get(), "127.0.0.1:0", options.max_message_mb,
      std::make_shared<server::QueryAdapter>(server::QueryAdapterOptions{}));
  if (!grpc_server.ok()) {
    std::cerr << "error: " << grpc_server.status().message() << "\n";
    return 1;
  }
  const std::string address = "127.0.0.1:" + std::to_string((*grpc_server)->port());
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(64 << 20);
  args.SetMaxReceiveMessageSize(-1);
  std::printf("loci bench load: %d robots at %.1f keyframes/s each, %d query clients (%s), %.0f s, "
              "%u cores\n",
              a.robots, a.robot_hz, a.clients,
              a.client_hz > 0 ? absl::StrFormat("%.1f calls/s each", a.client_hz).c_str()
                              : "unpaced",
              a.seconds, std::thread::hardware_concurrency());
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> acked{0}, ingest_errors{0};
  Latencies lat;
  std::vector<std::thread> threads;
  for (int r = 0; r < a.robots; ++r) {
    // A channel per robot and client: separate connections, as separate machines would have.
    auto channel = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
    threads.emplace_back(RobotLoop, channel, "robot" + std::to_string(r), "",
                         std::cref(*views), a.robot_hz, std::cref(stop), &acked, &ingest_errors);
  }
  for (int c = 0; c < a.clients; ++c) {
    auto channel = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
    threads.emplace_back(ClientLoop, channel, a.client_hz, false, std::cref(stop), &lat);
  }
  const auto t0 = Clock::now();
  for (double t = 10; t <= a.seconds + 1e-9; t += 10) {
    std::this_thread::sleep_until(t0 + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(t)));
    std::printf("  t=%4.0f s  RSS %.0f MB, %llu keyframes acknowledged\n", t, RssMb(),
                static_cast<unsigned long long>(acked.load()));
    std::fflush(stdout);
  }
  stop = true;
  for (auto& t : threads) t.join();
  const double wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(lat.mu);
  std::printf("  ingest      %.1f keyframes/s acknowledged (%llu), %llu ingest errors\n",
              acked / wall_s, static_cast<unsigned long long>(acked.load()),
              static_cast<unsigned long long>(ingest_errors.load()));
  std::printf("  Ask         %zu calls, p50 %.1f ms, p99 %.1f ms, max %.1f ms\n", lat.ask_ms.size(),
              Percentile(lat.ask_ms, 0.5), Percentile(lat.ask_ms, 0.99),
              Percentile(lat.ask_ms, 1.0));
  std::printf("  FindObjects %zu calls, p50 %.1f ms, p99 %.1f ms, max %.1f ms\n",
              lat.find_ms.size(), Percentile(lat.find_ms, 0.5), Percentile(lat.find_ms, 0.99),
              Percentile(lat.find_ms, 1.0));
  std::printf("  query errors %llu; map %llu objects; queue depth at the end %zu\n",
              static_cast<unsigned long long>(lat.errors.load()),
              static_cast<unsigned long long>((*srv)->mapper().Stats().objects),
              (*srv)->stats().queue_depth);
  grpc_server->reset();
  srv->reset();
  std::filesystem::remove_all(dir);
  return ingest_errors == 0 && lat.errors == 0 ? 0 : 1;
}

}  // namespace

void RegisterBenchLoadCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchLoadArgs>();
  CLI::App* c = bench->add_subcommand(
      "load", "N streaming robots and M query clients on loopback gRPC: errors, rates, latency");
  c->add_option("--robots", args->robots, "streaming robots")->capture_default_str();
  c->add_option("--clients", args->clients, "query clients (Ask and FindObjects in turn)")
      ->capture_default_str();
  c->add_option("--seconds", args->seconds, "duration")->capture_default_str();
  c->add_option("--robot-hz", args->robot_hz, "keyframes per second per robot (0 = unpaced)")
      ->capture_default_str();
  c->add_option("--client-hz", args->client_hz, "calls per second per query client (0 = unpaced)")
      ->capture_default_str();
  c->add_option("--views", args->views, "distinct rendered views, cycled")->capture_default_str();
  c->add_option("--config", args->config, "server YAML (default: config/server.yaml)");
  c->add_option("--objects", args->objects, "objects in the synthetic scene")
      ->capture_default_str();
  c->callback([args] { ExitCode() = RunBenchLoad(*args); });
}

}  // namespace loci::cli

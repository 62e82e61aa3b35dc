// `loci bench fleet --store postgresql://... [--sites N] [--robots M] [--clients C] [--seconds T]`:
// a fleet on one machine. N sites, each mapped by its own in-process server on a PostgreSQL site
// (behind its writer lease), M robots each streaming rendered `loci synth` views as fast as they
// are acknowledged, C query clients calling FindObjects spread over the sites; then the same
// N x M robots and C clients on one server with one SQLite file, the single-machine baseline,
// in the same run. Prints keyframes/s acknowledged and FindObjects p50/p99 of both, and the
// ratio. The bench's sites are dropped afterwards.
#include <grpcpp/create_channel.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "cli/bench_stats.h"
#include "cli/bench_traffic.h"
#include "cli/bench_views.h"
#include "cli/commands.h"
#include "common/config.h"
#include "server/postgres/postgres_store.h"
#include "server/runtime/map_server.h"
#include "server/runtime/store_opener.h"
#include "server/service/grpc_server.h"

namespace loci::cli {
namespace {

struct BenchFleetArgs {
  std::string store;  // postgresql://...
  int sites = 4;
  int robots = 4;  // per site
  int clients = 4;
  double seconds = 30;
  int views = 30;
  int objects = 8;
  std::string config;  // "" = config/server.yaml
};

struct PhaseResult {
  double keyframes_per_s = 0;
  double find_p50_ms = 0, find_p99_ms = 0;
  size_t find_calls = 0;
  uint64_t errors = 0;
};

// One in-process server on `store`, listening on a free loopback port.
struct RunningServer {
  server::OpenedStore store;
  std::unique_ptr<server::MapServer> map;
  std::unique_ptr<server::GrpcServer> grpc;
  std::string address;
};

StatusOr<std::unique_ptr<RunningServer>> StartServer(const server::ServerOptions& options) {
  auto out = std::make_unique<RunningServer>();
  LOCI_ASSIGN_OR_RETURN(
      out->store, server::OpenServerStore(
                      options,
                      [](const server::LeaseHolder& holder) {
                        std::cerr << "site taken by " << holder.holder << "\n";
                        return false;
                      },
                      [](const Status& s) { std::cerr << "error: " << s.message() << "\n"; }));
  LOCI_ASSIGN_OR_RETURN(out->map, server::MapServer::Open(options, out->store.store));
  LOCI_ASSIGN_OR_RETURN(out->grpc, server::GrpcServer::Start(out->map.get(), "127.0.0.1:0",
                                                             options.max_message_mb));
  out->address = "127.0.0.1:" + std::to_string(out->grpc->port());
  return out;
}

// Robots and clients against `servers` (robots_per_server each; clients round-robin) for T s.
PhaseResult Drive(const std::vector<std::unique_ptr<RunningServer>>& servers,
                  const std::vector<std::string>& sites, int robots_per_server,
                  const std::vector<loci::v1::Keyframe>& views, const BenchFleetArgs& a) {
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(64 << 20);
  args.SetMaxReceiveMessageSize(-1);
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> acked{0}, errors{0};
  Latencies lat;
  std::vector<std::thread> threads;
  for (size_t s = 0; s < servers.size(); ++s) {
    for (int r = 0; r < robots_per_server; ++r) {
      auto channel = grpc::CreateCustomChannel(servers[s]->address,
                                               grpc::InsecureChannelCredentials(), args);
      threads.emplace_back(RobotLoop, channel, "robot" + std::to_string(s) + "-" +
                           std::to_string(r), sites[s], std::cref(views), 0.0, std::cref(stop),
                           &acked, &errors);
    }
  }
  for (int c = 0; c < a.clients; ++c) {
    auto channel = grpc::CreateCustomChannel(servers[c % servers.size()]->address,
                                             grpc::InsecureChannelCredentials(), args);
    threads.emplace_back(ClientLoop, channel, 0.0, true, std::cref(stop), &lat);
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(a.seconds));
  stop = true;
  for (auto& t : threads) t.join();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  PhaseResult r;
  r.keyframes_per_s = static_cast<double>(acked) / wall_s;
  std::lock_guard<std::mutex> lock(lat.mu);
  r.find_calls = lat.find_ms.size();
  r.find_p50_ms = Percentile(lat.find_ms, 0.5);
  r.find_p99_ms = Percentile(lat.find_ms, 0.99);
  r.errors = errors + lat.errors;
  return r;
}

void Print(const char* name, const PhaseResult& r) {
  std::printf("  %-34s ingest %6.1f keyframes/s, FindObjects %zu calls p50 %.1f ms p99 %.1f ms, "
              "%llu errors\n",
              name, r.keyframes_per_s, r.find_calls, r.find_p50_ms, r.find_p99_ms,
              static_cast<unsigned long long>(r.errors));
}

int RunBenchFleet(const BenchFleetArgs& a) {
  if (!server::IsPostgresStore(a.store)) {
    std::cerr << "error: --store must name a PostgreSQL database (postgresql://...)\n";
    return 2;
  }
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("loci_bench_fleet_" + std::to_string(getpid())))
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
  server::ServerOptions options;
  if (Status s = options.FromYamlFile(a.config.empty() ? SourceDir() + "/config/server.yaml"
                                                        : a.config);
      !s.ok()) {
    std::cerr << "error: " << s.message() << "\n";
    return 2;
  }
  std::printf("loci bench fleet: %d sites x %d robots (unpaced), %d FindObjects clients, %.0f s "
              "per phase, %u cores\n",
              a.sites, a.robots, a.clients, a.seconds, std::thread::hardware_concurrency());
  PhaseResult fleet, single;
  std::vector<std::string> sites;
  int code = 0;
  {
    std::vector<std::unique_ptr<RunningServer>> servers;
    for (int s = 0; s < a.sites; ++s) {
      sites.push_back("bench-fleet-" + std::to_string(getpid()) + "-" + std::to_string(s));
      server::ServerOptions o = options;
      o.store = a.store;
      o.site = sites.back();
      auto started = StartServer(o);
      if (!started.ok()) {
        std::cerr << "error: site " << o.site << ": " << started.status().message() << "\n";
        code = 1;
        break;
      }
      servers.push_back(std::move(*started));
    }
    if (code == 0) fleet = Drive(servers, sites, a.robots, *views, a);
  }
  for (const std::string& site : sites) {
    if (Status s = server::PostgresStore::DropSite(a.store, site); !s.ok()) {
      std::cerr << "warning: " << s.message() << "\n";
    }
  }
  if (code != 0) return code;
  {
    server::ServerOptions o = options;
    o.db_path = dir + "/single.db";
    auto started = StartServer(o);
    if (!started.ok()) {
      std::cerr << "error: " << started.status().message() << "\n";
      return 1;
    }
    std::vector<std::unique_ptr<RunningServer>> one;
    one.push_back(std::move(*started));
    single = Drive(one, {""}, a.sites * a.robots, *views, a);
  }
  char label[96];
  std::snprintf(label, sizeof(label), "PostgreSQL, %d sites x %d robots", a.sites, a.robots);
  Print(label, fleet);
  std::snprintf(label, sizeof(label), "one SQLite server, %d robots", a.sites * a.robots);
  Print(label, single);
  std::printf("  ingest ratio PostgreSQL fleet / single SQLite: %.2f\n",
              single.keyframes_per_s > 0 ? fleet.keyframes_per_s / single.keyframes_per_s : 0.0);
  std::filesystem::remove_all(dir);
  return fleet.errors == 0 && single.errors == 0 ? 0 : 1;
}

}  // namespace

void RegisterBenchFleetCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchFleetArgs>();
  CLI::App* c = bench->add_subcommand(
      "fleet", "N PostgreSQL sites x M robots against one SQLite server: ingest, query p99");
  c->add_option("--store", args->store, "PostgreSQL database (postgresql://USER@HOST:PORT/DB)")
      ->required();
  c->add_option("--sites", args->sites, "sites, one server each")->capture_default_str();
  c->add_option("--robots", args->robots, "robots per site")->capture_default_str();
  c->add_option("--clients", args->clients, "FindObjects clients in all")->capture_default_str();
  c->add_option("--seconds", args->seconds, "duration of each phase")->capture_default_str();
  c->add_option("--views", args->views, "distinct rendered views, cycled")->capture_default_str();
  c->add_option("--objects", args->objects, "objects in the synthetic scene")
      ->capture_default_str();
  c->add_option("--config", args->config, "server YAML (default: config/server.yaml)");
  c->callback([args] { ExitCode() = RunBenchFleet(*args); });
}

}  // namespace loci::cli

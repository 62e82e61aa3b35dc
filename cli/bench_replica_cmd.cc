// `loci bench replica --store postgresql://... [--objects N] [--publications P] [--queries Q]`:
// a read-only query server on a site of N synthetic office objects. A writer (this process, as
// the site's writer would) publishes the whole table, then P changes of --changed objects each;
// for each the time from the start of its publication to the read-only server's map holding it.
// Then Q gRPC calls of each kind on the read-only server from --clients threads: FindObjects of
// one class near a point, GetObject, and Ask. Prints p50/p99/max. The site is dropped afterwards.
#include <grpcpp/create_channel.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <random>
#include <thread>

#include "cli/bench_stats.h"
#include "cli/commands.h"
#include "query/synthetic_map.h"
#include "server/postgres/postgres_store.h"
#include "server/runtime/map_publisher.h"
#include "server/runtime/replica_map.h"
#include "server/service/grpc_server.h"

namespace loci::cli {
namespace {

struct BenchReplicaArgs {
  std::string store;
  int objects = 10'000;
  int publications = 20;
  int changed = 20;  // objects moved per change publication
  int queries = 2'000;
  int asks = 200;
  int clients = 2;
  uint32_t seed = 1;
};

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void PrintLatency(const char* name, const std::vector<double>& ms) {
  std::printf("  %-44s %5zu  p50 %7.2f ms  p99 %7.2f ms  max %7.2f ms\n", name, ms.size(),
              Percentile(ms, 0.5), Percentile(ms, 0.99), Percentile(ms, 1.0));
}

// P change publications of `changed` moved objects each; per publication, ms until the
// read-only map holds its version.
StatusOr<std::vector<double>> MeasureVisibility(server::PostgresStore& writer,
                                                const server::ReplicaMap& replica,
                                                std::vector<MapObject>& objects,
                                                const BenchReplicaArgs& a) {
  std::mt19937 rng(a.seed);
  std::vector<double> ms;
  for (int p = 0; p < a.publications; ++p) {
    server::MapPublication change;
    for (int k = 0; k < a.changed; ++k) {
      MapObject& o = objects[rng() % objects.size()];
      o.centroid_m.x() += 0.01;
      o.aabb_min_m.x() += 0.01;
      o.aabb_max_m.x() += 0.01;
      change.objects.push_back(server::ObjectRow(o));
    }
    change.levelled_by = "gravity";
    const int64_t before = replica.Snapshot()->version;
    const auto t0 = std::chrono::steady_clock::now();
    LOCI_RETURN_IF_ERROR(writer.Publish(change));
    while (replica.Snapshot()->version <= before) {
      if (MsSince(t0) > 30'000) return absl::DeadlineExceededError("no reload within 30 s");
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    ms.push_back(MsSince(t0));
  }
  return ms;
}

// `calls` calls of `call` spread over the clients' threads; ms per call, and the failures.
std::vector<double> Drive(const std::string& address, int clients, int calls,
                          const std::function<grpc::Status(loci::v1::Query::Stub*, int)>& call,
                          std::atomic<int>* failures) {
  std::vector<double> ms;
  std::mutex mu;
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      auto stub = loci::v1::Query::NewStub(
          grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
      std::vector<double> mine;
      for (int i = c; i < calls; i += clients) {
        const auto t0 = std::chrono::steady_clock::now();
        const grpc::Status s = call(stub.get(), i);
        mine.push_back(MsSince(t0));
        if (!s.ok()) ++*failures;
      }
      std::lock_guard<std::mutex> lock(mu);
      ms.insert(ms.end(), mine.begin(), mine.end());
    });
  }
  for (auto& t : threads) t.join();
  return ms;
}

Status QueryLatencies(const std::string& address, const std::vector<MapObject>& objects,
                      const BenchReplicaArgs& a) {
  std::atomic<int> failures{0};
  size_t found = 0;
  std::mutex found_mu;
  const auto find = [&](loci::v1::Query::Stub* stub, int i) {
    const MapObject& at = objects[(static_cast<size_t>(i) * 7919) % objects.size()];
    grpc::ClientContext ctx;
    loci::v1::FindObjectsRequest req;
    req.add_classes(at.class_name);
    req.mutable_near_center_m()->set_x(at.centroid_m.x());
    req.mutable_near_center_m()->set_y(at.centroid_m.y());
    req.mutable_near_center_m()->set_z(at.centroid_m.z());
    req.set_radius_m(2.0);
    loci::v1::FindObjectsResponse resp;
    grpc::Status s = stub->FindObjects(&ctx, req, &resp);
    std::lock_guard<std::mutex> lock(found_mu);
    found += resp.objects_size();
    return s;
  };
  const auto get = [&](loci::v1::Query::Stub* stub, int i) {
    grpc::ClientContext ctx;
    loci::v1::GetObjectRequest req;
    req.set_id(objects[(static_cast<size_t>(i) * 104729) % objects.size()].id);
    loci::v1::GetObjectResponse resp;
    return stub->GetObject(&ctx, req, &resp);
  };
  const auto ask = [&](loci::v1::Query::Stub* stub, int i) {
    grpc::ClientContext ctx;
    loci::v1::AskRequest req;
    req.set_text(std::string("where is the ") + (i % 2 ? "cup" : "chair") + "?");
    loci::v1::AskResponse resp;
    return stub->Ask(&ctx, req, &resp);
  };
  {  // The first Ask builds the query index of this map version; the rest reuse it.
    auto stub = loci::v1::Query::NewStub(
        grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
    const auto t0 = std::chrono::steady_clock::now();
    if (!ask(stub.get(), 0).ok()) ++failures;
    std::printf("  first Ask (builds the index of %zu objects): %.1f ms\n", objects.size(),
                MsSince(t0));
  }
  const std::vector<double> find_ms = Drive(address, a.clients, a.queries, find, &failures);
  PrintLatency("FindObjects (a class within 2 m of a point)", find_ms);
  std::printf("  %-44s %.1f objects per answer\n", "",
              static_cast<double>(found) / std::max(1, a.queries));
  PrintLatency("GetObject", Drive(address, a.clients, a.queries, get, &failures));
  PrintLatency("Ask (\"where is the cup?\")", Drive(address, a.clients, a.asks, ask, &failures));
  if (failures > 0) return absl::InternalError(absl::StrCat(failures.load(), " calls failed"));
  return absl::OkStatus();
}

Status Run(const BenchReplicaArgs& a, const std::string& site) {
  query::SyntheticMapOptions so;
  so.object_count = a.objects;
  so.seed = a.seed;
  std::vector<MapObject> objects =
      query::MapObjectsFromGroundTruth(query::MakeSyntheticOffice(so), 1'000, "robot-a");
  server::PostgresStoreOptions wo;
  wo.site = site;
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<server::PostgresStore> writer,
                        server::PostgresStore::Open(a.store, wo));
  server::MapPublication whole;
  whole.replace_all = true;
  for (const MapObject& o : objects) whole.objects.push_back(server::ObjectRow(o));
  whole.poses = {{"robot-a", 1'000, SE3d::Identity()}};
  whole.levelled_by = "gravity";
  auto t0 = std::chrono::steady_clock::now();
  LOCI_RETURN_IF_ERROR(writer->Publish(whole));
  std::printf("  whole table published: %zu objects in %.0f ms\n", objects.size(), MsSince(t0));

  wo.read_only = true;
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<server::PostgresStore> reader,
                        server::PostgresStore::Open(a.store, wo));
  std::shared_ptr<server::PostgresStore> shared_reader = std::move(reader);
  t0 = std::chrono::steady_clock::now();
  server::ReplicaMap replica(shared_reader);
  LOCI_RETURN_IF_ERROR(replica.readiness().Wait());
  std::printf("  read-only map loaded: %zu objects in %.0f ms\n",
              replica.Snapshot()->objects.size(), MsSince(t0));
  LOCI_ASSIGN_OR_RETURN(std::vector<double> visible_ms,
                        MeasureVisibility(*writer, replica, objects, a));
  char label[96];
  std::snprintf(label, sizeof(label), "publication -> read-only map (%d moved)", a.changed);
  PrintLatency(label, visible_ms);

  LOCI_ASSIGN_OR_RETURN(
      std::unique_ptr<server::GrpcServer> grpc,
      server::GrpcServer::StartReadOnly(
          &replica, shared_reader.get(), "127.0.0.1:0", 64,
          std::make_shared<server::QueryAdapter>(server::QueryAdapterOptions{}),
          [] { return std::string(); }));
  const Status queried =
      QueryLatencies("127.0.0.1:" + std::to_string(grpc->port()), replica.Snapshot()->objects, a);
  grpc->Shutdown();
  return queried;
}

int RunBenchReplica(const BenchReplicaArgs& a) {
  if (a.objects < 1 || a.publications < 1 || a.changed < 1 || a.queries < 1 || a.asks < 1 ||
      a.clients < 1) {
    std::cerr << "error: every count must be >= 1\n";
    return 2;
  }
  std::printf("loci bench replica: %d objects, %d publications, %d calls per kind from %d "
              "clients, %u cores\n",
              a.objects, a.publications, a.queries, a.clients,
              std::thread::hardware_concurrency());
  const std::string site = "bench-replica-" + std::to_string(getpid());
  const Status s = Run(a, site);
  if (Status dropped = server::PostgresStore::DropSite(a.store, site); !dropped.ok()) {
    std::cerr << "warning: " << dropped.message() << "\n";
  }
  if (!s.ok()) {
    std::cerr << "error: " << s.message() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

void RegisterBenchReplicaCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchReplicaArgs>();
  CLI::App* c = bench->add_subcommand(
      "replica", "a read-only query server: publication-to-visible latency, query p50/p99");
  c->add_option("--store", args->store, "PostgreSQL database (postgresql://USER@HOST:PORT/DB)")
      ->required();
  c->add_option("--objects", args->objects, "objects in the site's map")->capture_default_str();
  c->add_option("--publications", args->publications, "change publications timed")
      ->capture_default_str();
  c->add_option("--changed", args->changed, "objects moved per publication")
      ->capture_default_str();
  c->add_option("--queries", args->queries, "FindObjects and GetObject calls each")
      ->capture_default_str();
  c->add_option("--asks", args->asks, "Ask calls")->capture_default_str();
  c->add_option("--clients", args->clients, "client threads")->capture_default_str();
  c->add_option("--seed", args->seed, "synthetic office seed")->capture_default_str();
  c->callback([args] { ExitCode() = RunBenchReplica(*args); });
}

}  // namespace loci::cli

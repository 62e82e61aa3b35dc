#include "cli/bench_query_grpc.h"

#include <grpcpp/create_channel.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include "cli/bench_stats.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/service/query_adapter.h"

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

// A fixed map (the synthetic snapshot) behind the adapter's source interface.
class FixedSource final : public server::QueryMapSource {
 public:
  FixedSource(std::vector<MapObject> objects, const query::Viewpoint& view)
      : objects_(std::move(objects)) {
    poses_[view.robot] = server::RobotPose{view.t_ns, view.T_map_cam};
  }
  std::map<std::string, server::RobotPose> LatestPoses() const override { return poses_; }
  std::vector<MapObject> Objects(bool) const override { return objects_; }
  std::optional<Vec3d> GravityUp() const override { return Vec3d::UnitZ(); }
  std::vector<Eigen::Vector3f> CloudPoints(double) const override { return {}; }

 private:
  std::vector<MapObject> objects_;
  std::map<std::string, server::RobotPose> poses_;
};

// Answers from the fixed map instead of the (empty) server map, through the QueryAdapter.
class FixedMapEngine final : public server::QueryEngine {
 public:
  FixedMapEngine(std::vector<MapObject> objects, const query::Viewpoint& view, int64_t now_ns)
      : source_(std::move(objects), view), adapter_(Options(now_ns)) {}
  StatusOr<loci::v1::AskResponse> Ask(const loci::v1::AskRequest& request,
                                      const server::MapServer&) override {
    return adapter_.Ask(request, source_);
  }

 private:
  static server::QueryAdapterOptions Options(int64_t now_ns) {
    server::QueryAdapterOptions o;
    o.confirmed_only = false;  // the synthetic objects are not marked confirmed
    o.now_ns = [now_ns] { return now_ns; };
    return o;
  }
  FixedSource source_;
  server::QueryAdapter adapter_;
};

}  // namespace

StatusOr<GrpcBenchResult> RunGrpcAskBench(std::vector<MapObject> objects,
                                          const query::Viewpoint& view, int64_t now_ns,
                                          const std::vector<std::string>& questions, int threads) {
  namespace fs = std::filesystem;
  const std::string db =
      (fs::temp_directory_path() / ("loci_bench_query_" + std::to_string(getpid()) + ".db"))
          .string();
  server::ServerOptions options;
  LOCI_RETURN_IF_ERROR(options.LoadClasses());
  options.db_path = db;
  GrpcBenchResult out;
  {
    LOCI_ASSIGN_OR_RETURN(auto map_server, server::MapServer::Open(options));
    LOCI_ASSIGN_OR_RETURN(auto grpc,
                          server::GrpcServer::Start(
                              map_server.get(), "127.0.0.1:0", options.max_message_mb,
                              std::make_shared<FixedMapEngine>(std::move(objects), view, now_ns)));
    auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(grpc->port()),
                                       grpc::InsecureChannelCredentials());
    auto stub = loci::v1::Query::NewStub(channel);
    std::atomic<size_t> failures{0};
    auto ask = [&](loci::v1::Query::Stub* s, const std::string& text) {
      grpc::ClientContext ctx;
      loci::v1::AskRequest req;
      req.set_text(text);
      loci::v1::AskResponse resp;
      const grpc::Status st = s->Ask(&ctx, req, &resp);
      if (!st.ok()) failures.fetch_add(1);
    };
    ask(stub.get(), questions.front());  // connect and build the index outside the timings

    std::vector<double> ms;
    ms.reserve(questions.size());
    const auto t_all = Clock::now();
    for (const std::string& q : questions) {
      const auto t0 = Clock::now();
      ask(stub.get(), q);
      ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    const double single_s = std::chrono::duration<double>(Clock::now() - t_all).count();

    std::atomic<size_t> next{0};
    const auto t_mt = Clock::now();
    std::vector<std::thread> workers;
    for (int t = 0; t < threads; ++t) {
      workers.emplace_back([&] {
        auto own = loci::v1::Query::NewStub(channel);
        for (size_t i; (i = next.fetch_add(1)) < questions.size();) ask(own.get(), questions[i]);
      });
    }
    for (std::thread& w : workers) w.join();
    const double mt_s = std::chrono::duration<double>(Clock::now() - t_mt).count();

    out.p50_ms = Percentile(ms, 0.5);
    out.p99_ms = Percentile(ms, 0.99);
    out.max_ms = Percentile(ms, 1.0);
    out.qps_1 = questions.size() / single_s;
    out.qps_n = questions.size() / mt_s;
    out.failures = failures.load();
    grpc->Shutdown();
  }
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(db + suffix);
  return out;
}

}  // namespace loci::cli

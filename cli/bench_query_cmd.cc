// `loci bench query [--objects 10000] [--queries 20000] [--threads 2] [--seed 1]`: in-process
// Ask latency (p50 / p99 per question form and overall) and throughput of the query engine on a
// synthetic office map (query/synthetic_map.h), plus the time to index the snapshot; then Ask
// over gRPC on loopback against an in-process server answering from the same map
// (cli/bench_query_grpc.h; `--grpc-queries 0` skips it).
#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "cli/bench_query_grpc.h"
#include "cli/bench_stats.h"
#include "cli/commands.h"
#include "common/config.h"
#include "common/time.h"
#include "query/query_engine.h"
#include "query/synthetic_map.h"

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchQueryArgs {
  size_t objects = 10000;
  size_t queries = 20000;
  int threads = 2;
  uint64_t seed = 1;
  std::string config;
  size_t grpc_queries = 5000;  // questions asked over gRPC (0 = skip)
};

// Question forms of the mix; "%d" is replaced by a random object id of the named class.
struct Form {
  const char* text;
  const char* id_class;  // nullptr = no id
};
constexpr Form kForms[] = {
    {"where is the book on the table", nullptr},
    {"what is on #%d", "dining table"},
    {"is there a cup near the keyboard", nullptr},
    {"how many chairs are there", nullptr},
    {"list all objects", nullptr},
    {"which robot saw the laptop last", nullptr},
    {"what is left of #%d", "tv"},
    {"where is #%d", "book"},
    {"where is the nearest chair to #%d", "dining table"},
    {"is #%d under the table", "chair"},
    {"what is on the desk", nullptr},
    {"how many cups are on the tables", nullptr},
};
constexpr size_t kNumForms = sizeof(kForms) / sizeof(kForms[0]);

// The synthetic office map and the one viewpoint every question is asked from.
struct BenchMap {
  int64_t now_ns = 2'000'000'000'000'000'000;
  std::vector<MapObject> objects;
  query::Viewpoint view;
};

BenchMap MakeBenchMap(const BenchQueryArgs& a) {
  BenchMap m;
  query::SyntheticMapOptions so;
  so.object_count = a.objects;
  so.seed = a.seed;
  m.objects = query::MapObjectsFromGroundTruth(query::MakeSyntheticOffice(so),
                                               m.now_ns - 30'000'000'000, "robot-a");
  // A viewpoint in the middle of the first room, level, looking along +y.
  m.view = query::Viewpoint{"robot-a", SE3d::Identity(), m.now_ns};
  m.view.T_map_cam.linear() << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  m.view.T_map_cam.translation() = Vec3d(1.5, 3.0, 1.2);
  return m;
}

// The question list (form index, text), drawn once so every run asks the same.
std::vector<std::pair<size_t, std::string>> DrawQuestions(const BenchQueryArgs& a,
                                                          const std::vector<MapObject>& objects) {
  std::mt19937_64 rng(a.seed);
  std::vector<std::vector<int64_t>> ids_of(kNumForms);
  for (size_t f = 0; f < kNumForms; ++f) {
    if (!kForms[f].id_class) continue;
    for (const MapObject& o : objects) {
      if (o.class_name == kForms[f].id_class) ids_of[f].push_back(o.id);
    }
  }
  std::vector<std::pair<size_t, std::string>> questions;
  for (size_t i = 0; i < a.queries; ++i) {
    const size_t f = i % kNumForms;
    std::string text = kForms[f].text;
    if (kForms[f].id_class && !ids_of[f].empty()) {
      const int64_t id = ids_of[f][rng() % ids_of[f].size()];
      text.replace(text.find("%d"), 2, std::to_string(id));
    }
    questions.push_back({f, text});
  }
  return questions;
}

// Wall and thread-CPU milliseconds of each Ask, per form and over all, on one thread.
struct SingleThreadRun {
  std::vector<std::vector<double>> ms_by_form = std::vector<std::vector<double>>(kNumForms);
  std::vector<std::vector<double>> cpu_by_form = std::vector<std::vector<double>>(kNumForms);
  std::vector<double> all_ms;
  std::vector<double> all_cpu_ms;
  size_t failures = 0;
  double wall_s = 0;
};

SingleThreadRun AskOneByOne(const query::QueryEngine& engine, const query::MapIndex& index,
                            const std::vector<std::pair<size_t, std::string>>& questions,
                            int64_t now_ns) {
  SingleThreadRun run;
  const auto t_all = Clock::now();
  for (const auto& [f, text] : questions) {
    const auto t0 = Clock::now();
    const double c0 = ThreadCpuMs();
    const query::AskResult r = engine.Ask(text, index, query::AskContext{now_ns, ""});
    const double cpu_ms = ThreadCpuMs() - c0;
    const double ms = MsSince(t0);
    run.cpu_by_form[f].push_back(cpu_ms);
    run.all_cpu_ms.push_back(cpu_ms);
    run.failures += !r.status.ok();
    run.ms_by_form[f].push_back(ms);
    run.all_ms.push_back(ms);
  }
  run.wall_s = MsSince(t_all) * 1e-3;
  return run;
}

// Seconds for `threads` threads sharing the index to ask every question once.
double AskOnThreads(const query::QueryEngine& engine, const query::MapIndex& index,
                    const std::vector<std::pair<size_t, std::string>>& questions, int64_t now_ns,
                    int threads) {
  std::atomic<size_t> next{0};
  const auto t_mt = Clock::now();
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      for (size_t i; (i = next.fetch_add(1)) < questions.size();) {
        (void)engine.Ask(questions[i].second, index, query::AskContext{now_ns, ""});
      }
    });
  }
  for (std::thread& w : workers) w.join();
  return MsSince(t_mt) * 1e-3;
}

// Milliseconds of a one-off Ask that indexes the snapshot itself (the MapView path).
double AskOnMapView(const query::QueryEngine& engine, const BenchMap& m) {
  const auto t_view = Clock::now();
  query::MapView mv;
  mv.objects = m.objects;
  mv.viewpoints = {m.view};
  mv.now_ns = m.now_ns;
  (void)engine.Ask(kForms[0].text, mv);
  return MsSince(t_view);
}

void PrintInProcess(const BenchQueryArgs& a, size_t objects, size_t questions,
                    const std::vector<double>& index_ms, double view_ms, const SingleThreadRun& run,
                    double mt_s) {
  double load[3] = {0, 0, 0};
  const bool have_load = getloadavg(load, 3) == 3;
  std::printf("loci bench query: %zu objects, %zu questions (%zu forms), in-process\n", objects,
              questions, kNumForms);
  if (have_load) {
    std::printf(
        "  machine load average %.2f (%u hardware threads): tail latencies include "
        "preemption by other processes\n",
        load[0], std::thread::hardware_concurrency());
  }
  std::printf("  index build   median %.2f ms (5 runs)\n", Percentile(index_ms, 0.5));
  std::printf("  Ask on MapView (index + answer) %.2f ms\n", view_ms);
  std::printf("  %-40s %8s %8s %8s %8s %8s\n", "question form (wall / thread-CPU ms)", "p50", "p99",
              "max", "cpu p50", "cpu p99");
  for (size_t f = 0; f < kNumForms; ++f) {
    std::printf("  %-40s %8.3f %8.3f %8.3f %8.3f %8.3f\n", kForms[f].text,
                Percentile(run.ms_by_form[f], 0.5), Percentile(run.ms_by_form[f], 0.99),
                Percentile(run.ms_by_form[f], 1.0), Percentile(run.cpu_by_form[f], 0.5),
                Percentile(run.cpu_by_form[f], 0.99));
  }
  std::printf("  %-40s %8.3f %8.3f %8.3f %8.3f %8.3f\n", "all", Percentile(run.all_ms, 0.5),
              Percentile(run.all_ms, 0.99), Percentile(run.all_ms, 1.0),
              Percentile(run.all_cpu_ms, 0.5), Percentile(run.all_cpu_ms, 0.99));
  double cpu_total_ms = 0;
  for (double c : run.all_cpu_ms) cpu_total_ms += c;
  std::printf("  CPU cost per Ask (mean) %.3f ms -> %.0f Ask/s per core\n",
              cpu_total_ms / run.all_cpu_ms.size(), 1e3 * run.all_cpu_ms.size() / cpu_total_ms);
  std::printf("  throughput 1 thread  %.0f Ask/s\n", questions / run.wall_s);
  std::printf("  throughput %d threads %.0f Ask/s\n", a.threads, questions / mt_s);
  if (run.failures > 0) std::printf("  %zu questions failed to parse\n", run.failures);
}

// The gRPC part: failed asks, or -1 when the benchmark could not run.
int64_t RunGrpcPart(const BenchQueryArgs& a, const BenchMap& m,
                    const std::vector<std::pair<size_t, std::string>>& questions) {
  std::vector<std::string> texts;
  for (size_t i = 0; i < std::min(a.grpc_queries, questions.size()); ++i) {
    texts.push_back(questions[i].second);
  }
  auto g = RunGrpcAskBench(m.objects, m.view, m.now_ns, texts, a.threads);
  if (!g.ok()) {
    std::fprintf(stderr, "error: gRPC bench: %s\n", std::string(g.status().message()).c_str());
    return -1;
  }
  std::printf(
      "loci bench query: gRPC Ask on loopback (in-process server, same map), %zu "
      "questions\n",
      texts.size());
  std::printf("  latency (wall ms, 1 client)  p50 %.3f  p99 %.3f  max %.3f\n", g->p50_ms, g->p99_ms,
              g->max_ms);
  std::printf("  throughput 1 client   %.0f Ask/s\n", g->qps_1);
  std::printf("  throughput %d clients %.0f Ask/s\n", a.threads, g->qps_n);
  if (g->failures > 0) std::printf("  %zu gRPC asks failed\n", g->failures);
  return static_cast<int64_t>(g->failures);
}

int RunBenchQuery(const BenchQueryArgs& a) {
  query::QueryOptions options = query::QueryOptions::Defaults();
  if (!a.config.empty()) {
    auto o = query::LoadQueryOptions(a.config);
    if (!o.ok()) {
      std::fprintf(stderr, "error: %s\n", std::string(o.status().message()).c_str());
      return 1;
    }
    options = *o;
  }
  if (a.objects == 0 || a.queries == 0 || a.threads < 1) {
    std::fprintf(stderr, "error: --objects, --queries and --threads must be > 0\n");
    return 1;
  }
  const query::QueryEngine engine(options);
  const BenchMap m = MakeBenchMap(a);
  std::vector<double> index_ms;
  std::shared_ptr<const query::MapIndex> index;
  for (int k = 0; k < 5; ++k) {
    const auto t0 = Clock::now();
    index = engine.Index(m.objects, std::nullopt, {m.view});
    index_ms.push_back(MsSince(t0));
  }
  const auto questions = DrawQuestions(a, m.objects);
  const SingleThreadRun run = AskOneByOne(engine, *index, questions, m.now_ns);
  const double mt_s = AskOnThreads(engine, *index, questions, m.now_ns, a.threads);
  const double view_ms = AskOnMapView(engine, m);
  PrintInProcess(a, m.objects.size(), questions.size(), index_ms, view_ms, run, mt_s);
  size_t failures = run.failures;
  if (a.grpc_queries > 0) {
    const int64_t grpc_failures = RunGrpcPart(a, m, questions);
    if (grpc_failures < 0) return 1;
    failures += static_cast<size_t>(grpc_failures);
  }
  return failures > 0 ? 1 : 0;
}
}  // namespace

void RegisterBenchQueryCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchQueryArgs>();
  CLI::App* c = bench->add_subcommand("query", "query engine Ask latency and throughput");
  c->add_option("--objects", args->objects, "objects in the synthetic map")->capture_default_str();
  c->add_option("--queries", args->queries, "questions to ask")->capture_default_str();
  c->add_option("--threads", args->threads, "threads for the throughput run")
      ->capture_default_str();
  c->add_option("--seed", args->seed, "random seed of map and questions")->capture_default_str();
  c->add_option("--config", args->config, "query YAML (default: built-in defaults)");
  c->add_option("--grpc-queries", args->grpc_queries,
                "questions asked over gRPC on loopback (0 = in-process only)")
      ->capture_default_str();
  c->callback([args] { ExitCode() = RunBenchQuery(*args); });
}

}  // namespace loci::cli

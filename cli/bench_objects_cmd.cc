// `loci bench objects [--seeds 20] [--first-seed 1] [--frames 200] [--exact] [--out DIR]
// [--server-config FILE]`: the object map on varied synthetic rooms with detector noise
// (cli/report/synth_objects_eval.h): precision, recall, F1 and centroid error per seed, then the
// mean over the seeds, the median centroid error and the worst seed.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

#include "cli/bench_stats.h"
#include "cli/commands.h"
#include "cli/report/synth_objects_eval.h"

namespace loci::cli {
namespace {

struct BenchObjectsArgs {
  int seeds = 20;
  uint64_t first_seed = 1;
  report::SynthObjectsOptions scene;
  bool exact = false;
};

void PrintSummary(const std::vector<report::SynthObjectsResult>& results) {
  double p = 0, r = 0, f1 = 0;
  std::vector<double> centroids_cm;
  const report::SynthObjectsResult* worst = &results.front();
  for (const auto& s : results) {
    p += s.eval.precision / results.size();
    r += s.eval.recall / results.size();
    f1 += s.eval.f1 / results.size();
    centroids_cm.push_back(100 * s.eval.mean_centroid_error_m);
    if (s.eval.f1 < worst->eval.f1) worst = &s;
  }
  double mean_cm = 0;
  for (double c : centroids_cm) mean_cm += c / centroids_cm.size();
  std::printf("mean over %zu seeds: precision %.3f recall %.3f F1 %.3f, centroid %.1f cm "
              "(median of the seeds %.1f cm); worst seed %llu (F1 %.3f)\n",
              results.size(), p, r, f1, mean_cm, Percentile(centroids_cm, 0.5),
              static_cast<unsigned long long>(worst->seed), worst->eval.f1);
}

int RunBenchObjects(BenchObjectsArgs a) {
  namespace fs = std::filesystem;
  const bool temporary = a.scene.work_dir.empty();
  if (temporary) a.scene.work_dir = (fs::temp_directory_path() / "loci-bench-objects").string();
  a.scene.detector_noise = !a.exact;
  std::printf("loci bench objects: %d seeds from %llu, %d frames, detector noise %s\n", a.seeds,
              static_cast<unsigned long long>(a.first_seed), a.scene.frames,
              a.exact ? "off" : "on");
  std::printf("%6s %5s %5s %9s %7s %7s %11s %8s\n", "seed", "gt", "map", "precision", "recall",
              "F1", "centroid_cm", "seconds");
  std::vector<report::SynthObjectsResult> results;
  for (int i = 0; i < a.seeds; ++i) {
    a.scene.seed = a.first_seed + i;
    auto r = report::EvaluateSynthObjects(a.scene);
    if (!r.ok()) {
      std::cerr << "error: seed " << a.scene.seed << ": " << r.status().message() << "\n";
      return 1;
    }
    std::printf("%6llu %5d %5d %9.3f %7.3f %7.3f %11.1f %8.1f\n",
                static_cast<unsigned long long>(r->seed), r->eval.gt_count,
                r->eval.detected_count, r->eval.precision, r->eval.recall, r->eval.f1,
                100 * r->eval.mean_centroid_error_m, r->seconds);
    std::fflush(stdout);
    results.push_back(*std::move(r));
    if (temporary) fs::remove_all(a.scene.work_dir);
  }
  PrintSummary(results);
  return 0;
}

}  // namespace

void RegisterBenchObjectsCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchObjectsArgs>();
  CLI::App* c = bench->add_subcommand(
      "objects", "Object map on varied synthetic rooms with detector noise, over many seeds");
  c->add_option("--seeds", args->seeds, "number of seeds")->capture_default_str();
  c->add_option("--first-seed", args->first_seed, "first seed")->capture_default_str();
  c->add_option("--frames", args->scene.frames, "frames per room (30 Hz)")->capture_default_str();
  c->add_flag("--exact", args->exact, "exact detections (no detector noise)");
  c->add_option("--out", args->scene.work_dir, "keep the rooms in DIR/seed-N (default: temporary)");
  c->add_option("--server-config", args->scene.server_config, "server YAML")
      ->check(CLI::ExistingFile);
  c->callback([args] { ExitCode() = RunBenchObjects(*args); });
}

}  // namespace loci::cli

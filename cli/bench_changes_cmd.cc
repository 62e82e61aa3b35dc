// `loci bench changes [--seeds 20] [--first-seed 1] [--frames 200] [--exact] [--out DIR]
// [--server-config FILE]`: the map over three sessions of varied synthetic rooms in which
// objects move, vanish and appear (cli/report/synth_changes_eval.h): per seed the true changes,
// those found and the false ones, then the share found and the false changes per object and
// session over all seeds.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

#include "cli/commands.h"
#include "cli/report/synth_changes_eval.h"

namespace loci::cli {
namespace {

struct BenchChangesArgs {
  int seeds = 20;
  uint64_t first_seed = 1;
  report::SynthChangesOptions scene;
  bool exact = false;
  bool verbose = false;
};

int RunBenchChanges(BenchChangesArgs a) {
  namespace fs = std::filesystem;
  const bool temporary = a.scene.work_dir.empty();
  if (temporary) a.scene.work_dir = (fs::temp_directory_path() / "loci-bench-changes").string();
  a.scene.detector_noise = !a.exact;
  std::printf("loci bench changes: %d seeds from %llu, 3 sessions of %d frames, detector noise %s\n",
              a.seeds, static_cast<unsigned long long>(a.first_seed), a.scene.frames,
              a.exact ? "off" : "on");
  std::printf("%6s %7s %7s %6s %6s %8s %8s\n", "seed", "objects", "changes", "found", "false",
              "unseen", "seconds");
  int objects = 0, changes = 0, found = 0, false_changes = 0, unseen = 0, skipped = 0;
  for (int i = 0; i < a.seeds; ++i) {
    a.scene.seed = a.first_seed + i;
    auto r = report::EvaluateSynthChanges(a.scene);
    if (temporary) fs::remove_all(a.scene.work_dir);
    if (r.status().code() == absl::StatusCode::kFailedPrecondition) {
      std::printf("%6llu skipped: %s\n", static_cast<unsigned long long>(a.scene.seed),
                  std::string(r.status().message()).c_str());
      ++skipped;
      continue;
    }
    if (!r.ok()) {
      std::cerr << "error: seed " << a.scene.seed << ": " << r.status().message() << "\n";
      return 1;
    }
    std::printf("%6llu %7d %7d %6d %6d %8d %8.1f\n", static_cast<unsigned long long>(r->seed),
                r->objects, r->true_changes, r->found, r->false_changes, r->unobservable,
                r->seconds);
    if (a.verbose) {
      for (const std::string& note : r->notes) std::printf("         %s\n", note.c_str());
    }
    std::fflush(stdout);
    objects += r->objects;
    changes += r->true_changes;
    found += r->found;
    false_changes += r->false_changes;
    unseen += r->unobservable;
  }
  // Two sessions per seed can change (the first one builds the map).
  std::printf("over %d seeds (%d skipped): changes found %d / %d = %.3f, false changes %d = %.4f "
              "per object per session; %d changes left out, their old place never in view\n",
              a.seeds - skipped, skipped, found, changes, changes ? double(found) / changes : 0.0,
              false_changes, objects ? double(false_changes) / (2.0 * objects) : 0.0, unseen);
  return 0;
}

}  // namespace

void RegisterBenchChangesCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchChangesArgs>();
  CLI::App* c = bench->add_subcommand(
      "changes", "Moved, removed and new objects over three sessions of synthetic rooms");
  c->add_option("--seeds", args->seeds, "number of seeds")->capture_default_str();
  c->add_option("--first-seed", args->first_seed, "first seed")->capture_default_str();
  c->add_option("--frames", args->scene.frames, "frames per session (30 Hz)")
      ->capture_default_str();
  c->add_flag("--exact", args->exact, "exact detections (no detector noise)");
  c->add_flag("--verbose", args->verbose, "list each missed and false change");
  c->add_option("--out", args->scene.work_dir,
                "keep the sessions in DIR/seed-N (default: temporary)");
  c->add_option("--server-config", args->scene.server_config, "server YAML")
      ->check(CLI::ExistingFile);
  c->callback([args] { ExitCode() = RunBenchChanges(*args); });
}

}  // namespace loci::cli

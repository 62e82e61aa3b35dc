// `loci reprocess --db FILE [--config server.yaml]`: recomputes every keyframe's map products
// from its raw images with the current detector and options (after a detector or config
// change), rebuilds the map from them and checkpoints it, with a progress bar. Stop the server
// on that database first. Deterministic: running it twice gives the same map.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "cli/commands.h"
#include "common/progress.h"
#include "server/runtime/checkpointer.h"
#include "server/runtime/map_publisher.h"
#include "server/runtime/replay.h"
#include "server/runtime/server_detector.h"
#include "server/runtime/server_options.h"
#include "server/storage/sqlite_store.h"

namespace loci::cli {
namespace {

struct ReprocessArgs {
  std::string db, config;
};

// A bar on a terminal, a line every 10 % otherwise (common/progress.h).
void ShowProgress(uint64_t done, uint64_t total) {
  if (StderrIsTerminal()) {
    std::fprintf(stderr, "\r%s %llu / %llu keyframes", ProgressBar(done, total, 40).c_str(),
                 static_cast<unsigned long long>(done), static_cast<unsigned long long>(total));
    if (done >= total) std::fprintf(stderr, "\n");
  } else if (AtProgressStep(done, total)) {
    std::fprintf(stderr, "%llu / %llu keyframes\n", static_cast<unsigned long long>(done),
                 static_cast<unsigned long long>(total));
  }
}

Status Reprocess(const ReprocessArgs& a) {
  server::ServerOptions options;
  LOCI_RETURN_IF_ERROR(a.config.empty() ? options.LoadClasses() : options.FromYamlFile(a.config));
  LOCI_ASSIGN_OR_RETURN(std::shared_ptr<server::KeyframeDetection> detection,
                        server::MakeServerDetection(options, a.config));
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<server::SqliteStore> store,
                        server::SqliteStore::Open(a.db));
  const auto t0 = std::chrono::steady_clock::now();
  LOCI_RETURN_IF_ERROR(store->DeleteCheckpoints());
  LOCI_RETURN_IF_ERROR(store->DeleteAllProducts());
  auto mapper = std::make_unique<server::Mapper>(options.map);
  server::LoadOptions load;
  load.use_checkpoint = false;
  load.progress = ShowProgress;
  LOCI_ASSIGN_OR_RETURN(server::LoadReport report,
                        server::LoadMap(*store, &mapper, detection.get(), load));
  const server::CheckpointRecord checkpoint = server::MakeCheckpoint(*mapper);
  if (!checkpoint.data.empty()) LOCI_RETURN_IF_ERROR(store->PutCheckpoint(checkpoint));
  LOCI_RETURN_IF_ERROR(store->Publish(server::WholePublication(*mapper)));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const server::MapperStats stats = mapper->Stats();
  std::printf("reprocessed %llu keyframes in %.1f s (%llu skipped: no images), %llu objects "
              "(%llu confirmed); products fingerprint %s\n",
              static_cast<unsigned long long>(report.from_raw), s,
              static_cast<unsigned long long>(report.skipped),
              static_cast<unsigned long long>(stats.objects),
              static_cast<unsigned long long>(stats.confirmed_objects),
              options.map.ProductsFingerprint().c_str());
  return absl::OkStatus();
}

}  // namespace

void RegisterReprocessCommand(CLI::App& app) {
  auto args = std::make_shared<ReprocessArgs>();
  CLI::App* c = app.add_subcommand(
      "reprocess", "recompute every keyframe's map products from its images, rebuild the map");
  c->add_option("--db", args->db, "loci-server database (stop the server first)")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--config", args->config, "server YAML (map options, detector)")
      ->check(CLI::ExistingFile);
  c->callback([args] {
    const Status s = Reprocess(*args);
    if (!s.ok()) std::cerr << "error: " << s.message() << "\n";
    ExitCode() = s.ok() ? 0 : 1;
  });
}

}  // namespace loci::cli

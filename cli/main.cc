// `loci`: the command line of the loci semantic map (evaluation, synthetic scenes, detection,
// exports, queries, benchmarks). `loci --help` lists the commands.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <string>

#include "cli/commands.h"
#include "common/malloc_tuning.h"

namespace loci::cli {
int& ExitCode() {
  static int code = 0;
  return code;
}

namespace {

CLI::App* Group(CLI::App& app, const std::string& name, const std::string& description) {
  for (CLI::App* s : app.get_subcommands([&](CLI::App* s) { return s->get_name() == name; })) {
    return s;
  }
  CLI::App* group = app.add_subcommand(name, description);
  group->require_subcommand(1);
  return group;
}

}  // namespace

CLI::App* BenchGroup(CLI::App& app) {
  return Group(app, "bench", "Benchmarks that print their figures");
}

CLI::App* EvalGroup(CLI::App& app) {
  return Group(app, "eval", "Evaluate trajectories and maps against ground truth");
}

namespace {
// Command groups (loci, eval, bench) take at most one subcommand; their "one is required" is
// checked after parsing, so that an unknown word is reported as such by CLI11 ("not expected:
// frobnicate") instead of as a missing subcommand.
void AllowNoSubcommand(CLI::App* app) {
  if (app->get_subcommands({}).empty()) return;
  app->require_subcommand(0, 1);
  for (CLI::App* s : app->get_subcommands({})) AllowNoSubcommand(s);
}

// The deepest command given; an error when it is a group. Returns the exit code, 0 when fine.
int RequireLeafCommand(CLI::App& app) {
  CLI::App* at = &app;
  std::string path = "loci";
  while (!at->get_subcommands().empty()) {
    at = at->get_subcommands().front();
    path += " " + at->get_name();
  }
  if (at->get_subcommands({}).empty()) return 0;
  std::string names;
  for (const CLI::App* s : at->get_subcommands({})) {
    names += (names.empty() ? "" : ", ") + s->get_name();
  }
  std::cerr << path << ": a subcommand is required (" << names << ")\n"
            << "Run with --help for more information.\n";
  return static_cast<int>(CLI::ExitCodes::RequiredError);
}
}  // namespace
}  // namespace loci::cli

int main(int argc, char** argv) {
  loci::LimitHeapArenas();  // before any thread: the benches run a server (common/malloc_tuning.h)
  CLI::App app{"loci: semantic map server tools"};
  // Logs go to stderr: stdout carries the results (--json output must parse as JSON).
  spdlog::set_default_logger(spdlog::stderr_color_mt("loci"));
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error")->capture_default_str();
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });

  loci::cli::RegisterEvalCommands(app);
  loci::cli::RegisterSynthCommands(app);
  loci::cli::RegisterExportCommand(app);
  loci::cli::RegisterEvalObjectsCommand(app);
  loci::cli::RegisterEvalLoopsCommand(app);
  loci::cli::RegisterBenchIngestCommand(app);
  loci::cli::RegisterBenchLoadCommand(app);
  loci::cli::RegisterBenchFleetCommand(app);
  loci::cli::RegisterBenchReplicaCommand(app);
  loci::cli::RegisterBenchMergeCommand(app);
  loci::cli::RegisterReprocessCommand(app);
  loci::cli::RegisterMigrateCommand(app);
  loci::cli::RegisterBenchRestartCommand(app);
  loci::cli::RegisterBenchGraphCommand(app);
  loci::cli::RegisterDetectCommand(app);
  loci::cli::RegisterBenchDetectCommand(app);
  loci::cli::RegisterBenchTrackCommand(app);
  loci::cli::RegisterBenchQueryCommand(app);
  loci::cli::RegisterBenchPlaceCommand(app);
  loci::cli::RegisterAskCommand(app);
  loci::cli::RegisterObjectsCommands(app);
  loci::cli::RegisterBenchReportCommand(app);
  loci::cli::RegisterBenchObjectsCommand(app);
  loci::cli::RegisterBenchChangesCommand(app);

  loci::cli::AllowNoSubcommand(&app);
  CLI11_PARSE(app, argc, argv);
  if (const int rc = loci::cli::RequireLeafCommand(app)) return rc;
  return loci::cli::ExitCode();
}

// `loci`: the command line of the loci semantic map (evaluation, synthetic scenes, detection,
// exports, queries, benchmarks). `loci --help` lists the commands.
#include <spdlog/spdlog.h>

#include "cli/commands.h"

namespace loci::cli {
int& ExitCode() {
  static int code = 0;
  return code;
}

CLI::App* BenchGroup(CLI::App& app) {
  for (CLI::App* s : app.get_subcommands([](CLI::App* s) { return s->get_name() == "bench"; })) {
    return s;
  }
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks that print their figures");
  bench->require_subcommand(1);
  return bench;
}
}  // namespace loci::cli

int main(int argc, char** argv) {
  CLI::App app{"loci: semantic map server tools"};
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error")->capture_default_str();
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });

  loci::cli::RegisterEvalCommands(app);
  loci::cli::RegisterSynthCommands(app);
  loci::cli::RegisterExportCommand(app);
  loci::cli::RegisterEvalObjectsCommand(app);
  loci::cli::RegisterBenchIngestCommand(app);
  loci::cli::RegisterBenchLoadCommand(app);
  loci::cli::RegisterBenchMergeCommand(app);
  loci::cli::RegisterReprocessCommand(app);
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

  CLI11_PARSE(app, argc, argv);
  return loci::cli::ExitCode();
}

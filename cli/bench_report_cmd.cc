// `loci bench report --tum DIR [--out FILE.md] [--detections FILE] [--synth-objects objects.json]
//  [--max-frames N] [--title T]`: runs client + mapper in one process on a TUM folder (and the
// mapping again with ground-truth poses) and prints / writes the markdown evaluation report.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "cli/commands.h"
#include "cli/report/report_pipeline.h"

namespace loci::cli {
namespace {

struct BenchReportArgs {
  report::ReportOptions options;
  std::string out, title;
};

int RunBenchReport(BenchReportArgs a) {
  const std::string beside = a.options.tum_dir + "/objects_gt.json";
  if (a.options.objects_gt.empty() && std::filesystem::exists(beside)) {
    a.options.objects_gt = beside;
  }
  auto r = report::RunReport(a.options);
  if (!r.ok()) {
    std::cerr << "error: " << r.status().message() << "\n";
    return 1;
  }
  const std::string md = report::FormatMarkdown(
      *r, a.options, a.title.empty() ? "loci report: " + a.options.tum_dir : a.title);
  std::cout << md;
  if (!a.out.empty()) {
    std::ofstream f(a.out);
    f << md;
    if (!f) {
      std::cerr << "error: cannot write " << a.out << "\n";
      return 1;
    }
    std::cerr << "report written to " << a.out << "\n";
  }
  return 0;
}

}  // namespace

void RegisterBenchReportCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto a = std::make_shared<BenchReportArgs>();
  CLI::App* c = bench->add_subcommand(
      "report", "evaluation report on a TUM folder: trajectory, objects, map size, timing");
  c->add_option("--tum", a->options.tum_dir, "TUM RGB-D folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  c->add_option("--out", a->out, "also write the markdown here");
  c->add_option("--title", a->title, "report heading");
  c->add_option("--detections", a->options.detections,
                "detections.jsonl (e.g. a loci synth scene's); default: run the detector")
      ->check(CLI::ExistingFile);
  c->add_option("--synth-objects", a->options.synth_objects,
                "objects.json of a loci synth scene: true object count and centroid errors")
      ->check(CLI::ExistingFile);
  c->add_option("--objects-gt", a->options.objects_gt,
                 "hand-made object ground truth (objects_gt.json): precision, recall, count "
                 "error, X-on-Y answers; default: DIR/objects_gt.json when present")
      ->check(CLI::ExistingFile);
  c->add_option("--client-config", a->options.client_config, "client YAML")
      ->check(CLI::ExistingFile);
  c->add_option("--server-config", a->options.server_config, "server YAML")
      ->check(CLI::ExistingFile);
  c->add_option("--max-frames", a->options.max_frames, "stop after N frames (0 = all)");
  c->add_option("--match-max", a->options.match_max_m, "est-vs-GT-pose object pairing radius, m")
      ->capture_default_str();
  c->callback([a] { ExitCode() = RunBenchReport(*a); });
}

}  // namespace loci::cli

#include "cli/report/synth_objects_eval.h"

#include <chrono>

#include "cli/report/report_pipeline.h"
#include "common/config.h"
#include "common/objects_json.h"
#include "server/runtime/server_options.h"
#include "synth/sequence_writer.h"

namespace loci::report {
namespace {

// The classes the server maps, without the dynamic ones (the person walks through).
StatusOr<std::vector<std::string>> EvaluatedClasses(const std::string& server_config) {
  server::ServerOptions options;
  LOCI_RETURN_IF_ERROR(server_config.empty() ? options.LoadClasses()
                                             : options.FromYamlFile(server_config));
  std::vector<std::string> classes;
  for (const std::string& c : options.map.mapped_classes) {
    if (!options.map.IsDynamic(c)) classes.push_back(c);
  }
  return classes;
}

}  // namespace

StatusOr<SynthObjectsResult> EvaluateSynthObjects(const SynthObjectsOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  synth::SceneOptions scene;
  scene.seed = o.seed;
  scene.num_frames = o.frames;
  scene.num_objects = o.max_objects;
  scene.varied_layout = true;
  scene.depth_noise = true;
  scene.detector_noise = o.detector_noise;
  const std::string dir = absl::StrCat(o.work_dir, "/seed-", o.seed);
  LOCI_RETURN_IF_ERROR(synth::WriteSequence(scene, dir));

  ReportOptions ro;
  ro.tum_dir = dir;
  ro.detections = dir + "/detections.jsonl";
  ro.server_config = o.server_config;
  ro.progress = false;
  LOCI_ASSIGN_OR_RETURN(ReportResult report, RunReport(ro));
  LOCI_ASSIGN_OR_RETURN(GroundTruthScene truth, ReadObjectsJson(dir + "/objects.json"));
  server::ObjectEvalOptions eo;
  LOCI_ASSIGN_OR_RETURN(eo.classes, EvaluatedClasses(o.server_config));

  SynthObjectsResult r;
  r.seed = o.seed;
  r.eval = server::EvaluateObjects(report.objects_est, truth, eo);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace loci::report

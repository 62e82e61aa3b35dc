// The evaluation behind `loci bench report`: the client (odometry + detector + tracker) and the
// server's mapper run in one process on a TUM folder, the mapping a second time with ground-truth
// poses (paper 000 Table 4), and every figure the report prints is collected here.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/status.h"
#include "common/trajectory_eval.h"
#include "server/map/object_eval.h"
#include "cli/report/gt_eval.h"

namespace loci::report {

struct ReportOptions {
  std::string tum_dir;        // TUM RGB-D folder (rgb.txt, depth.txt, groundtruth.txt)
  std::string detections;     // detections.jsonl; "" = run the configured detector (YOLOX)
  std::string synth_objects;  // objects.json of a `loci synth` scene; "" = none
  // Hand-made ground truth (objects_gt.json of TUM fr1_rpy, cli/report/gt_eval.h); "" = none.
  std::string objects_gt;
  double gt_radius_m = 0.3;   // its matching radius, m
  std::string client_config;  // client YAML; "" = config/client.yaml
  std::string server_config;  // server YAML; "" = config/server.yaml
  int max_frames = 0;         // 0 = every frame
  double match_max_m = 0.5;   // est-vs-GT-pose object matching radius, m (class + nearest)
  bool progress = true;       // progress line on stderr
};

// One object of the estimated-pose map with its partner in the ground-truth-pose map.
struct ObjectPair {
  MapObject est;                // centroid in the ground-truth frame (estimate aligned by ATE)
  std::optional<MapObject> gt;  // nullopt: no same-class partner within match_max_m
  double error_m = 0;           // |est - gt| centroid distance
};

struct ReportResult {
  // Sequence and trajectory (client alone).
  size_t frames = 0, tracked = 0, keyframes = 0;
  std::optional<AteResult> ate;
  std::optional<RpeResult> rpe;
  // Objects (confirmed) of both runs, in the ground-truth world frame (the estimated map moved
  // there by the ATE alignment); pairs sorted by class then id.
  std::vector<MapObject> objects_est, objects_gt_poses;
  std::vector<ObjectPair> pairs;
  double mean_pair_error_m = 0;
  int matched_pairs = 0;
  // Against a synthetic scene's true objects (est map aligned to GT frame; and the GT-pose map).
  std::optional<server::ObjectEvalResult> synth_est, synth_gt_poses;
  // Against hand-made ground truth (ReportOptions::objects_gt).
  std::optional<GroundTruthEval> gt_eval;
  // The same with the map aligned by the camera orientations (--align orientations): for
  // sequences that turn in place, where the positions barely fix the alignment's rotation.
  std::optional<GroundTruthEval> gt_eval_orientations;
  // Map size (estimated-pose map).
  size_t cloud_points = 0;         // dense semantic cloud at the map's voxel
  size_t object_points = 0;        // ... of which labelled with an object
  size_t object_cloud_points = 0;  // the objects' own clouds (adaptive, finer voxels)
  size_t object_voxel_points = 0;  // the objects' clouds re-voxelised at the dense voxel
  uint64_t octomap_nodes = 0;
  size_t octomap_bytes = 0;
  double octomap_resolution_m = 0;
  // Timing (wall ms unless noted) and stream size.
  double track_ms_per_frame = 0;
  double detect_ms_per_keyframe = 0;      // 0 when detections come from a file
  double ingest_ms_per_keyframe = 0;      // Mapper::Integrate wall time (decode excluded)
  double ingest_cpu_ms_per_keyframe = 0;  // sum of the mapper's per-stage CPU times
  double bytes_per_keyframe = 0;          // encoded loci.v1.Keyframe (JPEG + PNG + detections)
  std::string detector_name;
};

StatusOr<ReportResult> RunReport(const ReportOptions& options);

// The markdown report (tables) of a result; `title` heads it.
std::string FormatMarkdown(const ReportResult& r, const ReportOptions& options,
                           const std::string& title);

}  // namespace loci::report

#include "cli/report/report_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <tuple>
#include <unordered_set>

#include "client/app/keyframe_stage.h"
#include "client/app/track_pipeline.h"
#include "client/streaming/keyframe_encoder.h"
#include "client/tracking/tracker.h"
#include "common/config.h"
#include "common/detections_io.h"
#include "common/objects_json.h"
#include "common/time.h"
#include "common/tum_io.h"
#include "detection/detection_config.h"
#include "detection/detector_options.h"
#include "detection/multi_object_tracker.h"
#include "server/map/mapper.h"
#include "server/map/voxel_key.h"
#include "server/service/query_adapter.h"
#include "server/runtime/server_options.h"

namespace loci::report {
namespace {

using Clock = std::chrono::steady_clock;
// Nearest ground-truth pose within max_dt_ns (TUM ground truth is at 100 Hz).
std::optional<SE3d> GroundTruthAt(const Trajectory& gt, int64_t t_ns, int64_t max_dt_ns) {
  const StampedPose* best = NearestByTime<StampedPose>(gt, t_ns, max_dt_ns);
  if (best == nullptr) return std::nullopt;
  return best->T_world_cam;
}

struct MapRun {
  std::unique_ptr<server::Mapper> mapper;
  double wall_ms = 0, cpu_ms = 0;
  size_t integrated = 0;
};

// Feeds the keyframes to a fresh mapper; poses from `pose_of` (nullopt = keyframe skipped).
template <typename PoseOf>
MapRun RunMapper(const server::MapOptions& map_options, const std::vector<KeyframeData>& kfs,
                 const PinholeCamera& camera, double depth_scale, PoseOf pose_of) {
  MapRun run;
  run.mapper = std::make_unique<server::Mapper>(map_options);
  int64_t id = 0;
  for (const KeyframeData& kf : kfs) {
    std::optional<SE3d> T_base_kf = pose_of(kf);
    if (!T_base_kf) continue;
    server::MapperKeyframe mk;
    mk.keyframe_id = ++id;
    mk.session_row = 1;
    mk.robot = "report";
    mk.t_ns = kf.t_ns;
    mk.T_base_kf = *T_base_kf;
    mk.camera = camera;
    mk.bgr = kf.bgr;
    kf.depth_u16.convertTo(mk.depth_m, CV_32F, 1.0 / depth_scale);
    mk.detections = kf.detections;
    if (kf.gravity_cam) {
      mk.has_gravity = true;
      mk.gravity_cam = *kf.gravity_cam;
    }
    const auto t0 = Clock::now();
    const server::StageTimes st = run.mapper->Integrate(mk);
    run.wall_ms += MsSince(t0);
    run.cpu_ms += st.products_ms + st.fusion_ms + st.cloud_ms + st.octomap_ms;
    ++run.integrated;
  }
  run.mapper->FlushOctomap();
  return run;
}

// Objects expressed in the ground-truth frame.
std::vector<MapObject> ToGroundTruthFrame(std::vector<MapObject> objects, const SE3d& T_gt_map) {
  for (MapObject& o : objects) o = Transformed(o, T_gt_map);
  return objects;
}

// Paper 000 Table 4: each estimated-pose object against the same-class object of the
// ground-truth-pose map (Hungarian on centroid distance within max_m, as `loci eval objects`).
std::vector<ObjectPair> PairObjects(const std::vector<MapObject>& est,
                                    const std::vector<MapObject>& gt, double max_m) {
  GroundTruthScene scene;
  for (const MapObject& g : gt) {
    GroundTruthObject o;
    o.id = g.id;
    o.name = std::to_string(g.id);
    o.class_name = g.class_name;
    o.centroid_m = g.centroid_m;
    scene.objects.push_back(std::move(o));
  }
  server::ObjectEvalOptions eo;
  eo.max_match_m = max_m;
  const server::ObjectEvalResult r = server::EvaluateObjects(est, scene, eo);
  std::vector<ObjectPair> pairs;
  for (const MapObject& e : est) {
    ObjectPair p;
    p.est = e;
    for (const server::ObjectMatch& m : r.matches) {
      if (m.object_id != e.id) continue;
      for (const MapObject& g : gt) {
        if (g.id == m.gt_id) p.gt = g;
      }
      p.error_m = m.centroid_error_m;
    }
    pairs.push_back(std::move(p));
  }
  std::sort(pairs.begin(), pairs.end(), [](const ObjectPair& a, const ObjectPair& b) {
    return std::tie(a.est.class_name, a.est.id) < std::tie(b.est.class_name, b.est.id);
  });
  return pairs;
}

// The estimated map against hand-made ground truth, with its own Ask (as `loci eval objects`).
StatusOr<GroundTruthEval> EvaluateHandMade(const ReportOptions& o, const server::Mapper& mapper,
                                           const Trajectory& groundtruth,
                                           bool align_by_orientations) {
  GroundTruthEvalInput in;
  in.align_by_orientations = align_by_orientations;
  LOCI_ASSIGN_OR_RETURN(in.gt, ReadObjectsJson(o.objects_gt));
  in.objects = mapper.Snapshot(/*confirmed_only=*/true);
  for (auto& [robot, traj] : mapper.Trajectories()) in.keyframes.push_back(traj);
  in.groundtruth = groundtruth;
  in.options.max_match_m = o.gt_radius_m;
  for (const auto& c : mapper.options().mapped_classes) {
    if (!mapper.options().IsDynamic(c)) in.options.classes.push_back(c);
  }
  server::QueryAdapterOptions query;
  server::UseMapClassPriors(mapper.options(), &query);
  auto adapter = std::make_shared<server::QueryAdapter>(std::move(query));
  auto source = std::make_shared<server::MapperSource>(mapper);
  in.ask = [adapter, source](const std::string& q) {
    loci::v1::AskRequest req;
    req.set_text(q);
    return server::AnswerOrError(adapter->Ask(req, *source));
  };
  return EvaluateAgainstGroundTruth(in);
}

// The client as loci-track runs it on recorded data (client/app/track_pipeline.h, detector
// synchronous), keeping the keyframes it would stream.
struct ClientRun {
  TrackPipelineResult track;
  std::vector<KeyframeData> keyframes;
  std::string detector_name;
  double detect_ms = 0, bytes = 0;
};

StatusOr<ClientRun> RunClient(const ReportOptions& o, const TumSequence& seq,
                              const TrackerOptions& topt) {
  ClientRun run;
  std::vector<FrameDetections> file_dets;
  std::unique_ptr<detection::Detector> detector;
  std::unique_ptr<detection::MultiObjectTracker> mot;
  LOCI_ASSIGN_OR_RETURN(auto dc,
                        detection::LoadDetectionConfig(detection::DefaultDetectionConfigPath()));
  if (!o.detections.empty()) {
    LOCI_ASSIGN_OR_RETURN(file_dets, ReadDetectionsJsonl(o.detections));
    run.detector_name = "file " + o.detections;
  } else {
    LOCI_ASSIGN_OR_RETURN(detector, detection::MakeDetector(dc.detector));
    run.detector_name = detector->Name();
    mot = std::make_unique<detection::MultiObjectTracker>(dc.tracker);
  }
  KeyframeMasking masking{dc.mask, topt.camera};
  masking.options.depth_scale = static_cast<float>(topt.depth_scale);
  KeyframeStage stage(
      std::move(detector), std::move(mot),
      [&](KeyframeData kf) {
        auto encoded = EncodeKeyframe(kf, static_cast<int64_t>(run.keyframes.size()), 90);
        if (encoded.ok()) run.bytes += static_cast<double>(encoded->ByteSizeLong());
        run.keyframes.push_back(std::move(kf));
        return absl::OkStatus();
      },
      /*capacity=*/0, masking);
  LOCI_ASSIGN_OR_RETURN(auto tracker, Tracker::Create(topt));
  TrackPipelineOptions po;
  po.max_frames = o.max_frames > 0 ? static_cast<size_t>(o.max_frames) : 0;
  po.progress = o.progress;
  po.camera = topt.camera;
  po.distortion = topt.distortion;
  LOCI_ASSIGN_OR_RETURN(run.track,
                        RunTrackPipeline(seq, tracker.get(), nullptr, file_dets, stage, po));
  LOCI_RETURN_IF_ERROR(stage.Finish());
  run.detect_ms = stage.detect_ms_total();
  return run;
}

// The client's trajectory against the ground truth (ATE, RPE); the ATE's alignment, or the
// identity without ground truth.
SE3d TrajectoryFigures(const TumSequence& seq, const Trajectory& traj, ReportResult* r) {
  SE3d T_gt_est = SE3d::Identity();
  if (seq.groundtruth.empty()) return T_gt_est;
  if (auto ate = ComputeAte(seq.groundtruth, traj); ate.ok()) {
    r->ate = *ate;
    T_gt_est = ate->T_gt_est;
  }
  if (auto rpe = ComputeRpe(seq.groundtruth, traj); rpe.ok()) r->rpe = *rpe;
  return T_gt_est;
}

// The dense cloud, the object-only cloud and the OctoMap of a mapping run.
void MapFigures(server::Mapper& mapper, double voxel_m, ReportResult* r) {
  // Both counts on the dense cloud's voxel grid (the object clouds themselves use finer,
  // adaptive voxels and are counted separately).
  for (const server::SemanticPoint& p : mapper.Cloud(0, {})) {
    ++r->cloud_points;
    r->object_points += p.object_id != 0;
  }
  // The object-only map of paper 000 Table 6: the union of the objects' clouds on the dense
  // cloud's voxel grid.
  std::unordered_set<server::VoxelKey> object_voxels;
  for (const MapObject& obj : r->objects_est) {
    std::vector<server::ColoredPoint> pts;
    mapper.GetObject(obj.id, &pts, nullptr);
    r->object_cloud_points += pts.size();
    for (const server::ColoredPoint& p : pts) {
      object_voxels.insert(server::KeyOf(p.p_m.cast<double>(), voxel_m));
    }
  }
  r->object_voxel_points = object_voxels.size();
  mapper.FlushOctomap();
  r->octomap_nodes = mapper.Stats().octomap_nodes;
  r->octomap_bytes = mapper.OctomapBt().size();
  r->octomap_resolution_m = mapper.OctomapResolution();
}

// The same keyframes mapped again with ground-truth poses, and each estimated object paired
// with one of that map's.
void GroundTruthPosesFigures(const server::ServerOptions& sopt, const TrackerOptions& topt,
                             const TumSequence& seq, const std::vector<KeyframeData>& kfs,
                             const ReportOptions& o, ReportResult* r) {
  if (o.progress) std::fprintf(stderr, "server: mapping again with ground-truth poses\n");
  MapRun gt = RunMapper(sopt.map, kfs, topt.camera, topt.depth_scale, [&](const KeyframeData& kf) {
    return GroundTruthAt(seq.groundtruth, kf.t_ns, 20'000'000);
  });
  // Its base frame is the ground-truth world.
  r->objects_gt_poses =
      ToGroundTruthFrame(gt.mapper->Snapshot(true), gt.mapper->MapFromBaseFrame().inverse());
  r->pairs = PairObjects(r->objects_est, r->objects_gt_poses, o.match_max_m);
  double sum = 0;
  for (const ObjectPair& p : r->pairs) {
    if (!p.gt) continue;
    sum += p.error_m;
    ++r->matched_pairs;
  }
  r->mean_pair_error_m = r->matched_pairs ? sum / r->matched_pairs : 0;
}

// Both maps against a synthetic scene's objects.json.
Status SynthFigures(const ReportOptions& o, bool have_groundtruth, ReportResult* r) {
  LOCI_ASSIGN_OR_RETURN(GroundTruthScene scene, ReadObjectsJson(o.synth_objects));
  server::ObjectEvalOptions eo;
  r->synth_est = server::EvaluateObjects(r->objects_est, scene, eo);
  if (!r->objects_gt_poses.empty() || have_groundtruth) {
    r->synth_gt_poses = server::EvaluateObjects(r->objects_gt_poses, scene, eo);
  }
  return absl::OkStatus();
}

}  // namespace

StatusOr<ReportResult> RunReport(const ReportOptions& o) {
  ReportResult r;
  LOCI_ASSIGN_OR_RETURN(TumSequence seq, LoadTumSequence(o.tum_dir));
  if (seq.frames.empty()) return absl::InvalidArgumentError(o.tum_dir + ": no frames");

  LOCI_ASSIGN_OR_RETURN(ClientConfig config, LoadClientConfig(o.client_config, o.tum_dir));
  const TrackerOptions& topt = config.tracker;
  server::ServerOptions sopt;
  LOCI_RETURN_IF_ERROR(sopt.FromYamlFile(
      o.server_config.empty() ? SourceDir() + "/config/server.yaml" : o.server_config));
  LOCI_ASSIGN_OR_RETURN(ClientRun client, RunClient(o, seq, topt));
  r.frames = client.track.frames;
  r.tracked = client.track.tracked;
  r.keyframes = client.keyframes.size();
  r.detector_name = client.detector_name;
  if (r.frames == 0 || client.keyframes.empty()) {
    return absl::FailedPreconditionError("no keyframes");
  }
  r.track_ms_per_frame = client.track.track_ms / r.frames;
  r.detect_ms_per_keyframe = client.detect_ms / r.keyframes;
  r.bytes_per_keyframe = client.bytes / r.keyframes;
  const std::vector<KeyframeData>& kfs = client.keyframes;
  const SE3d T_gt_est = TrajectoryFigures(seq, client.track.trajectory, &r);

  // Server: the mapping with the client's poses, then with ground-truth poses.
  if (o.progress)
    std::fprintf(stderr, "server: mapping %zu keyframes (estimated poses)\n", r.keyframes);
  MapRun est = RunMapper(sopt.map, kfs, topt.camera, topt.depth_scale,
                         [](const KeyframeData& kf) { return std::optional<SE3d>(kf.T_odom_cam); });
  r.ingest_ms_per_keyframe = est.wall_ms / std::max<size_t>(1, est.integrated);
  r.ingest_cpu_ms_per_keyframe = est.cpu_ms / std::max<size_t>(1, est.integrated);
  r.objects_est = est.mapper->Snapshot(true);
  MapFigures(*est.mapper, sopt.map.cloud.voxel_m, &r);

  // The estimated map in the ground-truth world: its map frame -> the client's odometry frame
  // (the mapper's base) -> the world by the ATE alignment.
  r.objects_est =
      ToGroundTruthFrame(r.objects_est, T_gt_est * est.mapper->MapFromBaseFrame().inverse());
  if (!o.objects_gt.empty()) {
    LOCI_ASSIGN_OR_RETURN(r.gt_eval, EvaluateHandMade(o, *est.mapper, seq.groundtruth, false));
    LOCI_ASSIGN_OR_RETURN(r.gt_eval_orientations,
                          EvaluateHandMade(o, *est.mapper, seq.groundtruth, true));
  }
  if (!seq.groundtruth.empty()) GroundTruthPosesFigures(sopt, topt, seq, kfs, o, &r);
  if (!o.synth_objects.empty()) {
    LOCI_RETURN_IF_ERROR(SynthFigures(o, !seq.groundtruth.empty(), &r));
  }
  return r;
}

}  // namespace loci::report

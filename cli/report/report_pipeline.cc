#include "cli/report/report_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <tuple>
#include <unordered_set>

#include "client/streaming/keyframe_encoder.h"
#include "client/tracking/tracker.h"
#include "common/config.h"
#include "common/detections_io.h"
#include "common/objects_json.h"
#include "common/tum_io.h"
#include "detection/detection_config.h"
#include "detection/detector_options.h"
#include "detection/multi_object_tracker.h"
#include "server/map/mapper.h"
#include "server/service/server_options.h"

namespace loci::report {
namespace {

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// A keyframe as the client would stream it, kept in memory for the two mapping runs.
struct ClientKeyframe {
  KeyframeData data;
};

// Nearest ground-truth pose within max_dt_ns (TUM ground truth is at 100 Hz).
std::optional<SE3d> GroundTruthAt(const Trajectory& gt, int64_t t_ns, int64_t max_dt_ns) {
  auto it = std::lower_bound(gt.begin(), gt.end(), t_ns,
                             [](const StampedPose& p, int64_t t) { return p.t_ns < t; });
  const StampedPose* best = nullptr;
  if (it != gt.end()) best = &*it;
  if (it != gt.begin()) {
    const StampedPose& prev = *std::prev(it);
    if (!best || t_ns - prev.t_ns < best->t_ns - t_ns) best = &prev;
  }
  if (!best || std::llabs(best->t_ns - t_ns) > max_dt_ns) return std::nullopt;
  return best->T_world_cam;
}

struct MapRun {
  std::unique_ptr<server::Mapper> mapper;
  double wall_ms = 0, cpu_ms = 0;
  size_t integrated = 0;
};

// Feeds the keyframes to a fresh mapper; poses from `pose_of` (nullopt = keyframe skipped).
template <typename PoseOf>
MapRun RunMapper(const server::MapOptions& map_options, const std::vector<ClientKeyframe>& kfs,
                 const PinholeCamera& camera, double depth_scale, PoseOf pose_of) {
  MapRun run;
  run.mapper = std::make_unique<server::Mapper>(map_options);
  int64_t id = 0;
  for (const ClientKeyframe& kf : kfs) {
    std::optional<SE3d> T_map_kf = pose_of(kf.data);
    if (!T_map_kf) continue;
    server::MapperKeyframe mk;
    mk.keyframe_id = ++id;
    mk.session_row = 1;
    mk.robot = "report";
    mk.t_ns = kf.data.t_ns;
    mk.T_map_kf = *T_map_kf;
    mk.camera = camera;
    mk.bgr = kf.data.bgr;
    kf.data.depth_u16.convertTo(mk.depth_m, CV_32F, 1.0 / depth_scale);
    mk.detections = kf.data.detections;
    if (kf.data.gravity_cam) {
      mk.has_gravity = true;
      mk.gravity_cam = *kf.data.gravity_cam;
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

// Objects expressed in the ground-truth frame: only the centroid is moved (the report compares
// centroids).
std::vector<MapObject> ToGroundTruthFrame(std::vector<MapObject> objects, const SE3d& T_gt_est) {
  for (MapObject& o : objects) o.centroid_m = T_gt_est * o.centroid_m;
  return objects;
}

// Paper 000 Table 4: each estimated-pose object against the nearest same-class object of the
// ground-truth-pose map (greedy by distance, one partner each).
std::vector<ObjectPair> PairObjects(const std::vector<MapObject>& est,
                                    const std::vector<MapObject>& gt, double max_m) {
  struct Cand {
    double d;
    size_t e, g;
  };
  std::vector<Cand> cands;
  for (size_t e = 0; e < est.size(); ++e) {
    for (size_t g = 0; g < gt.size(); ++g) {
      if (est[e].class_name != gt[g].class_name) continue;
      const double d = (est[e].centroid_m - gt[g].centroid_m).norm();
      if (d <= max_m) cands.push_back({d, e, g});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) { return a.d < b.d; });
  std::vector<ObjectPair> pairs(est.size());
  std::vector<bool> e_used(est.size()), g_used(gt.size());
  for (size_t e = 0; e < est.size(); ++e) pairs[e].est = est[e];
  for (const Cand& c : cands) {
    if (e_used[c.e] || g_used[c.g]) continue;
    e_used[c.e] = g_used[c.g] = true;
    pairs[c.e].gt = gt[c.g];
    pairs[c.e].error_m = c.d;
  }
  std::sort(pairs.begin(), pairs.end(), [](const ObjectPair& a, const ObjectPair& b) {
    return std::tie(a.est.class_name, a.est.id) < std::tie(b.est.class_name, b.est.id);
  });
  return pairs;
}

}  // namespace

StatusOr<ReportResult> RunReport(const ReportOptions& o) {
  ReportResult r;
  LOCI_ASSIGN_OR_RETURN(TumSequence seq, LoadTumSequence(o.tum_dir));
  if (seq.frames.empty()) return absl::InvalidArgumentError(o.tum_dir + ": no frames");

  TrackerOptions topt;
  const std::string client_cfg =
      o.client_config.empty() ? SourceDir() + "/config/client.yaml" : o.client_config;
  if (auto node = LoadYamlFile(client_cfg); node.ok()) {
    LOCI_RETURN_IF_ERROR(topt.FromYaml((*node)["tracker"]));
  } else if (!o.client_config.empty()) {
    return node.status();
  }
  if (auto classes = LoadYamlFile(SourceDir() + "/config/classes.yaml"); classes.ok()) {
    (void)topt.ClassWeightsFromYaml(*classes);
  }
  if (auto cam = LoadYamlFile(o.tum_dir + "/camera.yaml"); cam.ok()) {
    if (auto c = CameraFromYaml(*cam); c.ok()) topt.camera = *c;
  }
  server::ServerOptions sopt;
  LOCI_RETURN_IF_ERROR(sopt.FromYamlFile(
      o.server_config.empty() ? SourceDir() + "/config/server.yaml" : o.server_config));

  std::vector<FrameDetections> file_dets;
  std::unique_ptr<detection::Detector> detector;
  std::unique_ptr<detection::MultiObjectTracker> mot;
  if (!o.detections.empty()) {
    LOCI_ASSIGN_OR_RETURN(file_dets, ReadDetectionsJsonl(o.detections));
    r.detector_name = "file " + o.detections;
  } else {
    LOCI_ASSIGN_OR_RETURN(auto dc,
                          detection::LoadDetectionConfig(detection::DefaultDetectionConfigPath()));
    LOCI_ASSIGN_OR_RETURN(detector, detection::MakeDetector(dc.detector));
    r.detector_name = detector->Name();
    mot = std::make_unique<detection::MultiObjectTracker>(dc.tracker);
  }

  // Client: odometry on every frame, detector + tracker on keyframes (sequentially, so the
  // timings are per stage; loci-track runs the detector on its own thread).
  LOCI_ASSIGN_OR_RETURN(auto tracker, Tracker::Create(topt));
  const size_t n =
      o.max_frames > 0 ? std::min<size_t>(o.max_frames, seq.frames.size()) : seq.frames.size();
  Trajectory traj;
  std::vector<ClientKeyframe> kfs;
  std::vector<Detection2D> prior;  // last keyframe's boxes: the odometry's dynamic prior
  int64_t prior_t_ns = 0;
  double track_ms = 0, detect_ms = 0, bytes = 0;
  for (size_t i = 0; i < n; ++i) {
    const TumFrame& f = seq.frames[i];
    cv::Mat bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (bgr.empty() || depth.empty()) continue;
    ++r.frames;
    std::vector<Detection2D> dets;
    if (const FrameDetections* fd = FindDetections(file_dets, f.rgb_t_ns)) {
      dets = fd->detections;
    } else if (detector && f.rgb_t_ns - prior_t_ns <= 300'000'000) {
      dets = prior;
    }
    const auto t0 = Clock::now();
    StatusOr<FrameResult> fr = tracker->Track(bgr, depth, f.rgb_t_ns, &dets);
    track_ms += MsSince(t0);
    if (o.progress) {
      std::fprintf(stderr, "\rclient: frame %zu/%zu, keyframes %zu   ", i + 1, n, kfs.size());
    }
    if (!fr.ok() || !fr->tracked) continue;
    ++r.tracked;
    traj.push_back({f.rgb_t_ns, fr->T_odom_cam});
    if (!fr->keyframe) continue;
    ClientKeyframe kf;
    kf.data.t_ns = f.rgb_t_ns;
    kf.data.T_odom_cam = fr->T_odom_cam;
    kf.data.bgr = bgr;
    kf.data.depth_u16 = depth;
    kf.data.segment = fr->segment;
    if (auto g = GravityInCamAt(seq.accel, f.rgb_t_ns); g.ok()) kf.data.gravity_cam = *g;
    if (detector) {
      const auto td = Clock::now();
      auto d = detector->Detect(bgr, f.rgb_t_ns);
      if (d.ok()) {
        kf.data.detections = std::move(*d);
        mot->Update(bgr, &kf.data.detections);
      }
      detect_ms += MsSince(td);
      prior = kf.data.detections;
      prior_t_ns = f.rgb_t_ns;
    } else {
      kf.data.detections = dets;
    }
    auto encoded = EncodeKeyframe(kf.data, static_cast<int64_t>(kfs.size()), 90);
    if (encoded.ok()) bytes += static_cast<double>(encoded->ByteSizeLong());
    kfs.push_back(std::move(kf));
  }
  if (o.progress) std::fprintf(stderr, "\n");
  r.keyframes = kfs.size();
  if (r.frames == 0 || kfs.empty()) return absl::FailedPreconditionError("no keyframes");
  r.track_ms_per_frame = track_ms / r.frames;
  r.detect_ms_per_keyframe = detector ? detect_ms / kfs.size() : 0;
  r.bytes_per_keyframe = bytes / kfs.size();

  SE3d T_gt_est = SE3d::Identity();
  if (!seq.groundtruth.empty()) {
    if (auto ate = ComputeAte(seq.groundtruth, traj); ate.ok()) {
      r.ate = *ate;
      T_gt_est = ate->T_gt_est;
    }
    if (auto rpe = ComputeRpe(seq.groundtruth, traj); rpe.ok()) r.rpe = *rpe;
  }

  // Server: the mapping with the client's poses, then with ground-truth poses.
  if (o.progress)
    std::fprintf(stderr, "server: mapping %zu keyframes (estimated poses)\n", r.keyframes);
  MapRun est = RunMapper(sopt.map, kfs, topt.camera, topt.depth_scale,
                         [](const KeyframeData& kf) { return std::optional<SE3d>(kf.T_odom_cam); });
  r.ingest_ms_per_keyframe = est.wall_ms / std::max<size_t>(1, est.integrated);
  r.ingest_cpu_ms_per_keyframe = est.cpu_ms / std::max<size_t>(1, est.integrated);
  r.objects_est = est.mapper->Snapshot(true);
  // Both counts on the dense cloud's voxel grid (the object clouds themselves use finer,
  // adaptive voxels and are counted separately).
  for (const server::SemanticPoint& p : est.mapper->Cloud(0, {})) {
    ++r.cloud_points;
    r.object_points += p.object_id != 0;
  }
  // The object-only map of paper 000 Table 6: the union of the objects' clouds on the dense
  // cloud's voxel grid.
  const double voxel_m = sopt.map.cloud.voxel_m;
  std::unordered_set<uint64_t> object_voxels;
  for (const MapObject& obj : r.objects_est) {
    std::vector<server::ColoredPoint> pts;
    est.mapper->GetObject(obj.id, &pts, nullptr);
    r.object_cloud_points += pts.size();
    for (const server::ColoredPoint& p : pts) {
      const Eigen::Vector3d q = p.p_m.cast<double>() / voxel_m;
      const auto key = [](double v) { return static_cast<uint64_t>(std::floor(v) + (1 << 20)); };
      object_voxels.insert(key(q.x()) << 42 | key(q.y()) << 21 | key(q.z()));
    }
  }
  r.object_voxel_points = object_voxels.size();
  r.octomap_nodes = est.mapper->Stats().octomap_nodes;
  r.octomap_bytes = est.mapper->OctomapBt().size();
  r.octomap_resolution_m = est.mapper->OctomapResolution();

  const std::vector<MapObject> est_in_gt = ToGroundTruthFrame(r.objects_est, T_gt_est);
  if (!seq.groundtruth.empty()) {
    if (o.progress) std::fprintf(stderr, "server: mapping again with ground-truth poses\n");
    MapRun gt =
        RunMapper(sopt.map, kfs, topt.camera, topt.depth_scale, [&](const KeyframeData& kf) {
          return GroundTruthAt(seq.groundtruth, kf.t_ns, 20'000'000);
        });
    r.objects_gt_poses = gt.mapper->Snapshot(true);
    r.pairs = PairObjects(est_in_gt, r.objects_gt_poses, o.match_max_m);
    double sum = 0;
    for (const ObjectPair& p : r.pairs) {
      if (!p.gt) continue;
      sum += p.error_m;
      ++r.matched_pairs;
    }
    r.mean_pair_error_m = r.matched_pairs ? sum / r.matched_pairs : 0;
  }
  if (!o.synth_objects.empty()) {
    LOCI_ASSIGN_OR_RETURN(GroundTruthScene scene, ReadObjectsJson(o.synth_objects));
    server::ObjectEvalOptions eo;
    r.synth_est = server::EvaluateObjects(est_in_gt, scene, eo);
    if (!r.objects_gt_poses.empty() || !seq.groundtruth.empty()) {
      r.synth_gt_poses = server::EvaluateObjects(r.objects_gt_poses, scene, eo);
    }
  }
  return r;
}

}  // namespace loci::report

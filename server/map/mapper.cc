#include "server/map/mapper.h"

#include <algorithm>
#include <chrono>
#include <set>
#include <unordered_map>

#include "common/thread_name.h"
#include "server/map/keyframe_products.h"
#include "server/map/map_points.h"

namespace loci::server {
namespace {

double MsSince(double t0_cpu_ms) { return ThreadCpuMs() - t0_cpu_ms; }

// The fusion options with the flat-topped furniture of the observation masks and the class size
// limits.
FusionOptions FusionWithFlatTops(const MapOptions& options) {
  FusionOptions f = options.fusion;
  f.max_size_m = options.max_size_m;
  f.max_thickness_m = options.max_thickness_m;
  for (const auto& [class_name, days] : options.stays_days) f.stays_s[class_name] = days * 86400;
  f.top_classes = options.observation.mask.flat_top_classes;
  f.top_margin_m = options.observation.mask.flat_top_margin_m;
  return f;
}

}  // namespace

Mapper::Mapper(const MapOptions& options)
    : options_(options),
      objects_(FusionWithFlatTops(options), options.observation.voxel_m),
      cloud_(options.cloud.voxel_m),
      octomap_(options.octomap.enabled ? std::make_unique<LiveOctomap>(options.octomap)
                                       : nullptr) {}

Mapper::~Mapper() {
  octomap_.reset();  // first: a running rebuild stops (its product source may be gone)
}

Status Mapper::SetFirstObjectId(int64_t first_id) {
  std::lock_guard<std::mutex> lock(mu_);
  return objects_.SetFirstId(first_id);
}

void Mapper::SetEventListener(std::function<void(const std::vector<ObjectEventOut>&)> listener) {
  listener_ = std::move(listener);
}

namespace {

std::optional<Vec3d> GravityOf(const MapperKeyframe& kf) {
  if (kf.has_gravity && kf.gravity_cam.allFinite() && kf.gravity_cam.norm() > 0.5) {
    return kf.gravity_cam.normalized();
  }
  return std::nullopt;
}

void CopyProductTimes(const KeyframeProducts& products, StageTimes* times) {
  // CPU of both threads of the products stage (the dense cloud runs on a second thread).
  times->products_ms = products.labels_ms + products.objects_ms + products.backproject_ms +
                       products.voxel_ms + products.outlier_ms;
  times->labels_ms = products.labels_ms;
  times->objects_ms = products.objects_ms;
  times->backproject_ms = products.backproject_ms;
  times->voxel_ms = products.voxel_ms;
  times->outlier_ms = products.outlier_ms;
}

// One object observation moved into the map frame.
MapObservation ToMap(const ObjectObservation& o, const MapperKeyframe& kf,
                     const Eigen::Isometry3f& T_map_kf, bool centroid_from_box) {
  MapObservation m;
  m.session_row = kf.session_row;
  m.robot = kf.robot;
  m.keyframe_id = kf.keyframe_id;
  m.t_ns = kf.t_ns;
  m.track_id = o.track_id;
  m.class_name = o.class_name;
  m.score = o.score;
  m.points_m = ObservationPointsMap(o, T_map_kf);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
  for (const ColoredPoint& q : m.points_m) {
    sum += q.p_m.cast<double>();
    lo = lo.cwiseMin(q.p_m);
    hi = hi.cwiseMax(q.p_m);
  }
  // The same centroid definition as the fused objects (FusionOptions::centroid_from_box).
  m.centroid_m = centroid_from_box ? Eigen::Vector3d((0.5f * (lo + hi)).cast<double>())
                                   : Eigen::Vector3d(sum / static_cast<double>(o.cloud_kf.size()));
  m.half_size_m = 0.5 * (hi - lo).maxCoeff();
  m.range_m = (m.centroid_m - T_map_kf.translation().cast<double>()).norm();
  return m;
}

}  // namespace

void Mapper::AppendEvents(const std::vector<ObjectChange>& changes,
                          std::vector<ObjectEventOut>* events) const {
  std::vector<int64_t> ids;
  for (const ObjectChange& c : changes) {
    if (c.kind != ObjectChange::Kind::kRemoved) ids.push_back(objects_.Resolve(c.object_id));
  }
  std::vector<std::optional<MapObject>> snapshots = objects_.SnapshotsOf(ids);
  size_t next = 0;
  for (const ObjectChange& c : changes) {
    ObjectEventOut e;
    e.kind = c.kind;
    e.merged_from_id = c.merged_from_id;
    if (c.kind == ObjectChange::Kind::kRemoved) {  // gone: its last state, its own id
      e.object = c.removed_state;
      e.object.id = c.object_id;
      e.evidence_keyframe_ids = c.evidence_keyframe_ids;
      e.evidence_t_ns = c.evidence_t_ns;
      events->push_back(std::move(e));
      continue;
    }
    if (std::optional<MapObject>& snapshot = snapshots[next++]) e.object = std::move(*snapshot);
    e.object.id = objects_.Resolve(c.object_id);
    e.evidence_keyframe_ids = c.evidence_keyframe_ids;
    e.evidence_t_ns = c.evidence_t_ns;
    e.from_m = c.from_m;
    events->push_back(std::move(e));
  }
}

KeyframeProducts Mapper::BuildProducts(const MapperKeyframe& kf) const {
  return BuildKeyframeProducts(kf.bgr, kf.depth_m, kf.camera, kf.detections, options_,
                               GravityOf(kf));
}

StageTimes Mapper::Integrate(const MapperKeyframe& kf) { return Integrate(kf, BuildProducts(kf)); }

void Mapper::FixFirstFrame(const MapperKeyframe& kf, const std::optional<Vec3d>& gravity_cam) {
  evidence_.T_base_first_cam = kf.T_base_kf;
  FrameEvidence first = evidence_;
  if (gravity_cam) {
    first.gravity_sum_base = kf.T_base_kf.linear() * *gravity_cam;
    first.gravity_count = 1;
  }
  const UpEstimate up = EstimateUp(first, options_.frame);  // no points yet: no planes
  T_map_base_ = MapFromBase(kf.T_base_kf, up.up_base);
  frame_source_ = up.source;
  have_frame_ = true;
}

void Mapper::CollectFrameEvidence(const MapperKeyframe& kf, const std::optional<Vec3d>& gravity_cam,
                                  const KeyframeProducts& products) {
  if (gravity_cam) {
    evidence_.gravity_sum_base += kf.T_base_kf.linear() * *gravity_cam;
    ++evidence_.gravity_count;
  }
  const Eigen::Isometry3f T_base_kf = kf.T_base_kf.cast<float>();
  for (const auto& p : products.static_cloud_kf) {
    evidence_.points_base.push_back(T_base_kf * p.getVector3fMap());
  }
}

StageTimes Mapper::Integrate(const MapperKeyframe& kf, const KeyframeProducts& products) {
  StageTimes times;
  CopyProductTimes(products, &times);
  const std::optional<Vec3d> gravity_cam = GravityOf(kf);
  std::vector<ObjectEventOut> events;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!have_frame_) FixFirstFrame(kf, gravity_cam);  // the origin and a first up
    // In id order; a keyframe held back (an unaligned robot's) may arrive after newer ones.
    keyframe_poses_.insert(KeyframePoseAfter(kf.keyframe_id),
                           {kf.keyframe_id, kf.robot, kf.t_ns, kf.T_base_kf, {}, {}, kf.T_base_kf});
  }
  if (!frame_settled_) CollectFrameEvidence(kf, gravity_cam, products);
  Observed observed = IntegrateProducts(kf, products, &times, &events);
  {
    std::lock_guard<std::mutex> lock(mu_);
    KeepObserved(kf.keyframe_id, std::move(observed));
  }
  if (!frame_settled_) {
    MapperKeyframe kept = kf;  // the products carry what mapping needs; drop the images
    kept.bgr.release();
    kept.depth_m.release();
    kept.detections.clear();
    settling_.push_back({std::move(kept), products});
    if (static_cast<int>(settling_.size()) >= options_.frame.settle_keyframes) {
      SettleFrame(&events);
    }
  }
  if (listener_ && !events.empty()) listener_(events);
  return times;
}

std::vector<Mapper::KeyframePose>::iterator Mapper::KeyframePoseAfter(int64_t keyframe_id) {
  return std::upper_bound(keyframe_poses_.begin(), keyframe_poses_.end(), keyframe_id,
                          [](int64_t id, const KeyframePose& k) { return id < k.keyframe_id; });
}

std::vector<Mapper::KeyframePose>::iterator Mapper::FindKeyframePose(int64_t keyframe_id) {
  auto it = std::lower_bound(keyframe_poses_.begin(), keyframe_poses_.end(), keyframe_id,
                             [](const KeyframePose& k, int64_t id) { return k.keyframe_id < id; });
  return it != keyframe_poses_.end() && it->keyframe_id == keyframe_id ? it : keyframe_poses_.end();
}

void Mapper::SettleFrame(std::vector<ObjectEventOut>* events) {
  const UpEstimate up = EstimateUp(evidence_, options_.frame);
  if (options_.octomap.enabled) FlushOctomap();
  {
    std::lock_guard<std::mutex> lock(mu_);
    T_map_base_ = MapFromBase(evidence_.T_base_first_cam, up.up_base);
    frame_source_ = up.source;
    frame_settled_ = true;
    // Re-derive: everything mapped so far moves to the settled frame.
    for (const MapObject& o : objects_.Snapshot(false)) {
      ObjectEventOut e;
      e.kind = ObjectChange::Kind::kRemoved;
      e.object = o;
      events->push_back(std::move(e));
    }
    objects_.Clear();
    cloud_ = SemanticCloud(options_.cloud.voxel_m);
    gravity_sum_map_.setZero();
    gravity_count_ = 0;
    latest_poses_.clear();
    stats_.keyframes = 0;
  }
  if (octomap_) octomap_->Clear();
  std::vector<Settling> settling = std::move(settling_);
  settling_.clear();
  evidence_.points_base.clear();
  evidence_.points_base.shrink_to_fit();
  for (size_t i = 0; i < settling.size(); ++i) {
    StageTimes ignored;
    Observed observed =
        IntegrateProducts(settling[i].keyframe, settling[i].products, &ignored, events);
    std::lock_guard<std::mutex> lock(mu_);
    KeepObserved(settling[i].keyframe.keyframe_id, std::move(observed));
  }
}

void Mapper::KeepObserved(int64_t keyframe_id, Observed observed) {
  auto pose = FindKeyframePose(keyframe_id);
  if (pose == keyframe_poses_.end()) return;  // no such keyframe: nothing to keep
  pose->observation_object_ids = std::move(observed.object_ids);
  pose->observation_centroids_kf_m = std::move(observed.centroids_kf_m);
}

Mapper::Observed Mapper::IntegrateProducts(const MapperKeyframe& kf,
                                           const KeyframeProducts& products, StageTimes* times,
                                           std::vector<ObjectEventOut>* events) {
  SE3d T_map_kf;
  {
    std::lock_guard<std::mutex> lock(mu_);
    T_map_kf = T_map_base_ * kf.T_base_kf;
  }
  const Eigen::Isometry3f T_map_kf_f = T_map_kf.cast<float>();
  std::vector<MapObservation> observations;
  observations.reserve(products.observations.size());
  for (const ObjectObservation& o : products.observations) {
    observations.push_back(ToMap(o, kf, T_map_kf_f, /*centroid_from_box=*/true));
  }
  Observed observed;
  const SE3d T_kf_map = T_map_kf.inverse();
  for (const MapObservation& o : observations) {
    observed.centroids_kf_m.push_back((T_kf_map * o.centroid_m).cast<float>());
  }
  std::vector<int64_t>& ids = observed.object_ids;
  std::vector<SemanticPoint> points;
  {
    std::lock_guard<std::mutex> lock(mu_);
    double t0 = ThreadCpuMs();
    std::vector<ObjectChange> changes;
    ids = objects_.Integrate(observations, &changes);
    const KeyframeView view{&kf.camera, &products.visibility_depth_m, products.depth_stride,
                            T_map_kf.inverse(), &products.detection_boxes};
    objects_.ObserveView(kf.keyframe_id, kf.t_ns, view, ids, &changes);
    AppendEvents(changes, events);
    times->fusion_ms = MsSince(t0);

    t0 = ThreadCpuMs();
    points = StaticPointsMap(products, T_map_kf_f, ids);
    cloud_.Add(points);
    times->cloud_ms = MsSince(t0);

    if (const std::optional<Vec3d> g = GravityOf(kf)) {
      gravity_sum_map_ += T_map_kf.linear() * *g;
      ++gravity_count_;
    }
    RobotPose& pose = latest_poses_[kf.robot];
    if (kf.t_ns >= pose.t_ns) pose = {kf.t_ns, T_map_kf};
    ++stats_.keyframes;
  }
  if (octomap_) {
    OctomapScan scan = ThinScan(points, T_map_kf.translation(), options_.octomap.resolution_m);
    scan.keyframe_id = kf.keyframe_id;
    octomap_->Push(std::move(scan));
  }
  AddTimes(*times);
  return observed;
}

void Mapper::AddTimes(const StageTimes& times) {
  std::lock_guard<std::mutex> lock(mu_);
  stats_.total.products_ms += times.products_ms;
  stats_.total.fusion_ms += times.fusion_ms;
  stats_.total.cloud_ms += times.cloud_ms;
  stats_.total.labels_ms += times.labels_ms;
  stats_.total.objects_ms += times.objects_ms;
  stats_.total.backproject_ms += times.backproject_ms;
  stats_.total.voxel_ms += times.voxel_ms;
  stats_.total.outlier_ms += times.outlier_ms;
}

std::vector<MapObject> Mapper::Snapshot(bool confirmed_only) const {
  std::lock_guard<std::mutex> lock(mu_);
  return objects_.Snapshot(confirmed_only);
}

std::vector<MapObject> Mapper::Removed() const {
  std::lock_guard<std::mutex> lock(mu_);
  return objects_.Removed();
}

std::optional<MapObject> Mapper::GetObject(int64_t id, std::vector<ColoredPoint>* cloud_m,
                                           std::vector<int64_t>* keyframe_ids) const {
  std::lock_guard<std::mutex> lock(mu_);
  const FusedObject* obj = objects_.Find(objects_.Resolve(id));
  if (obj == nullptr) return objects_.RemovedOf(objects_.Resolve(id));  // gone: its last state
  if (cloud_m) *cloud_m = obj->Cloud();
  if (keyframe_ids) *keyframe_ids = obj->keyframes();
  return objects_.SnapshotOf(obj->id());
}

std::vector<SemanticPoint> Mapper::Cloud(double voxel_m,
                                         const std::vector<std::string>& classes) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto resolve = [this](int64_t id) { return objects_.Resolve(id); };
  auto keep = [&](int64_t id) {
    if (classes.empty()) return true;
    std::string cls = "background";
    if (id != 0) {
      const FusedObject* obj = objects_.Find(id);
      cls = obj ? obj->labels().Argmax() : "background";
    }
    return std::find(classes.begin(), classes.end(), cls) != classes.end();
  };
  return cloud_.Points(voxel_m <= 0 ? cloud_.voxel_m() : voxel_m, resolve, keep);
}

std::string Mapper::OctomapBt(bool wait_for_rebuild) const {
  if (!octomap_) return {};
  octomap_->Flush(wait_for_rebuild);
  return octomap_->SerializeBt();
}

std::vector<Eigen::Vector3d> Mapper::OccupiedCenters() const {
  if (!octomap_) return {};
  octomap_->Flush(true);
  return octomap_->OccupiedCenters();
}

void Mapper::FlushOctomap(bool wait_for_rebuild) const {
  if (octomap_) octomap_->Flush(wait_for_rebuild);
}

bool Mapper::OctomapRebuilding() const { return octomap_ && octomap_->Rebuilding(); }

std::optional<Vec3d> Mapper::UpDirection() const {
  std::lock_guard<std::mutex> lock(mu_);
  if (gravity_count_ == 0 || gravity_sum_map_.norm() < 1e-9) return std::nullopt;
  return Vec3d(-gravity_sum_map_.normalized());
}

std::string Mapper::FrameSource() const {
  std::lock_guard<std::mutex> lock(mu_);
  return frame_source_;
}

bool Mapper::FrameSettled() const {
  std::lock_guard<std::mutex> lock(mu_);
  return frame_settled_;
}

SE3d Mapper::MapFromBaseFrame() const {
  std::lock_guard<std::mutex> lock(mu_);
  return T_map_base_;
}

std::map<std::string, Trajectory> Mapper::Trajectories() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::map<std::string, Trajectory> out;
  for (const KeyframePose& k : keyframe_poses_) {
    out[k.robot].push_back({k.t_ns, T_map_base_ * k.T_base_kf});
  }
  for (auto& [robot, traj] : out) {
    std::stable_sort(traj.begin(), traj.end(),
                     [](const StampedPose& a, const StampedPose& b) { return a.t_ns < b.t_ns; });
  }
  return out;
}

std::vector<Mapper::KeyframePoseUpdate> Mapper::KeyframePoses() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<KeyframePoseUpdate> out;
  out.reserve(keyframe_poses_.size());
  for (const KeyframePose& k : keyframe_poses_) out.push_back({k.keyframe_id, k.T_base_kf});
  return out;
}

size_t Mapper::KeyframeCount() const {
  std::lock_guard<std::mutex> lock(mu_);
  return keyframe_poses_.size();
}

bool Mapper::HasKeyframe(int64_t keyframe_id) const {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it =
      std::lower_bound(keyframe_poses_.begin(), keyframe_poses_.end(), keyframe_id,
                       [](const KeyframePose& k, int64_t id) { return k.keyframe_id < id; });
  return it != keyframe_poses_.end() && it->keyframe_id == keyframe_id;
}

std::map<std::string, RobotPose> Mapper::LatestPoses() const {
  std::lock_guard<std::mutex> lock(mu_);
  return latest_poses_;
}

MapperStats Mapper::Stats() const {
  MapperStats s;
  {
    std::lock_guard<std::mutex> lock(mu_);
    s = stats_;
    s.objects = objects_.size();
    s.confirmed_objects = objects_.confirmed_count();
    s.cloud_points = cloud_.size();
  }
  if (octomap_) {
    s.octomap_nodes = octomap_->node_count();
    s.octomap_pending_scans = octomap_->pending_scans();
    s.total.octomap_ms = octomap_->cpu_ms();
  }
  return s;
}

}  // namespace loci::server

// The checkpoint of the derived map (loci.store.v1.MapperCheckpoint): the state of the mapper,
// its objects, cloud and OctoMap, written on the mapping thread and loaded into a fresh mapper
// on start, so a restart re-derives only the keyframes after it.
#include "loci/store/v1/map_state.pb.h"
#include "server/map/mapper.h"

namespace loci::server {
namespace {

void ToState(const SE3d& T, loci::store::v1::Pose* out) {
  const Eigen::Quaterniond q(T.linear());
  out->set_tx(T.translation().x());
  out->set_ty(T.translation().y());
  out->set_tz(T.translation().z());
  out->set_qw(q.w());
  out->set_qx(q.x());
  out->set_qy(q.y());
  out->set_qz(q.z());
}

SE3d FromState(const loci::store::v1::Pose& in) {
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::Quaterniond(in.qw(), in.qx(), in.qy(), in.qz()).normalized().toRotationMatrix();
  T.translation() = Vec3d(in.tx(), in.ty(), in.tz());
  return T;
}

}  // namespace

void LabelDistribution::SaveState(loci::store::v1::LabelState* out) const {
  for (const auto& [name, lp] : log_p_) (*out->mutable_log_p())[name] = lp;
  out->set_log_p_unseen(log_p_unseen_);
}

void LabelDistribution::LoadState(const loci::store::v1::LabelState& in) {
  log_p_.clear();
  for (const auto& [name, lp] : in.log_p()) log_p_[name] = lp;
  log_p_unseen_ = in.log_p_unseen();
}

void FusedObject::SaveState(loci::store::v1::FusedObjectState* out) const {
  out->set_id(id_);
  for (const auto& [key, v] : voxels_) {
    out->add_voxel_key(key);
    for (int i = 0; i < 3; ++i) out->add_voxel_sum_m(v.sum_m[i]);
    for (int i = 0; i < 3; ++i) out->add_voxel_rgb_sum(v.rgb_sum[i]);
    out->add_voxel_count(v.count);
  }
  for (const auto& [key, c] : cells_) {
    out->add_cell_key(key);
    out->add_cell_observations(c.observations);
    out->add_cell_last(c.last);
    out->add_cell_label_pairs(static_cast<uint32_t>(c.by_label.size()));
    for (const auto& [label, n] : c.by_label) {
      out->add_cell_label(label);
      out->add_cell_label_observations(n);
    }
  }
  for (const std::string& l : point_labels_) out->add_point_label(l);
  for (uint32_t n : label_point_observations_) out->add_label_point_observations(n);
  labels_.SaveState(out->mutable_labels());
  out->set_point_observations(point_observations_);
  out->set_first_seen_ns(first_seen_ns_);
  out->set_last_seen_ns(last_seen_ns_);
  for (const std::string& r : robots_) out->add_robots(r);
  out->set_last_robot(last_robot_);
  for (int64_t kf : keyframes_) out->add_keyframes(kf);
  for (const auto& [session, track] : tracks_) {
    out->add_track_session(session);
    out->add_track_id(track);
  }
  for (int64_t kf : keyframes_) {
    const auto it = hit_t_ns_.find(kf);
    out->add_hit_t_ns(it == hit_t_ns_.end() ? 0 : it->second);
  }
  out->set_confirmed(confirmed_);
  out->set_misses(misses());
  for (const auto& [kf, t_ns] : missed_t_ns_) {
    out->add_missed_keyframes(kf);
    out->add_missed_t_ns(t_ns);
  }
  out->set_nearest_range_m(nearest_range_m_);
}

Status FusedObject::LoadCells(const loci::store::v1::FusedObjectState& in) {
  const auto bad = [&] {
    return absl::DataLossError(
        absl::StrCat("checkpoint: object ", in.id(), "'s cells are inconsistent"));
  };
  if (in.point_label_size() != in.label_point_observations_size() ||
      in.cell_label_pairs_size() != in.cell_key_size() ||
      in.cell_label_size() != in.cell_label_observations_size()) {
    return bad();
  }
  point_labels_ = {in.point_label().begin(), in.point_label().end()};
  label_point_observations_ = {in.label_point_observations().begin(),
                               in.label_point_observations().end()};
  int pair = 0;
  for (int i = 0; i < in.cell_key_size(); ++i) {
    Cell& cell = cells_[in.cell_key(i)];
    cell.observations = in.cell_observations(i);
    cell.last = in.cell_last(i);
    for (uint32_t k = 0; k < in.cell_label_pairs(i); ++k, ++pair) {
      if (pair >= in.cell_label_size() ||
          in.cell_label(pair) >= static_cast<uint32_t>(point_labels_.size())) {
        return bad();
      }
      cell.by_label.emplace_back(static_cast<uint16_t>(in.cell_label(pair)),
                                 in.cell_label_observations(pair));
    }
  }
  return pair == in.cell_label_size() ? absl::OkStatus() : bad();
}

Status FusedObject::LoadState(const loci::store::v1::FusedObjectState& in) {
  const int nv = in.voxel_key_size();
  if (in.voxel_sum_m_size() != 3 * nv || in.voxel_rgb_sum_size() != 3 * nv ||
      in.voxel_count_size() != nv || in.cell_observations_size() != in.cell_key_size() ||
      in.cell_last_size() != in.cell_key_size() || in.track_id_size() != in.track_session_size()) {
    return absl::DataLossError(absl::StrCat("checkpoint: object ", in.id(), " is inconsistent"));
  }
  for (int i = 0; i < nv; ++i) {
    Voxel& v = voxels_[in.voxel_key(i)];
    v.sum_m = Vec3d(in.voxel_sum_m(3 * i), in.voxel_sum_m(3 * i + 1), in.voxel_sum_m(3 * i + 2));
    v.rgb_sum =
        Vec3d(in.voxel_rgb_sum(3 * i), in.voxel_rgb_sum(3 * i + 1), in.voxel_rgb_sum(3 * i + 2));
    v.count = in.voxel_count(i);
  }
  LOCI_RETURN_IF_ERROR(LoadCells(in));
  labels_.LoadState(in.labels());
  point_observations_ = in.point_observations();
  first_seen_ns_ = in.first_seen_ns();
  last_seen_ns_ = in.last_seen_ns();
  robots_ = {in.robots().begin(), in.robots().end()};
  last_robot_ = in.last_robot();
  keyframes_ = {in.keyframes().begin(), in.keyframes().end()};
  for (int i = 0; i < in.track_id_size(); ++i) tracks_.insert({in.track_session(i), in.track_id(i)});
  confirmed_ = in.confirmed();
  if (in.missed_keyframes_size() != static_cast<int>(in.misses()) ||
      in.missed_t_ns_size() != in.missed_keyframes_size() ||
      in.hit_t_ns_size() != in.keyframes_size()) {
    // Checkpoints without the evidence's times are replayed.
    return absl::FailedPreconditionError(absl::StrCat(
        "the map checkpoint of object ", in.id(), " lacks the times of its hits and misses"));
  }
  for (int i = 0; i < in.keyframes_size(); ++i) hit_t_ns_[in.keyframes(i)] = in.hit_t_ns(i);
  for (int i = 0; i < in.missed_keyframes_size(); ++i) {
    missed_t_ns_[in.missed_keyframes(i)] = in.missed_t_ns(i);
  }
  nearest_range_m_ = in.nearest_range_m();
  RecomputeGeometry();
  return absl::OkStatus();
}

namespace {

void SaveVec3(const Eigen::Vector3d& v, loci::store::v1::Vec3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

Eigen::Vector3d LoadVec3(const loci::store::v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

void SaveHistory(const std::vector<ObjectPlaceChange>& history,
                 loci::store::v1::PlaceHistoryState* out) {
  for (const ObjectPlaceChange& c : history) {
    loci::store::v1::PlaceChangeState* s = out->add_changes();
    s->set_kind(static_cast<int32_t>(c.kind));
    s->set_t_ns(c.t_ns);
    SaveVec3(c.centroid_m, s->mutable_centroid_m());
    SaveVec3(c.from_m, s->mutable_from_m());
    for (int64_t id : c.evidence_keyframe_ids) s->add_evidence_keyframe_ids(id);
  }
}

StatusOr<std::vector<ObjectPlaceChange>> LoadHistory(const loci::store::v1::PlaceHistoryState& in) {
  std::vector<ObjectPlaceChange> out;
  for (const auto& s : in.changes()) {
    if (s.kind() < 0 || s.kind() > static_cast<int32_t>(ObjectPlaceChange::Kind::kRemoved)) {
      return absl::DataLossError("checkpoint: an object's history has an unknown change kind");
    }
    ObjectPlaceChange c;
    c.kind = static_cast<ObjectPlaceChange::Kind>(s.kind());
    c.t_ns = s.t_ns();
    c.centroid_m = LoadVec3(s.centroid_m());
    c.from_m = LoadVec3(s.from_m());
    c.evidence_keyframe_ids.assign(s.evidence_keyframe_ids().begin(),
                                   s.evidence_keyframe_ids().end());
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

void ObjectMap::SaveState(loci::store::v1::ObjectMapState* out) const {
  out->set_next_id(next_id_);
  for (const auto& [id, object] : objects_) object.SaveState(out->add_objects());
  for (const auto& [id, object] : gone_) object.SaveState(out->add_gone());
  for (const auto& [from, to] : merged_into_) (*out->mutable_merged_into())[from] = to;
  for (const auto& [id, history] : history_) SaveHistory(history, &(*out->mutable_history())[id]);
}

Status ObjectMap::LoadState(const loci::store::v1::ObjectMapState& in) {
  Clear();
  next_id_ = in.next_id();
  for (const auto& o : in.objects()) {
    FusedObject object = NewObject(o.id());
    LOCI_RETURN_IF_ERROR(object.LoadState(o));
    objects_.emplace(o.id(), std::move(object));
  }
  for (const auto& o : in.gone()) {
    FusedObject object = NewObject(o.id());
    LOCI_RETURN_IF_ERROR(object.LoadState(o));
    gone_.emplace(o.id(), std::move(object));
  }
  for (const auto& [from, to] : in.merged_into()) merged_into_[from] = to;
  for (const auto& [id, h] : in.history()) {
    StatusOr<std::vector<ObjectPlaceChange>> history = LoadHistory(h);
    if (!history.ok()) return history.status();
    history_[id] = std::move(*history);
  }
  return absl::OkStatus();
}

void SemanticCloud::SaveState(loci::store::v1::SemanticCloudState* out) const {
  for (const auto& [key, v] : voxels_) {
    out->add_key(key);
    for (int i = 0; i < 3; ++i) out->add_sum_m(v.sum_m[i]);
    for (int i = 0; i < 3; ++i) out->add_rgb_sum(v.rgb_sum[i]);
    out->add_count(v.count);
    out->add_object_id(v.object_id);
    out->add_votes(v.votes);
  }
}

Status SemanticCloud::LoadState(const loci::store::v1::SemanticCloudState& in) {
  const int n = in.key_size();
  if (in.sum_m_size() != 3 * n || in.rgb_sum_size() != 3 * n || in.count_size() != n ||
      in.object_id_size() != n || in.votes_size() != n) {
    return absl::DataLossError("checkpoint: the semantic cloud is inconsistent");
  }
  voxels_.clear();
  voxels_.reserve(n);
  for (int i = 0; i < n; ++i) {
    Voxel& v = voxels_[in.key(i)];
    v.sum_m = Eigen::Vector3f(in.sum_m(3 * i), in.sum_m(3 * i + 1), in.sum_m(3 * i + 2));
    v.rgb_sum = Eigen::Vector3f(in.rgb_sum(3 * i), in.rgb_sum(3 * i + 1), in.rgb_sum(3 * i + 2));
    v.count = in.count(i);
    v.object_id = in.object_id(i);
    v.votes = in.votes(i);
  }
  return absl::OkStatus();
}

std::string Mapper::SaveCheckpoint() const {
  if (!frame_settled_) return {};
  if (options_.octomap.enabled) FlushOctomap();
  loci::store::v1::MapperCheckpoint out;
  out.set_fingerprint(options_.MapFingerprint());
  {
    std::lock_guard<std::mutex> lock(mu_);
    out.set_last_keyframe_id(keyframe_poses_.empty() ? 0 : keyframe_poses_.back().keyframe_id);
    ToState(T_map_base_, out.mutable_t_map_base());
    out.set_frame_source(frame_source_);
    objects_.SaveState(out.mutable_objects());
    cloud_.SaveState(out.mutable_cloud());
    out.mutable_gravity_sum_map()->set_x(gravity_sum_map_.x());
    out.mutable_gravity_sum_map()->set_y(gravity_sum_map_.y());
    out.mutable_gravity_sum_map()->set_z(gravity_sum_map_.z());
    out.set_gravity_count(gravity_count_);
    for (const KeyframePose& k : keyframe_poses_) {
      auto* ks = out.add_keyframes();
      ks->set_keyframe_id(k.keyframe_id);
      ks->set_robot(k.robot);
      ks->set_t_ns(k.t_ns);
      ToState(k.T_base_kf, ks->mutable_t_base_kf());
      // Only where a move within the tolerance left the scan (absent: T_base_kf).
      if (k.T_base_kf_octomap.matrix() != k.T_base_kf.matrix()) {
        ToState(k.T_base_kf_octomap, ks->mutable_t_base_kf_octomap());
      }
      for (int64_t id : k.observation_object_ids) ks->add_observation_object_id(id);
      for (const Eigen::Vector3f& c : k.observation_centroids_kf_m) {
        for (int axis = 0; axis < 3; ++axis) ks->add_observation_centroid_kf_m(c[axis]);
      }
    }
    for (const auto& [robot, pose] : latest_poses_) {
      auto& rp = (*out.mutable_latest_poses())[robot];
      rp.set_t_ns(pose.t_ns);
      ToState(pose.T_map_cam, rp.mutable_t_map_cam());
    }
    out.set_keyframe_count(stats_.keyframes);
  }
  if (octomap_) out.set_octomap_ot(octomap_->SerializeState());
  return out.SerializeAsString();
}

Status Mapper::LoadCheckpoint(const std::string& bytes) {
  loci::store::v1::MapperCheckpoint in;
  if (!in.ParseFromString(bytes)) return absl::DataLossError("the map checkpoint does not parse");
  if (in.fingerprint() != options_.MapFingerprint()) {
    return absl::FailedPreconditionError(absl::StrCat("the map checkpoint was made with options ",
                                                      in.fingerprint(), ", not ",
                                                      options_.MapFingerprint()));
  }
  if (octomap_ && !in.octomap_ot().empty()) {
    LOCI_RETURN_IF_ERROR(octomap_->LoadState(in.octomap_ot()));
  }
  std::lock_guard<std::mutex> lock(mu_);
  LOCI_RETURN_IF_ERROR(objects_.LoadState(in.objects()));
  LOCI_RETURN_IF_ERROR(cloud_.LoadState(in.cloud()));
  T_map_base_ = FromState(in.t_map_base());
  frame_source_ = in.frame_source();
  have_frame_ = frame_settled_ = true;
  gravity_sum_map_ = Vec3d(in.gravity_sum_map().x(), in.gravity_sum_map().y(),
                           in.gravity_sum_map().z());
  gravity_count_ = in.gravity_count();
  keyframe_poses_.clear();
  keyframe_poses_.reserve(in.keyframes_size());
  for (const auto& k : in.keyframes()) {
    const SE3d T_base_kf = FromState(k.t_base_kf());
    keyframe_poses_.push_back(
        {k.keyframe_id(),
         k.robot(),
         k.t_ns(),
         T_base_kf,
         {k.observation_object_id().begin(), k.observation_object_id().end()},
         {},
         k.has_t_base_kf_octomap() ? FromState(k.t_base_kf_octomap()) : T_base_kf});
    const auto& c = k.observation_centroid_kf_m();
    for (int i = 0; i + 2 < c.size(); i += 3) {
      keyframe_poses_.back().observation_centroids_kf_m.emplace_back(c[i], c[i + 1], c[i + 2]);
    }
  }
  latest_poses_.clear();
  for (const auto& [robot, rp] : in.latest_poses()) {
    latest_poses_[robot] = {rp.t_ns(), FromState(rp.t_map_cam())};
  }
  stats_.keyframes = in.keyframe_count();
  return absl::OkStatus();
}

int64_t Mapper::last_keyframe_id() const {
  std::lock_guard<std::mutex> lock(mu_);
  return keyframe_poses_.empty() ? 0 : keyframe_poses_.back().keyframe_id;
}

}  // namespace loci::server

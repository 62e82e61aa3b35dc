// Mapper::UpdateKeyframePoses: keyframes whose poses changed (loop closure, robot alignment)
// move their contribution to the objects and the cloud: what they added at the old pose comes
// out, the same products go back in at the new pose, and moved objects that now coincide with
// others merge. Only the moved keyframes' products are read. Mapper::SeenCentroids: what the
// pose graph's object landmarks need of the map.
#include <algorithm>
#include <future>

#include "common/task_pool.h"
#include "server/map/map_points.h"
#include "server/map/mapper.h"

namespace loci::server {

StatusOr<size_t> Mapper::UpdateKeyframePoses(const std::vector<KeyframePoseUpdate>& updates,
                                             const ProductSource& source, bool rebuild_octomap) {
  if (!frame_settled_) {
    return absl::FailedPreconditionError(
        "keyframe poses can change once the map frame is settled (the first keyframes)");
  }
  std::vector<size_t> index;  // into keyframe_poses_, per update
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (const KeyframePoseUpdate& u : updates) {
      if (!u.T_base_kf.matrix().allFinite()) {
        return absl::InvalidArgumentError(absl::StrCat("pose of keyframe ", u.keyframe_id,
                                                       " is not finite"));
      }
      auto it = FindKeyframePose(u.keyframe_id);
      if (it == keyframe_poses_.end()) {
        return absl::NotFoundError(absl::StrCat("keyframe ", u.keyframe_id, " is not mapped"));
      }
      index.push_back(static_cast<size_t>(it - keyframe_poses_.begin()));
    }
  }
  std::vector<ObjectChange> changes;
  std::vector<int64_t> moved_objects;
  Status status;
  size_t moved = 0;
  // The next keyframe's products are read on a pool thread while this one moves.
  auto read = [&source](int64_t id) {
    return TaskPool::Shared().Submit([&source, id] { return source(id); });
  };
  std::future<StatusOr<KeyframeProducts>> next;
  if (!updates.empty()) next = read(updates.front().keyframe_id);
  for (size_t i = 0; i < updates.size(); ++i) {
    StatusOr<KeyframeProducts> products = next.get();
    if (!products.ok()) {
      status = products.status();  // the keyframes before it moved; this one and the rest not
      break;
    }
    if (i + 1 < updates.size()) next = read(updates[i + 1].keyframe_id);
    std::lock_guard<std::mutex> lock(mu_);
    MoveKeyframe(index[i], updates[i].T_base_kf, *products, &moved_objects);
    ++moved;
  }
  std::vector<ObjectEventOut> events;
  std::optional<LiveOctomap::Rebuild> rebuild;
  {
    std::lock_guard<std::mutex> lock(mu_);
    // A move in parts merges once, after its last part: a part moved onto objects that the rest
    // has not reached yet would merge what the whole move keeps apart (objects do not split).
    moved_since_merge_.insert(moved_since_merge_.end(), moved_objects.begin(),
                              moved_objects.end());
    if (rebuild_octomap) {
      objects_.MergeMoved(moved_since_merge_, &changes);
      moved_since_merge_.clear();
    }
    AppendEvents(changes, &events);
    if (octomap_ && rebuild_octomap && moved > 0) {
      if (OctomapOutOfTolerance()) {
        // Keyframes mapped from here on are not in the list: their scans join the new tree.
        rebuild = LiveOctomap::Rebuild{{}, source, octomap_->BeginRebuild()};
        rebuild->T_map_kf.reserve(keyframe_poses_.size());
        for (KeyframePose& k : keyframe_poses_) {
          rebuild->T_map_kf.emplace_back(k.keyframe_id, T_map_base_ * k.T_base_kf);
          k.T_base_kf_octomap = k.T_base_kf;
        }
        ++stats_.octomap_rebuilds;
      } else {
        ++stats_.octomap_rebuilds_skipped;
      }
    }
  }
  if (rebuild) octomap_->RequestRebuild(std::move(*rebuild));
  if (listener_ && !events.empty()) listener_(events);
  if (!status.ok()) return status;
  return moved;
}

bool Mapper::OctomapOutOfTolerance() const {
  const double tolerance_m = options_.octomap.rebuild_tolerance_m;
  if (tolerance_m <= 0) return true;
  const double range_m = options_.octomap.max_range_m > 0 ? options_.octomap.max_range_m : 4.0;
  for (const KeyframePose& k : keyframe_poses_) {
    const SE3d d = k.T_base_kf_octomap.inverse() * k.T_base_kf;
    const double angle_rad = Eigen::AngleAxisd(d.rotation()).angle();
    if (d.translation().norm() + angle_rad * range_m > tolerance_m) return true;
  }
  return false;
}

void Mapper::MoveKeyframe(size_t index, const SE3d& T_base_kf, const KeyframeProducts& products,
                          std::vector<int64_t>* moved_objects) {
  KeyframePose& k = keyframe_poses_[index];
  const Eigen::Isometry3f T_old = (T_map_base_ * k.T_base_kf).cast<float>();
  const SE3d T_map_kf_new = T_map_base_ * T_base_kf;
  const Eigen::Isometry3f T_new = T_map_kf_new.cast<float>();
  // The cloud half moves on a pool thread beside the object half: they touch different
  // structures (cloud_, objects_) and only read the keyframe's ids.
  std::future<void> cloud_moved = TaskPool::Shared().Submit([&] {
    cloud_.Remove(StaticPointsMap(products, T_old, k.observation_object_ids));
    cloud_.Add(StaticPointsMap(products, T_new, k.observation_object_ids));
  });
  const size_t n = std::min(products.observations.size(), k.observation_object_ids.size());
  for (size_t i = 0; i < n; ++i) {
    const ObjectObservation& o = products.observations[i];
    if (objects_.MoveObservation(k.observation_object_ids[i], ObservationPointsMap(o, T_old),
                                 ObservationPointsMap(o, T_new), o.class_name)) {
      moved_objects->push_back(k.observation_object_ids[i]);
    }
  }
  cloud_moved.get();
  k.T_base_kf = T_base_kf;
  RobotPose& latest = latest_poses_[k.robot];
  if (latest.t_ns == k.t_ns) latest.T_map_cam = T_map_kf_new;
}

std::vector<Mapper::SeenCentroid> Mapper::SeenCentroids(double max_size_m) const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<SeenCentroid> seen;
  for (const KeyframePose& k : keyframe_poses_) {
    const size_t n = std::min(k.observation_object_ids.size(), k.observation_centroids_kf_m.size());
    for (size_t i = 0; i < n; ++i) {
      const int64_t id = objects_.Resolve(k.observation_object_ids[i]);
      const FusedObject* object = objects_.Find(id);
      if (object == nullptr || !object->confirmed() || 2.0 * object->half_size_m() > max_size_m ||
          IsFlatTopClass(options_.observation.mask.flat_top_classes, object->labels().Argmax())) {
        continue;
      }
      seen.push_back({k.keyframe_id, id, k.observation_centroids_kf_m[i].cast<double>()});
    }
  }
  return seen;
}

}  // namespace loci::server


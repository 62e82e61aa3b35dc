// The tracker's local map: the last N keyframes and the 3-D points they observe (world frame =
// the odometry frame of the current segment). Points seen by no window keyframe are dropped,
// so memory stays bounded on a robot that runs for hours.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <unordered_map>
#include <vector>

#include "client/tracking/orb_frame.h"
#include "common/se3.h"

namespace loci {

struct MapPoint {
  int64_t id = 0;
  Vec3d p_world;               // m
  Descriptor256 descriptor{};  // from its latest keyframe observation
  int octave = 0;              // pyramid level of that observation
  double ref_depth_m = 1.0;    // depth of that observation (predicts the level when seen again)
  int visible = 1;             // frames in which it projected inside the image
  int found = 1;               // frames in which it was matched
  int dynamic_votes = 0;       // times the dynamic test flagged it
  int num_keyframes = 0;       // window keyframes observing it
  double weight = 0;           // sum of 1/sigma^2 (m^-2) of the depth measurements averaged
  // Last matched observation (for the epipolar test): pixel and the frame's T_world_cam.
  Eigen::Vector2d last_uv_px = Eigen::Vector2d::Zero();
  SE3d last_T_world_cam = SE3d::Identity();
  int64_t last_seen_frame = -1;  // frame index of the last match
  int64_t last_search_frame = -1;
};

struct KeyframeRecord {
  int64_t id = 0;
  int64_t frame_index = 0;
  SE3d T_world_cam;
  std::vector<int64_t> point_ids;  // static points it observes
  std::vector<int> point_kp;       // keypoint in `frame` observing point_ids[i]
  OrbFrame frame;                  // features, for relocalisation
};

class LocalMap {
 public:
  explicit LocalMap(int max_keyframes) : max_keyframes_(max_keyframes) {}

  void Clear();
  bool empty() const { return keyframes_.empty(); }
  MapPoint* Point(int64_t id);
  MapPoint* AddPoint(const Vec3d& p_world, const Descriptor256& d, int octave, double depth_m);
  // Adds a keyframe (taking ownership of its record) and drops the oldest beyond the window,
  // with the points no remaining keyframe observes.
  void AddKeyframe(std::unique_ptr<KeyframeRecord> kf);
  // Removes points judged unreliable (matched in < 25 % of the frames they were visible in
  // after 10 visible frames, or flagged dynamic twice).
  void CullPoints();
  // All points of the window.
  std::vector<MapPoint*> Points();
  const std::deque<std::unique_ptr<KeyframeRecord>>& keyframes() const { return keyframes_; }
  std::deque<std::unique_ptr<KeyframeRecord>>& mutable_keyframes() { return keyframes_; }
  const KeyframeRecord* LastKeyframe() const {
    return keyframes_.empty() ? nullptr : keyframes_.back().get();
  }
  size_t num_points() const { return points_.size(); }

 private:
  void RemovePoint(int64_t id);

  int max_keyframes_;
  int64_t next_point_id_ = 1;
  std::deque<std::unique_ptr<KeyframeRecord>> keyframes_;
  std::unordered_map<int64_t, MapPoint> points_;
};

}  // namespace loci

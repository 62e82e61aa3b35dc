// The map of the server: turns keyframes into objects, a semantic cloud and an OctoMap, and
// answers thread-safe snapshots for the services, exports and the query engine. Everything it
// gives out is in the gravity-aligned map frame (map_frame.h).
//
// Integrate() is called by one mapping thread; every other method may be called concurrently.
// The OctoMap is updated on its own thread (ray casting is the costliest stage); its readers wait
// until every integrated keyframe is in.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/map_object.h"
#include "common/se3.h"
#include "common/tum_io.h"
#include "server/map/keyframe_products.h"
#include "server/map/live_octomap.h"
#include "server/map/map_frame.h"
#include "server/map/map_options.h"
#include "server/map/object_map.h"
#include "server/map/semantic_cloud.h"

namespace loci::server {

// A decoded keyframe ready for mapping.
struct MapperKeyframe {
  int64_t keyframe_id = 0;
  int64_t session_row = 0;
  std::string robot;
  int64_t t_ns = 0;
  // Pose in the base frame (map_frame.h): T_base_odom(session) * T_odom_cam. The mapper moves
  // it into the map frame.
  SE3d T_base_kf = SE3d::Identity();
  SE3d T_odom_kf = SE3d::Identity();  // the pose the robot sent, in its odometry frame
  int segment = 0;  // the client's odometry segment (a tracking loss starts a new one)
  int tracking_inliers = 0;  // the client's tracking quality (0 = unknown)
  PinholeCamera camera;
  cv::Mat bgr;      // CV_8UC3
  cv::Mat depth_m;  // CV_32FC1, metres, 0 = invalid
  std::vector<Detection2D> detections;
  bool has_gravity = false;
  Vec3d gravity_cam = Vec3d::Zero();  // unit, pointing down
};

// Thread CPU milliseconds spent per stage of one keyframe (CPU time, so the figures hold on a
// loaded machine).
struct StageTimes {
  double products_ms = 0;  // labels, back-projection, voxel + outlier filters
  // ... of which: pixel labels, object clouds, dense back-projection, voxel filter, outliers
  double labels_ms = 0, objects_ms = 0, backproject_ms = 0, voxel_ms = 0, outlier_ms = 0;
  double fusion_ms = 0;   // association, object update, merges
  double cloud_ms = 0;    // global semantic cloud
  double octomap_ms = 0;  // ray casting into the OctoMap (its own thread)
};

struct RobotPose {
  int64_t t_ns = 0;
  SE3d T_map_cam = SE3d::Identity();
};

struct MapperStats {
  uint64_t keyframes = 0;
  uint64_t objects = 0;
  uint64_t confirmed_objects = 0;
  uint64_t cloud_points = 0;
  uint64_t octomap_nodes = 0;          // of the scans inserted so far ...
  uint64_t octomap_pending_scans = 0;  // ... while these still wait for the OctoMap thread
  // Pose updates that rebuilt the OctoMap / that moved keyframes within
  // octomap.rebuild_tolerance_m of their scans and left it.
  uint64_t octomap_rebuilds = 0;
  uint64_t octomap_rebuilds_skipped = 0;
  StageTimes total;  // sums over all keyframes
};

// A change of the object database with the object's state after it.
struct ObjectEventOut {
  ObjectChange::Kind kind = ObjectChange::Kind::kUpdated;
  MapObject object;
  int64_t merged_from_id = 0;
  std::vector<int64_t> evidence_keyframe_ids;  // ObjectChange::evidence_keyframe_ids
  int64_t evidence_t_ns = 0;
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero();  // kMoved: ObjectChange::from_m
};

class Mapper {
 public:
  explicit Mapper(const MapOptions& options);
  ~Mapper();
  Mapper(const Mapper&) = delete;
  Mapper& operator=(const Mapper&) = delete;

  // The products of one keyframe (keyframe frame; the server stores them, product_codec.h).
  KeyframeProducts BuildProducts(const MapperKeyframe& keyframe) const;
  // BuildProducts, then maps them.
  StageTimes Integrate(const MapperKeyframe& keyframe);
  // Maps a keyframe from its products alone: the keyframe's images are not read (may be empty).
  // Keyframes arrive in increasing keyframe_id, except those of a robot held back until it was
  // aligned (server/align/), which come in later, in id order among themselves.
  StageTimes Integrate(const MapperKeyframe& keyframe, const KeyframeProducts& products);

  // The whole derived map (objects, cloud, OctoMap, frame, poses) as a
  // loci.store.v1.MapperCheckpoint (map_checkpoint.cc); call on the mapping thread. Empty
  // before the map frame is settled (the first settle_keyframes keyframes re-derive cheaply).
  std::string SaveCheckpoint() const;
  // Restores a fresh mapper from SaveCheckpoint's bytes; FailedPrecondition when they were
  // made with other options (MapOptions::MapFingerprint), DataLoss when they do not parse.
  Status LoadCheckpoint(const std::string& bytes);
  // Id of the last keyframe integrated (0 = none).
  int64_t last_keyframe_id() const;

  // Moves mapped keyframes to new poses (T_base_kf; loop closure, robot alignment) and
  // re-derives what they touch (mapper_poses.cc): their object points and cloud points leave
  // the old place and enter the new one, and moved objects that now coincide with others merge.
  // Emits UPDATED / MERGED / REMOVED events. Products come from `source` (the store). Call on
  // the mapping thread, between Integrate calls. NotFound for an unmapped keyframe (nothing
  // moves). The OctoMap follows on its own thread: it is rebuilt from every keyframe's products
  // at the current poses (log-odds clamping makes taking scans back out inexact), while the old
  // one keeps answering and keyframes mapped meanwhile do not wait for it (their scans join the
  // new tree); FlushOctomap waits for it. `source` must stay valid until then.
  using ProductSource = LiveOctomap::ProductSource;
  struct KeyframePoseUpdate {
    int64_t keyframe_id = 0;
    SE3d T_base_kf = SE3d::Identity();
  };
  // rebuild_octomap false: a part of a larger move; moved objects are merged and the OctoMap
  // rebuilt by the call that ends it (a move in chunks does both once, after its last chunk).
  StatusOr<size_t> UpdateKeyframePoses(const std::vector<KeyframePoseUpdate>& updates,
                                       const ProductSource& source, bool rebuild_octomap = true);

  // Ids of the map's objects start here (ObjectMap::SetFirstId): before the first keyframe.
  Status SetFirstObjectId(int64_t first_id);

  // Called (on the mapping thread, outside the map's locks) for every object change.
  void SetEventListener(std::function<void(const std::vector<ObjectEventOut>&)> listener);

  std::vector<MapObject> Snapshot(bool confirmed_only = false) const;
  // The confirmed objects found gone, with their history (ObjectMap::Removed).
  std::vector<MapObject> Removed() const;
  std::optional<MapObject> GetObject(int64_t id, std::vector<ColoredPoint>* cloud_m,
                                     std::vector<int64_t>* keyframe_ids) const;
  // Semantic cloud at voxel_m (0 = the map's voxel); `classes` empty = all, "background" selects
  // unlabelled points.
  std::vector<SemanticPoint> Cloud(double voxel_m, const std::vector<std::string>& classes) const;
  // The OctoMap as a .bt stream once it holds every keyframe integrated so far. With
  // `wait_for_rebuild` false it does not wait for a rebuild after a pose update (seconds per
  // 1000 keyframes): the moved keyframes' scans are then where they were (OctomapRebuilding()).
  std::string OctomapBt(bool wait_for_rebuild = true) const;
  double OctomapResolution() const { return options_.octomap.resolution_m; }
  std::vector<Eigen::Vector3d> OccupiedCenters() const;
  // Unit "up" of the map frame (minus the mean gravity of the keyframes), if any had gravity.
  std::optional<Vec3d> UpDirection() const;
  // How the map frame's up was found ("gravity+planes", "gravity", "planes", "level-camera";
  // "" before the first keyframe) and whether it is final (the first settle_keyframes are in).
  std::string FrameSource() const;
  bool FrameSettled() const;
  // T_map_base (identity before the first keyframe).
  SE3d MapFromBaseFrame() const;
  // Every integrated keyframe's camera pose in the map frame, per robot, in time order.
  std::map<std::string, Trajectory> Trajectories() const;
  // Every integrated keyframe's id and camera pose in the base frame, in id order.
  std::vector<KeyframePoseUpdate> KeyframePoses() const;
  // How many keyframes are integrated (KeyframePoses().size() without the copy).
  size_t KeyframeCount() const;
  // An object's centroid as one keyframe saw it (the centre of that view's points, keyframe
  // frame, m): the pose graph's object landmarks (paper 000 eq. 19).
  struct SeenCentroid {
    int64_t keyframe_id = 0;
    int64_t object_id = 0;  // the object it is part of now (merges followed)
    Vec3d c_kf_m = Vec3d::Zero();
  };
  // Every view of a confirmed object no longer than max_size_m that is no flat-topped furniture
  // (a desk's views are parts of it, each centred elsewhere), in keyframe id order.
  std::vector<SeenCentroid> SeenCentroids(double max_size_m) const;
  // Whether the keyframe is in the map.
  bool HasKeyframe(int64_t keyframe_id) const;
  std::map<std::string, RobotPose> LatestPoses() const;
  // Does not wait for the OctoMap thread (a stats call must not stall behind ingestion): the
  // OctoMap figures cover the scans inserted so far. Call FlushOctomap first to settle them.
  MapperStats Stats() const;
  const MapOptions& options() const { return options_; }
  // Blocks until the OctoMap holds every keyframe integrated so far and (with
  // `wait_for_rebuild`) the rebuild after the last pose update is in.
  void FlushOctomap(bool wait_for_rebuild = true) const;
  // Whether a rebuild after a pose update is still running: SaveCheckpoint would wait for it
  // (about 9 ms per mapped keyframe).
  bool OctomapRebuilding() const;

 private:
  // A keyframe kept until the map frame is settled, to re-derive the map from.
  struct Settling {
    MapperKeyframe keyframe;
    KeyframeProducts products;
  };
  struct KeyframePose {
    int64_t keyframe_id = 0;
    std::string robot;
    int64_t t_ns = 0;
    SE3d T_base_kf = SE3d::Identity();
    std::vector<int64_t> observation_object_ids;  // the object each observation went into
    std::vector<Eigen::Vector3f> observation_centroids_kf_m;  // each one's centroid, kf frame
    // Where its scan is in the OctoMap (or will be, once the scan queue or a requested rebuild
    // gets to it): T_base_kf when mapped or at a rebuild's request; a move within
    // octomap.rebuild_tolerance_m leaves it.
    SE3d T_base_kf_octomap = SE3d::Identity();
  };
  // What a keyframe's observations went into: one entry per observation.
  struct Observed {
    std::vector<int64_t> object_ids;
    std::vector<Eigen::Vector3f> centroids_kf_m;
  };
  // mu_ held: keeps `observed` with the keyframe's pose.
  void KeepObserved(int64_t keyframe_id, Observed observed);
  // World products of one keyframe (objects, cloud, gravity, poses) in the current map frame;
  // appends object events. Caller holds no lock.
  // Returns the object id and the kf-frame centroid of each observation.
  Observed IntegrateProducts(const MapperKeyframe& kf, const KeyframeProducts& products,
                             StageTimes* times, std::vector<ObjectEventOut>* events);
  void FixFirstFrame(const MapperKeyframe& kf, const std::optional<Vec3d>& gravity_cam);
  void CollectFrameEvidence(const MapperKeyframe& kf, const std::optional<Vec3d>& gravity_cam,
                            const KeyframeProducts& products);
  // Where a keyframe's pose goes in keyframe_poses_ (id order) / where it is (end() when
  // absent); mu_ held.
  std::vector<KeyframePose>::iterator KeyframePoseAfter(int64_t keyframe_id);
  std::vector<KeyframePose>::iterator FindKeyframePose(int64_t keyframe_id);
  // Whether some keyframe's pose is farther from where its scan is in the OctoMap than
  // octomap.rebuild_tolerance_m allows (mu_ held).
  bool OctomapOutOfTolerance() const;
  // Moves keyframe_poses_[index] and its points (mu_ held).
  void MoveKeyframe(size_t index, const SE3d& T_base_kf, const KeyframeProducts& products,
                    std::vector<int64_t>* moved_objects);
  // Object events of fusion changes, with the objects' state now; call with mu_ held.
  void AppendEvents(const std::vector<ObjectChange>& changes,
                    std::vector<ObjectEventOut>* events) const;
  // Fixes the map frame from the settling keyframes and re-derives the map from them.
  void SettleFrame(std::vector<ObjectEventOut>* events);
  void AddTimes(const StageTimes& times);

  MapOptions options_;
  std::function<void(const std::vector<ObjectEventOut>&)> listener_;

  mutable std::mutex mu_;  // objects, cloud, poses, gravity, stats, frame
  SE3d T_map_base_ = SE3d::Identity();
  bool have_frame_ = false, frame_settled_ = false;
  std::string frame_source_;
  FrameEvidence evidence_;            // mapping thread only
  std::vector<Settling> settling_;    // mapping thread only
  std::vector<KeyframePose> keyframe_poses_;
  std::vector<int64_t> moved_since_merge_;  // objects moved by the parts of a move so far (mu_)
  ObjectMap objects_;
  SemanticCloud cloud_;
  Vec3d gravity_sum_map_ = Vec3d::Zero();
  uint64_t gravity_count_ = 0;
  std::map<std::string, RobotPose> latest_poses_;
  MapperStats stats_;

  // The OctoMap on its own threads; null when options_.octomap.enabled is false. Scans are
  // pushed without mu_ held (the queue is bounded).
  std::unique_ptr<LiveOctomap> octomap_;
};

}  // namespace loci::server

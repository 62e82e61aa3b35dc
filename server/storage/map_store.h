// Persistent storage of the map server behind an interface (RTAB-Map's DBDriver pattern):
// sessions and acknowledged keyframes. Map products are derived from keyframes by replay.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"
#include "common/status.h"

namespace loci::server {

// One robot's mapping session; `T_base_odom` places its odometry frame in the base frame (the
// first robot's odometry frame, server/map/map_frame.h), which the mapper levels into the map.
struct SessionRecord {
  int64_t row_id = 0;      // storage key
  std::string session_id;  // public id, e.g. "robot1-3"
  std::string robot_name;
  std::string client_version;
  PinholeCamera camera;         // default intrinsics of the session's keyframes
  double depth_scale = 5000.0;  // depth PNG units per metre
  SE3d T_base_odom = SE3d::Identity();
  int64_t opened_ns = 0;  // wall time
  bool open = true;
};

// One keyframe exactly as acknowledged (images still compressed).
struct KeyframeRecord {
  int64_t id = 0;           // server keyframe id, assigned by the store; replay order
  int64_t session_row = 0;  // SessionRecord::row_id
  int64_t seq = 0;          // client sequence number, unique per session
  int64_t t_ns = 0;         // capture time of the RGB image
  SE3d T_odom_cam = SE3d::Identity();
  PinholeCamera camera;
  double depth_scale = 5000.0;  // depth PNG units per metre
  bool has_gravity = false;
  Vec3d gravity_cam = Vec3d::Zero();  // unit, pointing down, cam frame
  int segment = 0;
  std::string rgb_jpeg;
  std::string depth_png;  // 16-bit PNG
  std::vector<Detection2D> detections;
};

// Result of storing a keyframe.
struct InsertResult {
  int64_t keyframe_id = 0;
  bool duplicate = false;  // (session, seq) was already stored; nothing changed
  // A duplicate whose stamp, pose or images differ from the stored keyframe's (still nothing
  // changed: the first write wins).
  bool conflict = false;
};

// The stamp of a session's keyframe with the highest seq.
struct LastStamp {
  int64_t seq = -1;
  int64_t t_ns = 0;
};

class MapStore {
 public:
  virtual ~MapStore() = default;

  // Schema version of the open database (see server/storage/schema/*.sql).
  virtual StatusOr<int> SchemaVersion() = 0;

  // Creates a session; fills row_id and session_id.
  virtual StatusOr<SessionRecord> CreateSession(SessionRecord session) = 0;
  // The latest open session of `robot_name`, if any.
  virtual StatusOr<std::optional<SessionRecord>> LatestOpenSession(
      const std::string& robot_name) = 0;
  virtual StatusOr<std::optional<SessionRecord>> FindSession(const std::string& session_id) = 0;
  virtual StatusOr<std::vector<SessionRecord>> ListSessions() = 0;
  virtual Status CloseSession(int64_t session_row, int64_t closed_ns) = 0;

  // Stores a keyframe in one transaction; (session_row, seq) is stored at most once.
  virtual StatusOr<InsertResult> InsertKeyframe(const KeyframeRecord& keyframe) = 0;
  // Highest stored seq of a session, -1 when none.
  virtual StatusOr<int64_t> LastStoredSeq(int64_t session_row) = 0;
  // seq -1 when the session has no keyframe.
  virtual StatusOr<LastStamp> LastStoredStamp(int64_t session_row) = 0;
  virtual StatusOr<uint64_t> CountKeyframes(std::optional<int64_t> session_row) = 0;
  // Calls `fn` for every keyframe with id > after_id, in id order; stops at the first error.
  virtual Status ForEachKeyframe(int64_t after_id,
                                 const std::function<Status(KeyframeRecord)>& fn) = 0;
  // Size of the database files (main + WAL), bytes.
  virtual uint64_t DbBytes() = 0;
};

}  // namespace loci::server

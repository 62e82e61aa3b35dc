// Persistent storage of the map server behind an interface (RTAB-Map's DBDriver pattern):
// sessions and acknowledged keyframes (the source of truth), each keyframe's map products (in
// the keyframe frame, server/map/product_codec.h) and checkpoints of the derived map.
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
  // Whether T_base_odom is known (server/align/): an unaligned session's keyframes stay out of
  // the map.
  bool aligned = true;
  // An unaligned session that joined another unaligned session's island: that session's row
  // and where this one's odometry frame sits in the island's frame (0: its own island).
  int64_t island_row = 0;
  SE3d T_island_odom = SE3d::Identity();
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
  int tracking_inliers = 0;  // the client's tracking quality (0 = unknown)
  std::string rgb_jpeg;
  std::string depth_png;  // 16-bit PNG
  std::vector<Detection2D> detections;
  // Stored map products (loci.store.v1.KeyframeProducts), when read with them; empty = none.
  std::string products;
  // A corrected pose (MapStore::PutKeyframePoses), when one was stored.
  std::optional<SE3d> T_base_kf_corrected;
};

// The keyframe's pose in the base frame: the corrected one when stored, else the session's
// odometry placement times the pose the robot sent.
inline SE3d BaseFromKeyframe(const KeyframeRecord& rec, const SessionRecord& session) {
  return rec.T_base_kf_corrected ? *rec.T_base_kf_corrected
                                 : session.T_base_odom * rec.T_odom_cam;
}

// A keyframe's corrected pose.
struct KeyframePoseRecord {
  int64_t keyframe_id = 0;
  SE3d T_base_kf = SE3d::Identity();
};

// A verified place-recognition match between two stored keyframes (p_a = T_a_b * p_b).
struct PlaceMatchRecord {
  int64_t a_keyframe_id = 0;
  int64_t b_keyframe_id = 0;
  SE3d T_a_b = SE3d::Identity();
  int inliers = 0;
  double rms_m = 0;
};

// What ForEachKeyframe reads besides the pose and metadata.
struct KeyframeScan {
  bool images = true;  // rgb_jpeg, depth_png, detections
  // Non-empty: KeyframeRecord::products of this fingerprint (MapOptions::ProductsFingerprint),
  // and the images only of keyframes without such products (a restart needs nothing else).
  std::string products_fingerprint;
  std::optional<int64_t> session_row;  // only this session's keyframes
  std::optional<int64_t> last_id;      // only keyframes with id <= this
};

// One object of the shared map as other tools read it: the object table, in the map frame.
struct ObjectRecord {
  int64_t id = 0;
  std::string class_name;
  double confidence = 0;
  bool confirmed = false;
  Vec3d centroid_m = Vec3d::Zero();
  Vec3d min_m = Vec3d::Zero();  // axis-aligned box
  Vec3d max_m = Vec3d::Zero();
  uint32_t observation_count = 0;
  int64_t last_seen_ns = 0;
  int64_t removed_t_ns = 0;  // 0: in the map
  std::string wire;          // the whole object as loci.v1.Object, for read-only servers
};

// A robot's latest camera pose in the map frame, published with the objects.
struct PublishedPose {
  std::string robot;
  int64_t t_ns = 0;
  SE3d T_map_cam = SE3d::Identity();
};

// What a map's writer publishes for read-only query servers and SQL tools: changes to the
// object table (the shared map's objects, map frame) and the state a question needs.
struct MapPublication {
  bool replace_all = false;           // `objects` is the whole table, else its changes
  std::vector<ObjectRecord> objects;  // new or changed
  std::vector<int64_t> gone_ids;      // left the map (merged into another)
  std::vector<PublishedPose> poses;   // every robot's latest; replaces the published ones
  std::optional<Vec3d> up_map;        // the clients' gravity up (unit), if any sent it
  std::string levelled_by;            // how the map frame was levelled ("" = not levelled)
  int64_t last_keyframe_id = 0;       // the newest keyframe in the published map
};

// The published map as a reader sees it.
struct PublishedMap {
  int64_t version = 0;       // counts publications; 0 = nothing published yet
  int64_t published_ns = 0;  // wall time of the latest publication
  std::vector<ObjectRecord> objects;  // by id
  std::vector<PublishedPose> poses;   // by robot
  std::optional<Vec3d> up_map;
  std::string levelled_by;
  int64_t last_keyframe_id = 0;
};

// A checkpoint of the derived map.
struct CheckpointRecord {
  int64_t last_keyframe_id = 0;
  std::string data;  // loci.store.v1.MapperCheckpoint
};

// Bytes the database spends, by kind (payload bytes, without SQLite's overhead).
struct StorageBytes {
  uint64_t keyframes = 0;          // keyframes stored
  uint64_t keyframes_with_raw = 0;  // ... that still hold their images
  uint64_t raw_bytes = 0;          // images + detections
  uint64_t products = 0;           // keyframes with products
  uint64_t product_bytes = 0;
  uint64_t checkpoint_bytes = 0;   // the latest checkpoint
  uint64_t place_features = 0;     // keyframes with stored place-recognition features
  uint64_t place_feature_bytes = 0;
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
  // Marks a session aligned at T_base_odom (robot alignment).
  virtual Status SetSessionAlignment(int64_t session_row, const SE3d& T_base_odom) = 0;
  // Places an unaligned session in another unaligned session's island (island_row) at
  // T_island_odom; NotFound for an unknown or aligned session.
  virtual Status SetSessionIsland(int64_t session_row, int64_t island_row,
                                  const SE3d& T_island_odom) = 0;

  // Stores a keyframe in one transaction; (session_row, seq) is stored at most once.
  virtual StatusOr<InsertResult> InsertKeyframe(const KeyframeRecord& keyframe) = 0;
  // Highest stored seq of a session, -1 when none.
  virtual StatusOr<int64_t> LastStoredSeq(int64_t session_row) = 0;
  // seq -1 when the session has no keyframe.
  virtual StatusOr<LastStamp> LastStoredStamp(int64_t session_row) = 0;
  virtual StatusOr<uint64_t> CountKeyframes(std::optional<int64_t> session_row) = 0;
  // Calls `fn` for every keyframe with id > after_id, in id order; stops at the first error.
  virtual Status ForEachKeyframe(int64_t after_id,
                                 const std::function<Status(KeyframeRecord)>& fn,
                                 const KeyframeScan& scan = {}) = 0;

  // Stores (or replaces) a keyframe's products in their own transaction: idempotent.
  virtual Status PutProducts(int64_t keyframe_id, const std::string& fingerprint,
                             const std::string& data) = 0;
  // A keyframe's stored products of `fingerprint`; nullopt when it has none of them.
  virtual StatusOr<std::optional<std::string>> GetProducts(int64_t keyframe_id,
                                                           const std::string& fingerprint) = 0;
  // Stores (or replaces) a keyframe's place-recognition features (server/place/feature_codec.h)
  // of `fingerprint` (FeatureOptions::Fingerprint).
  virtual Status PutPlaceFeatures(int64_t keyframe_id, const std::string& fingerprint,
                                  const std::string& data) = 0;
  // nullopt when the keyframe has no stored features of `fingerprint`.
  virtual StatusOr<std::optional<std::string>> GetPlaceFeatures(int64_t keyframe_id,
                                                                const std::string& fingerprint) = 0;
  // Deletes every keyframe's products (`loci reprocess`).
  virtual Status DeleteAllProducts() = 0;
  // Corrected poses, all in one transaction (a later one for the same keyframe replaces it).
  virtual Status PutKeyframePoses(const std::vector<KeyframePoseRecord>& poses) = 0;
  // Stores a checkpoint and drops the older ones.
  // Verified matches (loop closure, merges); a pair stored again is replaced.
  virtual Status PutPlaceMatch(const PlaceMatchRecord& match) = 0;
  virtual StatusOr<std::vector<PlaceMatchRecord>> ListPlaceMatches() = 0;
  virtual Status PutCheckpoint(const CheckpointRecord& checkpoint) = 0;
  virtual StatusOr<std::optional<CheckpointRecord>> LatestCheckpoint() = 0;
  // Applies a publication to the object table and the published state in one transaction and
  // counts it (PublishedMap::version).
  virtual Status Publish(const MapPublication& publication) = 0;
  virtual StatusOr<PublishedMap> ReadPublished() = 0;
  // Only the published version (cheap: read-only servers poll it).
  virtual StatusOr<int64_t> PublishedVersion() = 0;
  virtual Status DeleteCheckpoints() = 0;
  // Retention: empties the images of keyframes that have products and match the policy
  // (older than before_ns, or all but the newest keep_last); returns how many were emptied.
  virtual StatusOr<uint64_t> DropRawImages(int64_t before_stored_ns, int64_t keep_last) = 0;
  virtual StatusOr<StorageBytes> Bytes() = 0;
  // Size of the database files (main + WAL), bytes.
  virtual uint64_t DbBytes() = 0;
};

}  // namespace loci::server

// A synthetic indoor scene with exact ground truth: a textured room (floor, 4 walls, ceiling),
// a table, a shelf, N objects of COCO classes standing on them or on the floor, an optional
// walking person, and a hand-held-like camera path looking at the table.
// World frame: z up, floor at z = 0, room centred on the origin (metres).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/objects_json.h"
#include "common/se3.h"
#include "common/status.h"
#include "synth/camera_path.h"
#include "synth/texture.h"

namespace loci::synth {

struct SceneOptions {
  uint64_t seed = 1;         // everything (layout, textures, path, noise) follows from it
  int num_frames = 300;      // RGB-D frames, >= 1
  int num_objects = 10;      // objects besides the table, the shelf and the person, [0, 40]
  // Varied layout (from the seed): room size, table size and place from published furniture
  // dimensions, a shelf or none, and between min(6, num_objects) and num_objects objects. Off:
  // the fixed 6 x 5 m room of earlier scenes (their bytes are unchanged).
  bool varied_layout = false;
  // Detector noise on detections.jsonl (synth/detector_noise.h); off: exact boxes and masks.
  bool detector_noise = false;
  bool dynamic = false;      // adds a walking person (class "person", "dynamic": true)
  bool depth_noise = false;  // Kinect-like depth noise, quantisation and edge dropouts; off
                             // by default so depth is exact up to the 0.2 mm PNG step
  int width_px = 640;        // image size; intrinsics are fr1's scaled by width/640 and
  int height_px = 480;       // height/480
  double fps_hz = 30.0;      // frame rate; stamps are rounded to whole microseconds
  int64_t start_t_ns = 1'700'000'000'000'000'000;  // stamp of the first frame
  double accel_rate_hz = 100.0;                    // accelerometer.txt rate
  bool accel_with_motion = true;  // accelerometer = gravity reaction + the camera's linear
                                  // acceleration (like a real IMU); false: gravity only
  double depth_scale = 5000.0;    // depth PNG units per metre (TUM)
  double min_depth_m = 0.3;       // closer surfaces read 0 (Kinect minimum range)
  double max_depth_m = 8.0;       // farther surfaces read 0
  int min_visible_px = 150;       // an object is detected when at least this many pixels show it
  bool detect_non_coco = false;   // also emit detections (class_id -1) of non-COCO objects (shelf)
  int jpeg_quality = 95;          // rgb/*.jpg quality, [1, 100]
  int num_threads = 0;            // worker threads; 0 = std::thread::hardware_concurrency()
  // Objects taken out of the room (ids as in objects.json): the same scene without them, for a
  // later session of a room in which things changed. An object something rests on stays.
  std::vector<int64_t> absent_ids;
  // Objects put somewhere else on the same support (not overlapping where they were), drawn
  // from their own random stream: the rest of the scene stays as it was. An object something
  // rests on stays.
  std::vector<int64_t> moved_ids;

  Status Validate() const;
};

// An analytic solid in its object's frame. Box: |x|,|y|,|z| <= half_m. Cylinder: axis z,
// radius half_m.x(), |z| <= half_m.z(). Sphere: radius half_m.x().
enum class Shape { kBox, kCylinder, kSphere };

struct Primitive {
  Shape shape = Shape::kBox;
  SE3d T_obj_prim = SE3d::Identity();  // pose of the solid in its object's frame
  Vec3d half_m = Vec3d::Constant(0.05);
  int texture = 0;                                        // index into Scene::textures
  Eigen::Vector2d uv_offset_m = Eigen::Vector2d::Zero();  // where the part starts in its texture
};

struct SceneObject {
  int64_t id = 0;          // >= 1; 0 in instance images means "room"
  std::string class_name;  // COCO name ("dining table", "cup") or "shelf"
  int coco_class_id = -1;  // COCO-80 index, -1 when not a COCO class
  int64_t on_id = 0;       // id of the supporting object, 0 = floor
  bool dynamic = false;
  // Object frame: origin at the centre of its footprint on the ground (lowest point z = 0),
  // z up. For dynamic objects this is the pose at the first frame.
  SE3d T_world_obj = SE3d::Identity();
  std::vector<Primitive> parts;
  // Dynamic objects walk from walk_start_m to walk_end_m and back (ping-pong), facing the
  // walking direction, at walk_speed_mps.
  Vec3d walk_start_m = Vec3d::Zero(), walk_end_m = Vec3d::Zero();
  double walk_speed_mps = 0;
};

struct Scene {
  SceneOptions options;
  PinholeCamera camera;  // fr1 scaled to the image size
  Vec3d room_min_m = Vec3d::Zero(), room_max_m = Vec3d::Zero();
  // Room surfaces: floor, ceiling, walls x-min, x-max, y-min, y-max (indices into textures).
  int room_texture[6] = {0, 0, 0, 0, 0, 0};
  Vec3d light_world_m = Vec3d::Zero();  // point light position
  // Table first, then the shelf (when there is one), objects, person. options.num_objects is
  // the number placed (varied_layout draws it).
  std::vector<SceneObject> objects;
  std::vector<Texture> textures;
  CameraPath camera_path;
};

// Builds the scene of `options` (deterministic for options.seed). InvalidArgument for bad
// options; FailedPrecondition when the objects do not fit on the supports.
StatusOr<Scene> MakeScene(const SceneOptions& options);

// Stamp of frame i (ns), i in [0, num_frames).
int64_t FrameStampNs(const SceneOptions& options, int i);
// Camera pose at an absolute stamp.
SE3d CameraPoseAt(const Scene& scene, int64_t t_ns);
// Object pose at an absolute stamp (static objects: T_world_obj).
SE3d ObjectPoseAt(const Scene& scene, const SceneObject& object, int64_t t_ns);
// World AABB of an object in pose T_world_obj (exact for these solids).
void ObjectAabb(const SceneObject& object, const SE3d& T_world_obj, Vec3d* min_m, Vec3d* max_m);
// objects.json content: every object at its first-frame pose.
GroundTruthScene ToGroundTruth(const Scene& scene);

}  // namespace loci::synth

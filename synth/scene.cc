#include "synth/scene.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "common/time.h"
#include "synth/object_catalog.h"

namespace loci::synth {
namespace {

// Room: 6 x 5 x 2.7 m, centred on the origin, floor at z = 0.
const Vec3d kRoomMin(-3.0, -2.5, 0.0);
const Vec3d kRoomMax(3.0, 2.5, 2.7);
// Band of the floor kept free for the walking person (world y, m), between table and shelf.
constexpr double kWalkY = 1.42, kWalkBandLo = 1.0, kWalkBandHi = 1.85;

struct Rect2 {
  double x0, y0, x1, y1;
  bool Overlaps(const Rect2& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
  Rect2 Grown(double m) const { return {x0 - m, y0 - m, x1 + m, y1 + m}; }
};

// The scene's room, table and clutter: fixed, or drawn from their own random stream
// (SceneOptions::varied_layout) so the fixed scenes keep their bytes.
struct Layout {
  Vec3d room_min_m = kRoomMin, room_max_m = kRoomMax;
  std::optional<Vec3d> table_size_m;         // nullopt: the fixed scenes' draw
  std::optional<Eigen::Vector2d> table_xy_m;  // likewise
  bool shelf = true;
  int num_objects = 0;
};

Layout MakeLayout(const SceneOptions& o) {
  Layout l;
  l.num_objects = o.num_objects;
  if (!o.varied_layout) return l;
  Rng rng(Rng::Mix(o.seed, 0x1A7007));
  // Rooms of 4.8-7 x 4.8-6 m: the camera stands about 1.7 m in front of the table and the
  // walking person's band (y 1.0-1.85 m) stays clear of the table and the shelf.
  const double hx = rng.Uniform(2.4, 3.5), hy = rng.Uniform(2.4, 3.0);
  l.room_min_m = Vec3d(-hx, -hy, 0.0);
  l.room_max_m = Vec3d(hx, hy, rng.Uniform(2.4, 3.0));
  // Published dining and office table sizes: 1.2-2.0 m long, 0.7-1.0 m deep, 0.72-0.78 m high.
  l.table_size_m = Vec3d(rng.Uniform(1.2, 2.0), rng.Uniform(0.7, 1.0), rng.Uniform(0.72, 0.78));
  l.table_xy_m = Eigen::Vector2d(rng.Uniform(-0.6, 0.6), rng.Uniform(-0.1, 0.4));
  l.shelf = rng.Bernoulli(0.75);
  l.num_objects = rng.UniformInt(std::min(6, o.num_objects), o.num_objects);
  return l;
}

Rect2 Footprint(const SceneObject& o) {
  Vec3d lo, hi;
  ObjectAabb(o, o.T_world_obj, &lo, &hi);
  return {lo.x(), lo.y(), hi.x(), hi.y()};
}

SE3d PoseXYYaw(double x, double y, double z, double yaw) {
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vec3d::UnitZ()).toRotationMatrix();
  T.translation() = Vec3d(x, y, z);
  return T;
}

// Shifts the parts so the lowest point is at z = 0 (objects stand exactly on their support).
void RestOnGround(std::vector<Primitive>* parts) {
  Vec3d lo, hi;
  PartsAabb(*parts, SE3d::Identity(), &lo, &hi);
  for (Primitive& p : *parts) p.T_obj_prim.translation().z() -= lo.z();
}

// One texture per object; each part starts elsewhere in it so parts do not look alike.
void Texturize(Scene* scene, SceneObject* o, TextureStyle style, const cv::Vec3b& base, Rng& rng) {
  Vec3d lo, hi;
  PartsAabb(o->parts, SE3d::Identity(), &lo, &hi);
  const int size_px = style == TextureStyle::kWood ? 512 : 256;
  const double side_m = std::max(0.25, 1.2 * (hi - lo).maxCoeff());
  scene->textures.push_back(MakeTexture(style, base, size_px, size_px, side_m / size_px, rng));
  for (size_t i = 0; i < o->parts.size(); ++i) {
    o->parts[i].texture = static_cast<int>(scene->textures.size()) - 1;
    o->parts[i].uv_offset_m = Eigen::Vector2d(0.29 * i, 0.41 * i) * side_m;
  }
}

// A place (x, y, yaw) for `o` inside `area` that overlaps none of `taken` nor `forbidden`.
bool Place(SceneObject* o, const Rect2& area, double z_m, bool face_front,
           const std::vector<Rect2>& forbidden, std::vector<Rect2>* taken, Rng& rng) {
  for (int attempt = 0; attempt < 300; ++attempt) {
    // Mostly square to the support's edges, as people leave things; fronts face the camera.
    const double yaw =
        (face_front ? 0.0 : M_PI / 2 * rng.UniformInt(0, 3)) + rng.Uniform(-0.35, 0.35);
    Vec3d lo, hi;
    PartsAabb(o->parts, PoseXYYaw(0, 0, 0, yaw), &lo, &hi);
    const double xa = area.x0 - lo.x(), xb = area.x1 - hi.x();
    const double ya = area.y0 - lo.y(), yb = area.y1 - hi.y();
    if (xa > xb || ya > yb) continue;  // does not fit with this yaw
    o->T_world_obj = PoseXYYaw(rng.Uniform(xa, xb), rng.Uniform(ya, yb), z_m, yaw);
    const Rect2 fp = Footprint(*o).Grown(0.02);
    bool free = true;
    for (const auto* list : {&forbidden, static_cast<const std::vector<Rect2>*>(taken)}) {
      for (const Rect2& r : *list) free = free && !fp.Overlaps(r);
    }
    if (free) {
      taken->push_back(fp);
      return true;
    }
  }
  return false;
}

cv::Vec3b ObjectColor(int index, double hue0, Rng& rng) {
  return HueColor(std::fmod(hue0 + 137.508 * index, 360.0), rng.Uniform(0.5, 0.9),
                  rng.Uniform(0.55, 0.95));
}

void AddRoom(const Layout& layout, Scene* s, Rng& rng) {
  s->room_min_m = layout.room_min_m;
  s->room_max_m = layout.room_max_m;
  const Vec3d size = s->room_max_m - s->room_min_m;
  auto add = [&](TextureStyle style, const cv::Vec3b& base, double w_m, double h_m,
                 double texel_m) {
    s->textures.push_back(MakeTexture(style, base, static_cast<int>(w_m / texel_m),
                                      static_cast<int>(h_m / texel_m), texel_m, rng));
    return static_cast<int>(s->textures.size()) - 1;
  };
  s->room_texture[0] =
      add(TextureStyle::kFloor, HueColor(rng.Uniform(20, 40), 0.5, 0.6), size.x(), size.y(), 0.005);
  s->room_texture[1] = add(TextureStyle::kCeiling, HueColor(0, 0, 0.85), size.x(), size.y(), 0.01);
  for (int w = 0; w < 4; ++w) {
    const double len = w < 2 ? size.y() : size.x();
    const cv::Vec3b paint =
        HueColor(rng.Uniform(0, 360), rng.Uniform(0.1, 0.35), rng.Uniform(0.7, 0.9));
    s->room_texture[2 + w] = add(TextureStyle::kWall, paint, len, size.z(), 0.005);
  }
  s->light_world_m = Vec3d(0.0, 0.0, s->room_max_m.z() - 0.15);
}

}  // namespace

Status SceneOptions::Validate() const {
  if (num_frames < 1) return absl::InvalidArgumentError("frames must be >= 1");
  if (num_objects < 0 || num_objects > 40) {
    return absl::InvalidArgumentError("objects must be in [0, 40]");
  }
  if (width_px < 16 || height_px < 16 || width_px > 4096 || height_px > 4096) {
    return absl::InvalidArgumentError("image size must be in [16, 4096] pixels");
  }
  if (!(fps_hz > 0 && fps_hz <= 1000) || !(accel_rate_hz > 0 && accel_rate_hz <= 10000)) {
    return absl::InvalidArgumentError("fps and accelerometer rate must be positive");
  }
  if (!(depth_scale > 0) || !(min_depth_m >= 0) || !(max_depth_m > min_depth_m) ||
      max_depth_m * depth_scale > 65535) {
    return absl::InvalidArgumentError("depth range and scale must fit a 16-bit PNG");
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    return absl::InvalidArgumentError("jpeg quality must be in [1, 100]");
  }
  if (start_t_ns < 0 || num_threads < 0 || min_visible_px < 1) {
    return absl::InvalidArgumentError("start stamp, threads and min visible pixels must be >= 0");
  }
  return absl::OkStatus();
}

namespace {

// The fr1 camera scaled to the options' image size.
PinholeCamera SceneCamera(const SceneOptions& options) {
  const PinholeCamera fr1 = PinholeCamera::TumFr1();
  const double kx = options.width_px / 640.0, ky = options.height_px / 480.0;
  return {fr1.fx * kx,      fr1.fy * ky,      (fr1.cx + 0.5) * kx - 0.5, (fr1.cy + 0.5) * ky - 0.5,
          options.width_px, options.height_px};
}

SceneObject MakeTable(const Layout& layout, Scene* s, Rng& rng) {
  SceneObject table;
  table.id = 1;
  table.class_name = "dining table";
  table.coco_class_id = CocoClassId(table.class_name);
  Vec3d table_size(rng.Uniform(1.4, 1.8), rng.Uniform(0.8, 0.95), rng.Uniform(0.72, 0.78));
  if (layout.table_size_m) table_size = *layout.table_size_m;
  table.parts = BuildTable(table_size);
  Eigen::Vector2d xy(rng.Uniform(-0.3, 0.3), rng.Uniform(0.1, 0.3));
  if (layout.table_xy_m) xy = *layout.table_xy_m;
  table.T_world_obj = PoseXYYaw(xy.x(), xy.y(), 0, 0);
  Texturize(s, &table, TextureStyle::kWood, HueColor(rng.Uniform(15, 40), 0.6, 0.55), rng);
  return table;
}

SceneObject MakeShelf(Scene* s, Rng& rng) {
  SceneObject shelf;
  shelf.id = 2;
  shelf.class_name = "shelf";
  const Vec3d shelf_size(rng.Uniform(1.0, 1.3), rng.Uniform(0.35, 0.42), rng.Uniform(0.85, 1.0));
  shelf.parts = BuildShelf(shelf_size);
  shelf.T_world_obj =
      PoseXYYaw(rng.Uniform(-1.2, 1.2), s->room_max_m.y() - shelf_size.y() / 2 - 0.02, 0, 0);
  Texturize(s, &shelf, TextureStyle::kWood, HueColor(rng.Uniform(0, 360), 0.4, 0.7), rng);
  return shelf;
}

// Where objects go: the table top, the shelf top and the floor, and what each already holds.
struct Supports {
  int table_id = 0, shelf_id = 0;
  double table_z = 0, shelf_z = 0;
  Rect2 table_area{}, shelf_area{}, floor_area{};
  std::vector<Rect2> floor_forbidden;
  std::vector<Rect2> taken_table, taken_shelf, taken_floor;
};

Supports MakeSupports(const Scene& s, const SceneObject& table, const SceneObject& shelf,
                      bool with_shelf) {
  Supports u;
  Vec3d table_lo, table_hi, shelf_lo, shelf_hi;
  ObjectAabb(table, table.T_world_obj, &table_lo, &table_hi);
  ObjectAabb(shelf, shelf.T_world_obj, &shelf_lo, &shelf_hi);
  u.table_id = table.id;
  u.shelf_id = shelf.id;
  u.table_z = table_hi.z();
  u.shelf_z = shelf_hi.z();
  u.table_area = {table_lo.x() + 0.03, table_lo.y() + 0.03, table_hi.x() - 0.03,
                  table_hi.y() - 0.03};
  u.shelf_area = {shelf_lo.x() + 0.03, shelf_lo.y() + 0.03, shelf_hi.x() - 0.03,
                  shelf_hi.y() - 0.03};
  u.floor_area = {s.room_min_m.x() + 0.4, -0.9, s.room_max_m.x() - 0.4, s.room_max_m.y() - 0.1};
  u.floor_forbidden = {Rect2{table_lo.x(), table_lo.y(), table_hi.x(), table_hi.y()}.Grown(0.12),
                       Rect2{shelf_lo.x(), shelf_lo.y(), shelf_hi.x(), shelf_hi.y()}.Grown(0.08),
                       Rect2{-100, kWalkBandLo, 100, kWalkBandHi}};
  if (!with_shelf) {
    u.shelf_area = {0, 0, -1, -1};  // nothing fits: the shelf's share goes to the others
    u.floor_forbidden.erase(u.floor_forbidden.begin() + 1);
  }
  return u;
}

// Core classes first (shuffled), then the extra ones; objects cycle through the list.
std::vector<ClassSpec> ShuffledClasses(Rng& rng) {
  std::vector<ClassSpec> order[2] = {CoreClasses(), ExtraClasses()};
  for (auto& list : order) {
    for (size_t i = list.size(); i > 1; --i) std::swap(list[i - 1], list[rng.UniformInt(0, i - 1)]);
  }
  std::vector<ClassSpec> classes = order[0];
  classes.insert(classes.end(), order[1].begin(), order[1].end());
  return classes;
}

// Things used from the front are left facing the room.
bool FacesFront(const std::string& class_name) {
  return class_name == "tv" || class_name == "laptop" || class_name == "keyboard" ||
         class_name == "clock";
}

// Places object `k` (0-based) on a support: the allowed one furthest behind its share (table
// 55%, shelf 20%, floor 25%), so every scene has objects on all three; the others are fallbacks.
bool PlaceOnSupport(const ClassSpec& spec, int k, Supports* u, SceneObject* o, Rng& rng) {
  const bool face_front = FacesFront(spec.name);
  std::vector<std::pair<double, int>> choices;
  const double n_placed = k + 1.0;
  auto deficit = [&](double share, size_t have) {
    return share * n_placed - static_cast<double>(have) + rng.Uniform(0, 0.1);
  };
  if (spec.supports & kOnTable) choices.push_back({deficit(0.55, u->taken_table.size()), kOnTable});
  if (spec.supports & kOnShelf) choices.push_back({deficit(0.20, u->taken_shelf.size()), kOnShelf});
  if (spec.supports & kOnFloor) choices.push_back({deficit(0.25, u->taken_floor.size()), kOnFloor});
  std::sort(choices.rbegin(), choices.rend());
  if (!(spec.supports & kOnFloor)) choices.push_back({-1.0, kOnFloor});  // last resort
  for (const auto& [weight, where] : choices) {
    bool placed = false;
    if (where == kOnTable) {
      placed = Place(o, u->table_area, u->table_z, face_front, {}, &u->taken_table, rng);
      o->on_id = u->table_id;
    } else if (where == kOnShelf) {
      placed = Place(o, u->shelf_area, u->shelf_z, face_front, {}, &u->taken_shelf, rng);
      o->on_id = u->shelf_id;
    } else {
      placed = Place(o, u->floor_area, 0.0, false, u->floor_forbidden, &u->taken_floor, rng);
      o->on_id = 0;
    }
    if (placed) return true;
  }
  return false;
}

Status AddObjects(const SceneOptions& options, double hue0, Supports* u, Scene* s, Rng& rng) {
  const std::vector<ClassSpec> classes = ShuffledClasses(rng);
  for (int k = 0; k < options.num_objects; ++k) {
    const ClassSpec& spec = classes[k % classes.size()];
    SceneObject o;
    o.id = 3 + k;
    o.class_name = spec.name;
    o.coco_class_id = spec.coco_id;
    o.parts = BuildClassParts(spec.name, rng);
    RestOnGround(&o.parts);
    if (!PlaceOnSupport(spec, k, u, &o, rng)) {
      return absl::FailedPreconditionError(absl::StrCat("no free place for object ", k + 1, " (",
                                                        spec.name, "); use fewer objects"));
    }
    Texturize(s, &o, TextureStyle::kPrint, ObjectColor(k, hue0, rng), rng);
    s->objects.push_back(std::move(o));
  }
  return absl::OkStatus();
}

// The walking person, from its own random stream: the rest of the scene is the same with and
// without it.
void AddPerson(const SceneOptions& options, double hue0, Scene* s) {
  Rng prng(Rng::Mix(options.seed, 0x9E750));
  SceneObject person;
  person.id = 3 + options.num_objects;
  person.class_name = "person";
  person.coco_class_id = 0;
  person.dynamic = true;
  person.parts = BuildPerson(prng.Uniform(1.65, 1.85));
  const bool left_to_right = prng.Bernoulli(0.5);
  const double x_end = s->room_max_m.x() - 0.5;
  person.walk_start_m =
      Vec3d(left_to_right ? prng.Uniform(-x_end, -0.5) : prng.Uniform(0.5, x_end), kWalkY, 0.0);
  person.walk_end_m = Vec3d(left_to_right ? x_end : -x_end, kWalkY, 0.0);
  person.walk_speed_mps = prng.Uniform(0.9, 1.3);
  Texturize(s, &person, TextureStyle::kPrint, ObjectColor(options.num_objects, hue0, prng), prng);
  s->objects.push_back(std::move(person));
  s->objects.back().T_world_obj = ObjectPoseAt(*s, s->objects.back(), options.start_t_ns);
}

// Takes the objects of `ids` out of the scene; an id that is not there, or that something else
// rests on, is an error.
Status RemoveAbsent(const std::vector<int64_t>& ids, Scene* s) {
  for (int64_t id : ids) {
    const auto it = std::find_if(s->objects.begin(), s->objects.end(),
                                 [&](const SceneObject& o) { return o.id == id; });
    if (it == s->objects.end()) {
      return absl::InvalidArgumentError(absl::StrCat("absent object ", id, " is not in the scene"));
    }
    for (const SceneObject& o : s->objects) {
      if (o.on_id == id) {
        return absl::InvalidArgumentError(
            absl::StrCat("absent object ", id, " holds object ", o.id, ": it stays"));
      }
    }
    s->objects.erase(it);
  }
  return absl::OkStatus();
}

// Puts the objects of `ids` elsewhere on their own support; errors as RemoveAbsent's.
Status MoveObjects(const SceneOptions& options, Supports* u, Scene* s) {
  Rng rng(Rng::Mix(options.seed, 0x30E3D));
  for (int64_t id : options.moved_ids) {
    const auto it = std::find_if(s->objects.begin(), s->objects.end(),
                                 [&](const SceneObject& o) { return o.id == id; });
    if (it == s->objects.end() || it->dynamic || id == u->table_id || id == u->shelf_id) {
      return absl::InvalidArgumentError(absl::StrCat("moved object ", id, " is not a placed object"));
    }
    for (const SceneObject& o : s->objects) {
      if (o.on_id == id) {
        return absl::InvalidArgumentError(
            absl::StrCat("moved object ", id, " holds object ", o.id, ": it stays"));
      }
    }
    const bool face_front = FacesFront(it->class_name);
    const bool placed =
        it->on_id == 0
            ? Place(&*it, u->floor_area, 0.0, false, u->floor_forbidden, &u->taken_floor, rng)
        : it->on_id == u->table_id
            ? Place(&*it, u->table_area, u->table_z, face_front, {}, &u->taken_table, rng)
            : Place(&*it, u->shelf_area, u->shelf_z, face_front, {}, &u->taken_shelf, rng);
    if (!placed) {
      return absl::FailedPreconditionError(
          absl::StrCat("no free place to move object ", id, " to on its support"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

StatusOr<Scene> MakeScene(const SceneOptions& options) {
  LOCI_RETURN_IF_ERROR(options.Validate());
  Scene s;
  s.options = options;
  s.camera = SceneCamera(options);
  Rng rng(Rng::Mix(options.seed, 0x5CE7E));
  const Layout layout = MakeLayout(options);
  s.options.num_objects = layout.num_objects;
  AddRoom(layout, &s, rng);
  const double hue0 = rng.Uniform(0, 360);
  s.objects.push_back(MakeTable(layout, &s, rng));
  const SceneObject shelf = MakeShelf(&s, rng);  // drawn either way: the same stream after it
  if (layout.shelf) s.objects.push_back(shelf);
  Supports supports = MakeSupports(s, s.objects[0], shelf, layout.shelf);
  LOCI_RETURN_IF_ERROR(AddObjects(s.options, hue0, &supports, &s, rng));
  if (options.dynamic) AddPerson(s.options, hue0, &s);
  LOCI_RETURN_IF_ERROR(MoveObjects(options, &supports, &s));
  LOCI_RETURN_IF_ERROR(RemoveAbsent(options.absent_ids, &s));
  const SceneObject& t = s.objects.front();
  const Vec3d target(t.T_world_obj.translation().x(), t.T_world_obj.translation().y(),
                     supports.table_z);
  Rng path_rng(Rng::Mix(options.seed, 0xCA3E7A));
  s.camera_path = CameraPath::Random(target, path_rng);
  return s;
}

int64_t FrameStampNs(const SceneOptions& options, int i) {
  // Whole microseconds, so the stamps survive the 6-decimal TUM text files exactly.
  return options.start_t_ns + std::llround(i * 1e6 / options.fps_hz) * 1000;
}

SE3d CameraPoseAt(const Scene& scene, int64_t t_ns) {
  return scene.camera_path.PoseAt(NsToSeconds(t_ns - scene.options.start_t_ns));
}

SE3d ObjectPoseAt(const Scene& scene, const SceneObject& object, int64_t t_ns) {
  if (!object.dynamic) return object.T_world_obj;
  const Vec3d path = object.walk_end_m - object.walk_start_m;
  const double len = path.norm();
  if (len < 1e-9) return object.T_world_obj;
  const Vec3d dir = path / len;
  const double s =
      std::fmod(std::max(0.0, NsToSeconds(t_ns - scene.options.start_t_ns)) * object.walk_speed_mps,
                2.0 * len);
  const bool outbound = s < len;
  const Vec3d p =
      outbound ? Vec3d(object.walk_start_m + dir * s) : Vec3d(object.walk_end_m - dir * (s - len));
  const Vec3d heading = outbound ? dir : -dir;
  // The object's front (-y) faces the walking direction.
  return PoseXYYaw(p.x(), p.y(), p.z(), std::atan2(heading.y(), heading.x()) + M_PI / 2);
}

void ObjectAabb(const SceneObject& object, const SE3d& T_world_obj, Vec3d* min_m, Vec3d* max_m) {
  PartsAabb(object.parts, T_world_obj, min_m, max_m);
}

GroundTruthScene ToGroundTruth(const Scene& scene) {
  GroundTruthScene gt;
  for (const SceneObject& o : scene.objects) {
    GroundTruthObject g;
    g.id = o.id;
    g.class_name = o.class_name;
    ObjectAabb(o, o.T_world_obj, &g.aabb_min_m, &g.aabb_max_m);
    g.centroid_m = (g.aabb_min_m + g.aabb_max_m) / 2;
    g.extent_m = g.aabb_max_m - g.aabb_min_m;
    g.on_id = o.on_id;
    g.dynamic = o.dynamic;
    gt.objects.push_back(std::move(g));
  }
  return gt;
}

}  // namespace loci::synth

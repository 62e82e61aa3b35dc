#include "query/synthetic_map.h"

#include <cmath>
#include <random>

namespace loci::query {
namespace {

class SceneBuilder {
 public:
  SceneBuilder(const SyntheticMapOptions& o) : opt_(o), rng_(o.seed) {}

  bool Full() const { return scene_.objects.size() >= opt_.object_count; }

  // Adds a box of `size` whose bottom centre is at `base`; returns its id (0 when full).
  int64_t Add(const std::string& cls, const Eigen::Vector3d& base, const Eigen::Vector3d& size,
              int64_t on_id) {
    if (Full()) return 0;
    GroundTruthObject g;
    g.id = static_cast<int64_t>(scene_.objects.size()) + 1;
    g.class_name = cls;
    g.extent_m = size;
    g.aabb_min_m = base - Eigen::Vector3d(size.x() / 2, size.y() / 2, 0);
    g.aabb_max_m = base + Eigen::Vector3d(size.x() / 2, size.y() / 2, size.z());
    g.centroid_m = 0.5 * (g.aabb_min_m + g.aabb_max_m);
    g.on_id = on_id;
    scene_.objects.push_back(g);
    return g.id;
  }
  const GroundTruthObject& Get(int64_t id) const { return scene_.objects[id - 1]; }

  double Jitter(double scale) {
    return std::uniform_real_distribution<double>(-scale, scale)(rng_);
  }
  Eigen::Vector3d Size(double x, double y, double z) {
    const double s = 1.0 + Jitter(0.1);
    return Eigen::Vector3d(x * s, y * s, z * s);
  }
  bool Coin(double p) { return std::uniform_real_distribution<double>(0, 1)(rng_) < p; }

  // Base point on the top of `support` at fractions (fx, fy) of its footprint.
  Eigen::Vector3d OnTop(int64_t support, double fx, double fy) {
    const GroundTruthObject& s = Get(support);
    return Eigen::Vector3d(s.aabb_min_m.x() + fx * s.extent_m.x(),
                           s.aabb_min_m.y() + fy * s.extent_m.y(), s.aabb_max_m.z());
  }

  void Room(double ox, double oy) {
    // Dining table with things on it and chairs around; one chair tucked under.
    const int64_t table = Add("dining table", {ox + 2.0, oy + 2.0, 0}, Size(1.6, 0.9, 0.75), 0);
    if (!table) return;
    const std::pair<const char*, Eigen::Vector3d> items[] = {{"book", {0.22, 0.16, 0.04}},
                                                             {"cup", {0.08, 0.08, 0.10}},
                                                             {"laptop", {0.34, 0.24, 0.02}},
                                                             {"bottle", {0.07, 0.07, 0.25}}};
    const double slots[][2] = {{0.15, 0.3}, {0.4, 0.7}, {0.65, 0.3}, {0.88, 0.7}};
    for (int k = 0; k < 4; ++k) {
      if (!Coin(0.8)) continue;
      const Eigen::Vector3d base =
          OnTop(table, slots[k][0] + Jitter(0.03), slots[k][1] + Jitter(0.05));
      Add(items[k].first, base, Size(items[k].second.x(), items[k].second.y(), items[k].second.z()),
          table);
    }
    // Copies: Add appends to the object vector, which may reallocate under a reference.
    const GroundTruthObject t = Get(table);
    Add("chair", {t.centroid_m.x() - 0.4, t.aabb_max_m.y() + 0.05, 0}, Size(0.45, 0.45, 0.9), 0);
    Add("chair", {t.centroid_m.x() + 0.4, t.aabb_min_m.y() - 0.45, 0}, Size(0.45, 0.45, 0.9), 0);
    if (Coin(0.5)) {
      Add("chair", {t.aabb_max_m.x() + 0.45, t.centroid_m.y(), 0}, Size(0.45, 0.45, 0.9), 0);
    }
    // Desk with a screen, keyboard and mouse; an office chair under it.
    const int64_t desk = Add("dining table", {ox + 1.2, oy + 5.2, 0}, Size(1.2, 0.6, 0.72), 0);
    if (!desk) return;
    Add("tv", OnTop(desk, 0.5, 0.78), Size(0.6, 0.12, 0.4), desk);
    Add("keyboard", OnTop(desk, 0.45, 0.3), Size(0.44, 0.14, 0.03), desk);
    Add("mouse", OnTop(desk, 0.8, 0.3), Size(0.06, 0.1, 0.04), desk);
    if (Coin(0.5)) Add("cup", OnTop(desk, 0.12, 0.35), Size(0.08, 0.08, 0.1), desk);
    const GroundTruthObject d = Get(desk);
    // Seat partly under the desk; the back stays clear of the keyboard.
    Add("chair", {d.centroid_m.x(), d.aabb_min_m.y() - 0.1, 0}, Size(0.45, 0.45, 0.9), 0);
    // Shelf with books on top, a couch and a plant.
    const int64_t shelf = Add("shelf", {ox + 5.0, oy + 0.4, 0}, Size(0.8, 0.3, 1.2), 0);
    if (!shelf) return;
    Add("book", OnTop(shelf, 0.25, 0.5), Size(0.16, 0.22, 0.04), shelf);
    if (Coin(0.5)) Add("potted plant", OnTop(shelf, 0.75, 0.5), Size(0.15, 0.15, 0.3), shelf);
    Add("couch", {ox + 4.4, oy + 4.6, 0}, Size(2.0, 0.9, 0.8), 0);
    Add("potted plant", {ox + 5.5, oy + 3.0, 0}, Size(0.35, 0.35, 0.9), 0);
  }

  GroundTruthScene Build() {
    const int rooms_per_row = std::max(
        1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(opt_.object_count) / 16.0))));
    for (int r = 0; !Full(); ++r) {
      Room((r % rooms_per_row) * opt_.room_m, (r / rooms_per_row) * opt_.room_m);
    }
    return scene_;
  }

 private:
  SyntheticMapOptions opt_;
  std::mt19937_64 rng_;
  GroundTruthScene scene_;
};

}  // namespace

GroundTruthScene MakeSyntheticOffice(const SyntheticMapOptions& options) {
  return SceneBuilder(options).Build();
}

std::vector<MapObject> MapObjectsFromGroundTruth(const GroundTruthScene& scene, int64_t t_ns,
                                                 const std::string& robot, double confidence) {
  std::vector<MapObject> out;
  out.reserve(scene.objects.size());
  for (const GroundTruthObject& g : scene.objects) {
    MapObject o;
    o.id = g.id;
    o.class_name = g.class_name;
    o.confidence = confidence;
    o.labels = {{g.class_name, confidence}};
    if (confidence < 1.0) o.labels.push_back({"other", 1.0 - confidence});
    o.centroid_m = g.centroid_m;
    o.aabb_min_m = g.aabb_min_m;
    o.aabb_max_m = g.aabb_max_m;
    o.obb_center_m = 0.5 * (g.aabb_min_m + g.aabb_max_m);
    o.obb_half_extent_m = 0.5 * (g.aabb_max_m - g.aabb_min_m);
    o.first_seen_ns = t_ns;
    o.last_seen_ns = t_ns;
    if (!robot.empty()) {
      o.robots = {robot};
      o.last_robot = robot;
    }
    o.observation_count = 1;
    o.confirmed = true;
    out.push_back(std::move(o));
  }
  return out;
}

}  // namespace loci::query

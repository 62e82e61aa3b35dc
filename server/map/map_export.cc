#include "server/map/map_export.h"

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

namespace loci::server {
namespace {

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

Status WritePly(const std::string& path, const std::vector<SemanticPoint>& points) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return absl::UnavailableError(absl::StrCat("cannot write ", path));
  out << "ply\nformat binary_little_endian 1.0\ncomment loci semantic cloud, map frame, metres\n"
      << "element vertex " << points.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      << "property int object_id\nend_header\n";
  for (const SemanticPoint& p : points) {
    char rec[19];
    std::memcpy(rec, p.p_m.data(), 12);
    rec[12] = static_cast<char>((p.rgb >> 16) & 0xff);
    rec[13] = static_cast<char>((p.rgb >> 8) & 0xff);
    rec[14] = static_cast<char>(p.rgb & 0xff);
    const int32_t id = static_cast<int32_t>(p.object_id);
    std::memcpy(rec + 15, &id, 4);
    out.write(rec, sizeof(rec));
  }
  if (!out) return absl::UnavailableError(absl::StrCat("write failed: ", path));
  return absl::OkStatus();
}

Status WriteObjectsJsonExport(const std::string& path, const std::vector<MapObject>& objects,
                              const Vec3d& up) {
  nlohmann::json arr = nlohmann::json::array();
  for (const MapObject& o : objects) {
    nlohmann::json labels = nlohmann::json::object();
    for (const auto& [name, p] : o.labels) labels[name] = p;
    const Eigen::Quaterniond q(o.R_map_box);
    arr.push_back({{"id", o.id},
                   {"class_name", o.class_name},
                   {"confidence", o.confidence},
                   {"labels", labels},
                   {"centroid_m", Vec(o.centroid_m)},
                   {"extent_m", Vec(o.aabb_max_m - o.aabb_min_m)},
                   {"aabb_min_m", Vec(o.aabb_min_m)},
                   {"aabb_max_m", Vec(o.aabb_max_m)},
                   {"obb",
                    {{"center_m", Vec(o.obb_center_m)},
                     {"half_extent_m", Vec(o.obb_half_extent_m)},
                     {"q_map_box_wxyz", {q.w(), q.x(), q.y(), q.z()}}}},
                   {"first_seen_ns", o.first_seen_ns},
                   {"last_seen_ns", o.last_seen_ns},
                   {"robots", o.robots},
                   {"last_robot", o.last_robot},
                   {"observation_count", o.observation_count},
                   {"missed_views", o.missed_views},
                   {"existence", o.existence},
                   {"point_count", o.point_count},
                   {"confirmed", o.confirmed},
                   {"on", nullptr},
                   {"dynamic", false}});
  }
  const nlohmann::json j = {{"frame", "map"}, {"up", Vec(up)}, {"objects", arr}};
  std::ofstream out(path);
  if (!out) return absl::UnavailableError(absl::StrCat("cannot write ", path));
  out << j.dump(2) << "\n";
  if (!out) return absl::UnavailableError(absl::StrCat("write failed: ", path));
  return absl::OkStatus();
}

}  // namespace loci::server

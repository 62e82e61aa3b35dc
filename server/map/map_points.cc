#include "server/map/map_points.h"

namespace loci::server {

std::vector<ColoredPoint> ObservationPointsMap(const ObjectObservation& o,
                                               const Eigen::Isometry3f& T_map_kf) {
  std::vector<ColoredPoint> points;
  points.reserve(o.cloud_kf.size());
  for (const auto& p : o.cloud_kf) {
    points.push_back({T_map_kf * p.getVector3fMap(), PackRgb(p.r, p.g, p.b)});
  }
  return points;
}

std::vector<SemanticPoint> StaticPointsMap(const KeyframeProducts& products,
                                           const Eigen::Isometry3f& T_map_kf,
                                           const std::vector<int64_t>& object_ids) {
  std::vector<SemanticPoint> points;
  points.reserve(products.static_cloud_kf.size());
  for (const auto& p : products.static_cloud_kf) {
    const int64_t object_id =
        p.label > 0 && p.label <= object_ids.size() ? object_ids[p.label - 1] : 0;
    points.push_back({T_map_kf * p.getVector3fMap(), PackRgb(p.r, p.g, p.b), object_id});
  }
  return points;
}

}  // namespace loci::server

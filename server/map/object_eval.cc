#include "server/map/object_eval.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace loci::server {

ObjectEvalResult EvaluateObjects(const std::vector<MapObject>& objects, const GroundTruthScene& gt,
                                 const ObjectEvalOptions& options) {
  auto evaluated = [&](const std::string& cls) {
    return options.classes.empty() ||
           std::find(options.classes.begin(), options.classes.end(), cls) != options.classes.end();
  };
  std::vector<const GroundTruthObject*> g;
  for (const auto& o : gt.objects) {
    if (!o.dynamic && evaluated(o.class_name)) g.push_back(&o);
  }
  std::vector<const MapObject*> d;
  for (const auto& o : objects) {
    if (evaluated(o.class_name)) d.push_back(&o);
  }
  ObjectEvalResult r;
  r.gt_count = static_cast<int>(g.size());
  r.detected_count = static_cast<int>(d.size());
  r.count_error = r.gt_count > 0
                      ? std::abs(r.detected_count - r.gt_count) / static_cast<double>(r.gt_count)
                      : (r.detected_count > 0 ? 1.0 : 0.0);
  std::vector<std::tuple<double, size_t, size_t>> pairs;
  for (size_t i = 0; i < g.size(); ++i) {
    for (size_t j = 0; j < d.size(); ++j) {
      if (g[i]->class_name != d[j]->class_name) continue;
      const double dist = (g[i]->centroid_m - d[j]->centroid_m).norm();
      if (dist <= options.max_match_m) pairs.emplace_back(dist, i, j);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<bool> g_used(g.size(), false), d_used(d.size(), false);
  double sum = 0;
  for (const auto& [dist, i, j] : pairs) {
    if (g_used[i] || d_used[j]) continue;
    g_used[i] = d_used[j] = true;
    r.matches.push_back({g[i]->id, d[j]->id, g[i]->class_name, dist});
    sum += dist;
    r.max_centroid_error_m = std::max(r.max_centroid_error_m, dist);
  }
  if (!r.matches.empty()) r.mean_centroid_error_m = sum / r.matches.size();
  for (size_t i = 0; i < g.size(); ++i) {
    if (!g_used[i]) r.missed_gt_ids.push_back(g[i]->id);
  }
  for (size_t j = 0; j < d.size(); ++j) {
    if (!d_used[j]) r.false_positive_ids.push_back(d[j]->id);
  }
  return r;
}

}  // namespace loci::server

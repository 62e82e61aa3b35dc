#include "server/map/object_eval.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "detection/hungarian.h"

namespace loci::server {
namespace {

constexpr double kForbidden = 1e9;

// The ground-truth point a map centroid p is compared with: the nearer of the centroid and the
// centre of the visible part.
const Eigen::Vector3d& NearestReference(const GroundTruthObject& g, const Eigen::Vector3d& p) {
  if (g.visible_part_centroid_m &&
      (*g.visible_part_centroid_m - p).norm() < (g.centroid_m - p).norm()) {
    return *g.visible_part_centroid_m;
  }
  return g.centroid_m;
}

double DistanceTo(const GroundTruthObject& g, const Eigen::Vector3d& p) {
  return (NearestReference(g, p) - p).norm();
}

// Matches one class: rows = map objects, columns = GT objects (every confidence).
void EvaluateClass(const std::vector<const MapObject*>& d,
                   const std::vector<const GroundTruthObject*>& g,
                   const ObjectEvalOptions& options, ClassEval* row, ObjectEvalResult* r) {
  std::vector<std::vector<double>> cost(d.size(), std::vector<double>(g.size(), kForbidden));
  for (size_t i = 0; i < d.size(); ++i) {
    for (size_t j = 0; j < g.size(); ++j) {
      const double dist = DistanceTo(*g[j], d[i]->centroid_m);
      const double radius_m =
          options.max_match_m + (g[j]->confidence == "low" ? options.low_tolerance_m : 0.0);
      if (dist <= radius_m) cost[i][j] = dist;
    }
  }
  const std::vector<int> assigned =
      g.empty() ? std::vector<int>(d.size(), -1) : detection::SolveAssignment(cost, kForbidden);
  std::vector<bool> g_used(g.size(), false);
  for (size_t i = 0; i < d.size(); ++i) {
    const int j = assigned[i];
    if (j < 0 || cost[i][j] >= kForbidden) {
      ++row->fp;
      r->false_positive_ids.push_back(d[i]->id);
      continue;
    }
    g_used[j] = true;
    ObjectMatch m{g[j]->id, g[j]->name, d[i]->id, row->class_name, cost[i][j],
                  d[i]->centroid_m - NearestReference(*g[j], d[i]->centroid_m),
                  g[j]->confidence == "low"};
    if (m.neutral) {
      ++row->neutral;
    } else {
      ++row->tp;
    }
    r->matches.push_back(std::move(m));
  }
  for (size_t j = 0; j < g.size(); ++j) {
    if (g_used[j] || g[j]->confidence == "low") continue;
    ++row->fn;
    r->missed_gt_ids.push_back(g[j]->id);
    r->missed_gt_names.push_back(g[j]->name);
  }
}

void Summarise(ObjectEvalResult* r) {
  int fp = 0;
  std::vector<double> errors;
  for (const ClassEval& c : r->classes) {
    r->gt_count += c.gt;
    r->true_positives += c.tp;
    fp += c.fp;
  }
  for (const ObjectMatch& m : r->matches) {
    if (!m.neutral) errors.push_back(m.centroid_error_m);
  }
  r->detected_count = r->true_positives + fp;
  r->count_error = r->gt_count > 0 ? std::abs(r->detected_count - r->gt_count) /
                                         static_cast<double>(r->gt_count)
                                   : (r->detected_count > 0 ? 1.0 : 0.0);
  r->precision = r->detected_count > 0 ? r->true_positives / double(r->detected_count) : 0.0;
  r->recall = r->gt_count > 0 ? r->true_positives / double(r->gt_count) : 0.0;
  r->f1 = r->precision + r->recall > 0
              ? 2 * r->precision * r->recall / (r->precision + r->recall)
              : 0.0;
  if (errors.empty()) return;
  std::sort(errors.begin(), errors.end());
  double sum = 0;
  for (double e : errors) sum += e;
  r->mean_centroid_error_m = sum / errors.size();
  const size_t n = errors.size();
  r->median_centroid_error_m = n % 2 ? errors[n / 2] : 0.5 * (errors[n / 2 - 1] + errors[n / 2]);
  r->max_centroid_error_m = errors.back();
}

}  // namespace

ObjectEvalResult EvaluateObjects(const std::vector<MapObject>& objects, const GroundTruthScene& gt,
                                 const ObjectEvalOptions& options) {
  auto evaluated = [&](const std::string& cls) {
    return options.classes.empty() ||
           std::find(options.classes.begin(), options.classes.end(), cls) != options.classes.end();
  };
  std::set<std::string> classes;
  for (const auto& o : gt.objects) {
    if (!o.dynamic && evaluated(o.class_name)) classes.insert(o.class_name);
  }
  for (const auto& o : objects) {
    if (evaluated(o.class_name)) classes.insert(o.class_name);
  }
  ObjectEvalResult r;
  for (const std::string& cls : classes) {
    std::vector<const GroundTruthObject*> g;
    std::vector<const MapObject*> d;
    ClassEval row;
    row.class_name = cls;
    for (const auto& o : gt.objects) {
      if (o.dynamic || o.class_name != cls) continue;
      g.push_back(&o);
      ++(o.confidence == "low" ? row.gt_low : row.gt);
    }
    for (const auto& o : objects) {
      if (o.class_name == cls) d.push_back(&o);
    }
    row.mapped = static_cast<int>(d.size());
    EvaluateClass(d, g, options, &row, &r);
    r.classes.push_back(row);
  }
  Summarise(&r);
  return r;
}

}  // namespace loci::server

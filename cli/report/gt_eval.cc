#include "cli/report/gt_eval.h"

#include <absl/strings/str_cat.h>
#include <absl/strings/str_format.h>
#include <absl/strings/str_join.h>

#include <algorithm>
#include <cmath>

namespace loci::report {
namespace {

bool Counted(const GroundTruthObject& g) { return !g.dynamic && g.confidence != "low"; }

bool Evaluated(const server::ObjectEvalOptions& o, const std::string& cls) {
  return o.classes.empty() || std::find(o.classes.begin(), o.classes.end(), cls) != o.classes.end();
}

std::vector<OnPairCheck> CheckOnPairs(const GroundTruthEvalInput& in,
                                      const server::ObjectEvalResult& r) {
  std::map<int64_t, int64_t> map_id_of;  // GT id -> matched map object (true positives)
  for (const auto& m : r.matches) {
    if (!m.neutral) map_id_of[m.gt_id] = m.object_id;
  }
  std::map<int64_t, const GroundTruthObject*> by_id;
  for (const auto& g : in.gt.objects) by_id[g.id] = &g;
  std::vector<OnPairCheck> out;
  for (const auto& x : in.gt.objects) {
    if (x.on_id == 0 || !by_id.count(x.on_id)) continue;
    const GroundTruthObject& y = *by_id[x.on_id];
    if (!Counted(x) || !Counted(y) || !Evaluated(in.options, x.class_name) ||
        !Evaluated(in.options, y.class_name)) {
      continue;
    }
    OnPairCheck c;
    c.gt_subject = x.name;
    c.gt_support = y.name;
    c.question = absl::StrCat("where is the ", x.class_name, " on the ", y.class_name);
    c.subject_id = map_id_of.count(x.id) ? map_id_of[x.id] : 0;
    c.support_id = map_id_of.count(y.id) ? map_id_of[y.id] : 0;
    const loci::v1::AskResponse resp = in.ask(c.question);
    c.answer = resp.answer();
    for (const auto& rel : resp.relations()) {
      c.right |= c.subject_id != 0 && c.support_id != 0 && rel.name() == "on" &&
                 rel.subject_id() == c.subject_id && rel.anchor_id() == c.support_id;
    }
    out.push_back(std::move(c));
  }
  return out;
}

// Angle between the map's +z carried into the world by R_world_map and the world's up (deg).
double UpErrorDeg(const Mat3d& R_world_map, const Vec3d& up_world) {
  const Vec3d map_up_world = R_world_map * Vec3d::UnitZ();
  return std::acos(std::clamp(map_up_world.dot(up_world.normalized()), -1.0, 1.0)) * 180.0 /
         M_PI;
}

}  // namespace

StatusOr<GroundTruthEval> EvaluateAgainstGroundTruth(const GroundTruthEvalInput& in) {
  Trajectory stacked;
  for (const Trajectory& t : in.keyframes) stacked.insert(stacked.end(), t.begin(), t.end());
  std::sort(stacked.begin(), stacked.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.t_ns < b.t_ns; });
  GroundTruthEval e;
  LOCI_ASSIGN_OR_RETURN(e.alignment, ComputeAte(in.groundtruth, stacked));
  const Mat3d R_gt_map_positions = e.alignment.T_gt_est.linear();
  if (in.align_by_orientations) {
    LOCI_ASSIGN_OR_RETURN(e.alignment.T_gt_est, AlignByOrientations(in.groundtruth, stacked));
    e.aligned_by_orientations = true;
  }
  std::vector<MapObject> in_world;
  for (const MapObject& o : in.objects) in_world.push_back(Transformed(o, e.alignment.T_gt_est));
  e.objects = server::EvaluateObjects(in_world, in.gt, in.options);
  e.objects_world = in_world;
  e.radius_m = in.options.max_match_m;
  e.low_tolerance_m = in.options.low_tolerance_m;
  e.up_error_deg = UpErrorDeg(e.alignment.T_gt_est.linear(), in.gt.up);
  LOCI_ASSIGN_OR_RETURN(const Mat3d R_gt_map, OrientationAlignment(in.groundtruth, stacked));
  e.up_error_orientation_deg = UpErrorDeg(R_gt_map, in.gt.up);
  e.alignment_disagreement_deg =
      Eigen::AngleAxisd(R_gt_map.transpose() * R_gt_map_positions).angle() * 180.0 /
      M_PI;
  if (in.ask) {
    e.on_pairs = CheckOnPairs(in, e.objects);
    for (const OnPairCheck& c : e.on_pairs) e.on_right += c.right;
    e.on_share = e.on_pairs.empty() ? 0.0 : e.on_right / static_cast<double>(e.on_pairs.size());
  }
  return e;
}

std::string FormatGroundTruthEval(const GroundTruthEval& e) {
  const server::ObjectEvalResult& r = e.objects;
  std::string s = absl::StrFormat(
      "alignment: keyframe trajectory vs ground truth, %zu pairs, ATE rmse %.4f m; objects "
      "aligned by %s; map +z is %.1f deg from the ground truth's up\n"
      "  check: aligned by the camera orientations, map +z is %.1f deg from up; the positions' "
      "and the orientations' alignments differ by %.1f deg\n",
      e.alignment.pairs, e.alignment.trans_m.rmse,
      e.aligned_by_orientations ? "the camera orientations (--align orientations)"
                                : "positions (TUM)",
      e.up_error_deg, e.up_error_orientation_deg, e.alignment_disagreement_deg);
  absl::StrAppendFormat(&s, "matching radius %.2f m (%.2f m for low objects)\n", e.radius_m,
                        e.radius_m + e.low_tolerance_m);
  absl::StrAppendFormat(&s, "%-14s %4s %4s %5s %4s %4s %4s %7s\n", "class", "gt", "low", "map",
                        "tp", "fp", "fn", "neutral");
  for (const server::ClassEval& c : r.classes) {
    absl::StrAppendFormat(&s, "%-14s %4d %4d %5d %4d %4d %4d %7d\n", c.class_name, c.gt,
                          c.gt_low, c.mapped, c.tp, c.fp, c.fn, c.neutral);
  }
  absl::StrAppendFormat(&s,
                        "precision %.3f  recall %.3f  F1 %.3f  count error %.1f %% (D %d, GT %d)\n",
                        r.precision, r.recall, r.f1, 100 * r.count_error, r.detected_count,
                        r.gt_count);
  absl::StrAppendFormat(&s, "centroid error over %d matches: mean %.3f m, median %.3f m, max %.3f m\n",
                        r.true_positives, r.mean_centroid_error_m, r.median_centroid_error_m,
                        r.max_centroid_error_m);
  for (const auto& m : r.matches) {
    const MapObject* o = nullptr;
    for (const MapObject& w : e.objects_world) o = w.id == m.object_id ? &w : o;
    absl::StrAppendFormat(&s, "  %-14s %-18s -> #%-4d %.3f m  %u views, %u missed, existence %.2f%s\n",
                          m.class_name, m.gt_name, m.object_id, m.centroid_error_m,
                          o ? o->observation_count : 0, o ? o->missed_views : 0,
                          o ? o->existence : 0.0, m.neutral ? " (low: not counted)" : "");
  }
  if (!r.missed_gt_names.empty()) {
    absl::StrAppend(&s, "  missed: ", absl::StrJoin(r.missed_gt_names, ", "), "\n");
  }
  for (int64_t id : r.false_positive_ids) {
    for (const MapObject& o : e.objects_world) {
      if (o.id != id) continue;
      absl::StrAppendFormat(&s, "  false positive #%d %s at (%.2f, %.2f, %.2f) world, %u views, "
                            "%u missed, existence %.2f, size %.2f m, z %.2f..%.2f m\n", id,
                            o.class_name, o.centroid_m.x(), o.centroid_m.y(), o.centroid_m.z(),
                            o.observation_count, o.missed_views, o.existence,
                            (o.aabb_max_m - o.aabb_min_m).maxCoeff(), o.aabb_min_m.z(),
                            o.aabb_max_m.z());
    }
  }
  if (!e.on_pairs.empty()) {
    absl::StrAppendFormat(&s, "X-on-Y answers right: %d of %zu (%.0f %%)\n", e.on_right,
                          e.on_pairs.size(), 100 * e.on_share);
    // The relations apart from detection: pairs whose two objects both have a map object.
    int mapped = 0, mapped_right = 0;
    for (const OnPairCheck& c : e.on_pairs) {
      const bool both = c.subject_id != 0 && c.support_id != 0;
      mapped += both;
      mapped_right += both && c.right;
    }
    absl::StrAppendFormat(&s, "  of the %d pairs whose X and Y are both matched: %d right\n",
                          mapped, mapped_right);
    for (const OnPairCheck& c : e.on_pairs) {
      absl::StrAppendFormat(&s, "  [%s] %s on %s: \"%s?\" -> %s\n", c.right ? "ok" : "--",
                            c.gt_subject, c.gt_support, c.question, c.answer);
    }
  }
  return s;
}

}  // namespace loci::report

// Markdown tables of `loci bench report` (the layout of papers 000 Tables 4 and 6).
#include <absl/strings/str_format.h>
#include <absl/strings/str_join.h>

#include <map>
#include <thread>

#include "cli/report/report_pipeline.h"

namespace loci::report {
namespace {

std::string V3(const Eigen::Vector3d& v) {
  return absl::StrFormat("(%.2f, %.2f, %.2f)", v.x(), v.y(), v.z());
}

void SynthTable(std::string* md, const char* name, const server::ObjectEvalResult& e) {
  absl::StrAppendFormat(md, "| %s | %d | %d | %.3f | %zu | %zu | %zu | %.3f | %.3f |\n", name,
                        e.gt_count, e.detected_count, e.count_error, e.matches.size(),
                        e.false_positive_ids.size(), e.missed_gt_ids.size(),
                        e.mean_centroid_error_m, e.max_centroid_error_m);
}

void HandMadeTotals(std::string* md, const char* alignment, const GroundTruthEval& e) {
  const server::ObjectEvalResult& r = e.objects;
  absl::StrAppendFormat(md, "| %s | %.3f | %.3f | %.3f | %.1f %% | %.3f | %.3f | %d / %zu |\n",
                        alignment, r.precision, r.recall, r.f1, 100 * r.count_error,
                        r.mean_centroid_error_m, r.median_centroid_error_m, e.on_right,
                        e.on_pairs.size());
}

void HandMadeSection(std::string* md, const GroundTruthEval& e,
                     const std::optional<GroundTruthEval>& by_orientations) {
  const server::ObjectEvalResult& r = e.objects;
  *md += "\n### Objects against hand-made ground truth (`loci eval objects` method)\n\n";
  absl::StrAppendFormat(md,
                        "Map aligned to the ground-truth world with %zu keyframe poses (ATE rmse "
                        "%.4f m); per-class Hungarian matching within %.2f m (%.2f m for `low` "
                        "objects, placed to +-0.2 m); `low` objects neither count nor hurt.\n\n",
                        e.alignment.pairs, e.alignment.trans_m.rmse, e.radius_m,
                        e.radius_m + e.low_tolerance_m);
  *md += "| class | GT (high+medium) | GT low | map | TP | FP | FN | matched to low |\n";
  *md += "|---|---|---|---|---|---|---|---|\n";
  for (const server::ClassEval& c : r.classes) {
    absl::StrAppendFormat(md, "| %s | %d | %d | %d | %d | %d | %d | %d |\n", c.class_name, c.gt,
                          c.gt_low, c.mapped, c.tp, c.fp, c.fn, c.neutral);
  }
  *md += "\n| map aligned by | precision | recall | F1 | count error | mean centroid err (m) | "
         "median (m) | X-on-Y answers right |\n|---|---|---|---|---|---|---|---|\n";
  HandMadeTotals(md, "positions (TUM)", e);
  if (by_orientations) {
    HandMadeTotals(md, absl::StrFormat("camera orientations (%.1f deg from the positions')",
                                       e.alignment_disagreement_deg).c_str(),
                   *by_orientations);
  }
  *md += "\nThe class rows are for the positions' alignment.\n";
  if (!r.missed_gt_names.empty()) {
    absl::StrAppendFormat(md, "\nMissed: %s.\n", absl::StrJoin(r.missed_gt_names, ", "));
  }
  // Each match and false positive with its evidence, as `loci eval objects` prints them.
  absl::StrAppendFormat(md, "\n```\n%s```\n", FormatGroundTruthEval(e));
}

}  // namespace

std::string FormatMarkdown(const ReportResult& r, const ReportOptions& o,
                           const std::string& title) {
  std::string md = absl::StrFormat("## %s\n\n", title);
  absl::StrAppendFormat(&md,
                        "Data `%s`: %zu frames, %zu tracked, %zu keyframes; detections: %s; "
                        "%u hardware threads.\n\n",
                        o.tum_dir, r.frames, r.tracked, r.keyframes, r.detector_name,
                        std::thread::hardware_concurrency());

  md += "### Trajectory (client alone, TUM definitions)\n\n";
  md += "| metric | RMSE | mean | median | max | pairs |\n|---|---|---|---|---|---|\n";
  if (r.ate) {
    const auto& t = r.ate->trans_m;
    absl::StrAppendFormat(&md, "| ATE (m) | %.4f | %.4f | %.4f | %.4f | %zu |\n", t.rmse, t.mean,
                          t.median, t.max, r.ate->pairs);
  }
  if (r.rpe) {
    const auto& t = r.rpe->trans_m;
    const auto& q = r.rpe->rot_rad;
    absl::StrAppendFormat(&md, "| RPE trans (m / %.0f s) | %.4f | %.4f | %.4f | %.4f | %zu |\n",
                          r.rpe->delta_s, t.rmse, t.mean, t.median, t.max, r.rpe->pairs);
    absl::StrAppendFormat(&md, "| RPE rot (deg / %.0f s) | %.3f | %.3f | %.3f | %.3f | %zu |\n",
                          r.rpe->delta_s, q.rmse * 180 / M_PI, q.mean * 180 / M_PI,
                          q.median * 180 / M_PI, q.max * 180 / M_PI, r.rpe->pairs);
  }
  if (!r.ate && !r.rpe) md += "| (no groundtruth.txt) | | | | | |\n";

  md +=
      "\n### Objects per class (confirmed)\n\n| class | estimated poses | ground-truth poses |\n"
      "|---|---|---|\n";
  std::map<std::string, std::pair<int, int>> per_class;
  for (const MapObject& m : r.objects_est) ++per_class[m.class_name].first;
  for (const MapObject& m : r.objects_gt_poses) ++per_class[m.class_name].second;
  for (const auto& [cls, c] : per_class) {
    absl::StrAppendFormat(&md, "| %s | %d | %d |\n", cls, c.first, c.second);
  }
  absl::StrAppendFormat(&md, "| **total** | %zu | %zu |\n", r.objects_est.size(),
                        r.objects_gt_poses.size());

  if (!r.pairs.empty()) {
    absl::StrAppendFormat(
        &md,
        "\n### Object centroids: estimated vs ground-truth poses (paper 000 Table 4 method)\n\n"
        "Same keyframes and detections mapped twice; the estimated map is moved into the "
        "ground-truth frame by the ATE alignment; pairs by class + nearest centroid within "
        "%.2f m.\n\n| id | class | centroid, est. poses (m) | centroid, GT poses (m) | error (m) "
        "|\n"
        "|---|---|---|---|---|\n",
        o.match_max_m);
    for (const ObjectPair& p : r.pairs) {
      absl::StrAppendFormat(&md, "| %d | %s | %s | %s | %s |\n", p.est.id, p.est.class_name,
                            V3(p.est.centroid_m), p.gt ? V3(p.gt->centroid_m) : "no partner",
                            p.gt ? absl::StrFormat("%.3f", p.error_m) : "-");
    }
    absl::StrAppendFormat(&md,
                          "\n**Mean centroid error: %.3f m over %d matched objects** (of %zu)\n",
                          r.mean_pair_error_m, r.matched_pairs, r.pairs.size());
  }

  if (r.synth_est) {
    md +=
        "\n### Against the synthetic scene's true objects (paper 000 eq. 24)\n\n"
        "| map | GT objects | detected | count error | matched | false pos. | missed | "
        "mean centroid err (m) | max (m) |\n|---|---|---|---|---|---|---|---|---|\n";
    SynthTable(&md, "estimated poses", *r.synth_est);
    if (r.synth_gt_poses) SynthTable(&md, "ground-truth poses", *r.synth_gt_poses);
  }
  if (r.gt_eval) HandMadeSection(&md, *r.gt_eval, r.gt_eval_orientations);

  const double reduction =
      r.cloud_points ? 100.0 * (1.0 - static_cast<double>(r.object_voxel_points) / r.cloud_points)
                     : 0;
  absl::StrAppendFormat(
      &md,
      "\n### Map size (paper 000 Table 6)\n\nDense cloud and object-only cloud on the same "
      "voxel grid (the dense cloud's); the objects' own clouds use finer adaptive voxels.\n\n"
      "| dense cloud points | object-only points | reduction | dense points labelled with an "
      "object | object clouds (own voxels) | OctoMap nodes | OctoMap .bt bytes | OctoMap "
      "resolution |\n|---|---|---|---|---|---|---|---|\n| %zu | %zu | %.1f %% | %zu | %zu | %llu "
      "| %zu | %.2f m |\n",
      r.cloud_points, r.object_voxel_points, reduction, r.object_points, r.object_cloud_points,
      static_cast<unsigned long long>(r.octomap_nodes), r.octomap_bytes, r.octomap_resolution_m);

  absl::StrAppendFormat(
      &md,
      "\n### Timing (wall clock, one process, stages run one after another)\n\n"
      "| tracking ms/frame | detection ms/keyframe | server ingest ms/keyframe (wall; CPU) | "
      "bytes/keyframe streamed |\n|---|---|---|---|\n| %.1f | %s | %.1f; %.1f | %.0f |\n",
      r.track_ms_per_frame,
      r.detect_ms_per_keyframe > 0 ? absl::StrFormat("%.1f", r.detect_ms_per_keyframe)
                                   : std::string("- (file)"),
      r.ingest_ms_per_keyframe, r.ingest_cpu_ms_per_keyframe, r.bytes_per_keyframe);
  return md;
}

}  // namespace loci::report

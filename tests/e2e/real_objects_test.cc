// The object map on real data (a TUM RGB-D sequence with a hand-made object ground truth),
// through the same pipeline as the demo run in one process (client with YOLOX-Nano, synchronous,
// and the server's mapper): the figures stay at least where they were measured, the map frame is
// level, and the same input gives the same map twice (on the shipped sample).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "cli/report/report_pipeline.h"
#include "tests/support/tum_data.h"

namespace loci::report {
namespace {

namespace fs = std::filesystem;

TEST(RealObjects, Fr1RpyAgainstHandMadeGroundTruth) {
  const std::string dir = loci::testing::FullTumSequence("tum_fr1_rpy", {"objects_gt.json"});
  if (dir.empty()) GTEST_SKIP() << "no tum_fr1_rpy with objects_gt.json in $LOCI_DATA or ../shared/data";
  ReportOptions o;
  o.tum_dir = dir;
  o.objects_gt = dir + "/objects_gt.json";
  o.progress = false;
  auto r = RunReport(o);
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_TRUE(r->gt_eval.has_value());
  const GroundTruthEval& e = *r->gt_eval;
  const server::ObjectEvalResult& m = e.objects;
  std::printf("objects: precision %.3f recall %.3f F1 %.3f count error %.3f centroid %.3f m, "
              "X-on-Y %d/%zu, map up %.2f deg from ground truth (%.2f deg by the orientations)\n",
              m.precision, m.recall, m.f1, m.count_error, m.mean_centroid_error_m, e.on_right,
              e.on_pairs.size(), e.up_error_deg, e.up_error_orientation_deg);
  if (r->gt_eval_orientations) {
    const server::ObjectEvalResult& by_rot = r->gt_eval_orientations->objects;
    std::printf("aligned by the camera orientations (%.1f deg from the positions'): "
                "precision %.3f recall %.3f count error %.3f centroid %.3f m\n",
                e.alignment_disagreement_deg, by_rot.precision, by_rot.recall, by_rot.count_error,
                by_rot.mean_centroid_error_m);
  }
  // The map frame is level: its z within 3 deg of the ground truth's up (itself z within 2-4 deg),
  // with the map turned into the world by the camera orientations. The positions' alignment (the
  // TUM way, used for the object figures) is ill-conditioned in rotation when the camera turns in
  // place, so it cannot tell whether the map is level.
  EXPECT_LT(e.up_error_orientation_deg, 3.0);
  // Floors about one object (1/15 = 0.067) below the figures of the general object model with
  // YOLOX-Nano: precision 0.82 here (0.90 through the demo's gRPC stream), recall 0.60, count
  // error 27-33 %, centroid 0.10 m. Recall is capped by the detector: YOLOX-Nano boxes 10 of
  // the 15 objects at all.
  EXPECT_GE(m.precision, 0.75);
  EXPECT_GE(m.recall, 0.53);
  EXPECT_LE(m.count_error, 0.40);
  EXPECT_LE(m.mean_centroid_error_m, 0.12);
  // "Where is the X on the Y" is right only when both are mapped and X rests on Y's top: 3 of
  // 10 pairs measured, one less allowed.
  EXPECT_GE(e.on_right, 2);
  ASSERT_TRUE(r->gt_eval_orientations.has_value());
  EXPECT_GE(r->gt_eval_orientations->on_right, 2);
}

// The evaluation itself: a map in its own frame (turned 90 deg, shifted) is aligned to the world
// by the keyframes; the desk is matched by its visible top; "where is the keyboard on the
// dining table" is right only when the answer relates the two matched objects.
TEST(GroundTruthEval, AlignsByTheTrajectoryAndChecksOnPairs) {
  const SE3d T_map_world = MakeSE3(Vec3d(0.3, -2.0, -1.2),
                                   Quatd(Eigen::AngleAxisd(M_PI / 2, Vec3d::UnitZ())));
  GroundTruthEvalInput in;
  Trajectory map_kfs;
  for (int i = 0; i < 20; ++i) {
    const SE3d T_world_cam = MakeSE3(Vec3d(0.1 * i, 0.05 * i * i, 1.5),
                                     Quatd(Eigen::AngleAxisd(0.1 * i, Vec3d::UnitY())));
    in.groundtruth.push_back({1'000'000'000LL * i, T_world_cam});
    map_kfs.push_back({1'000'000'000LL * i, T_map_world * T_world_cam});
  }
  in.keyframes = {map_kfs};
  auto gt_object = [](int64_t id, const std::string& name, const std::string& cls,
                      Vec3d c, int64_t on) {
    GroundTruthObject g;
    g.id = id;
    g.name = name;
    g.class_name = cls;
    g.centroid_m = c;
    g.on_id = on;
    return g;
  };
  in.gt.objects.push_back(gt_object(1, "desk", "dining table", {1, 0, 0.4}, 0));
  in.gt.objects.back().visible_part_centroid_m = Vec3d(1, 0, 0.75);
  in.gt.objects.push_back(gt_object(2, "kb", "keyboard", {1, 0, 0.8}, 1));
  auto map_object = [&](int64_t id, const std::string& cls, Vec3d world) {
    MapObject o;
    o.id = id;
    o.class_name = cls;
    o.centroid_m = T_map_world * world;
    o.aabb_min_m = o.aabb_max_m = o.centroid_m;
    return o;
  };
  in.objects = {map_object(7, "dining table", {1, 0, 0.74}), map_object(9, "keyboard", {1.02, 0, 0.8})};
  int64_t anchor = 7;
  in.ask = [&](const std::string& q) {
    loci::v1::AskResponse r;
    r.set_answer(q);
    auto* rel = r.add_relations();
    rel->set_name("on");
    rel->set_subject_id(9);
    rel->set_anchor_id(anchor);
    return r;
  };
  auto e = EvaluateAgainstGroundTruth(in);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_LT(e->alignment.trans_m.rmse, 1e-6);
  EXPECT_LT(e->up_error_deg, 1e-3);
  EXPECT_EQ(e->objects.true_positives, 2);
  EXPECT_NEAR(e->objects.mean_centroid_error_m, 0.015, 1e-6);
  ASSERT_EQ(e->on_pairs.size(), 1u);
  EXPECT_TRUE(e->on_pairs[0].right);
  EXPECT_EQ(e->on_pairs[0].question, "where is the keyboard on the dining table");
  anchor = 8;  // an answer naming another support is wrong
  e = EvaluateAgainstGroundTruth(in);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->on_right, 0);
}

TEST(RealObjects, SameInputSameMapOnTheShippedSample) {
  ReportOptions o;
  o.tum_dir = std::string(LOCI_SOURCE_DIR) + "/tests/data/tum_fr1_rpy_sample";
  o.progress = false;
  auto a = RunReport(o);
  auto b = RunReport(o);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->keyframes, b->keyframes);
  ASSERT_EQ(a->objects_est.size(), b->objects_est.size());
  ASSERT_FALSE(a->objects_est.empty());
  for (size_t i = 0; i < a->objects_est.size(); ++i) {
    EXPECT_EQ(a->objects_est[i].id, b->objects_est[i].id);
    EXPECT_EQ(a->objects_est[i].class_name, b->objects_est[i].class_name);
    EXPECT_EQ(a->objects_est[i].observation_count, b->objects_est[i].observation_count);
    EXPECT_LT((a->objects_est[i].centroid_m - b->objects_est[i].centroid_m).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace loci::report

// `loci bench report` on a small `loci synth` scene: the report's figures are consistent with the
// scene's ground truth (trajectory, objects against the true objects, est vs GT-pose mapping,
// map size) and the markdown holds every table.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "cli/report/report_pipeline.h"
#include "synth/sequence_writer.h"

namespace loci::report {
namespace {

namespace fs = std::filesystem;

TEST(BenchReport, SynthSceneFiguresMatchTheGroundTruth) {
  const std::string dir =
      (fs::temp_directory_path() / ("loci_e2e_report_" + std::to_string(getpid()))).string();
  synth::SceneOptions so;
  so.seed = 3;
  so.num_frames = 90;
  so.num_objects = 6;
  ASSERT_TRUE(synth::WriteSequence(so, dir).ok());

  ReportOptions o;
  o.tum_dir = dir;
  o.detections = dir + "/detections.jsonl";
  o.synth_objects = dir + "/objects.json";
  o.progress = false;
  auto r = RunReport(o);
  ASSERT_TRUE(r.ok()) << r.status().message();

  EXPECT_EQ(r->frames, 90u);
  EXPECT_GT(r->keyframes, 5u);
  ASSERT_TRUE(r->ate.has_value());
  EXPECT_LT(r->ate->trans_m.rmse, 0.03);  // exact synthetic depth: odometry within a few cm
  ASSERT_TRUE(r->rpe.has_value());

  // The GT-pose mapping finds the same objects; est-vs-GT-pose centroids agree closely.
  ASSERT_FALSE(r->objects_est.empty());
  EXPECT_EQ(r->pairs.size(), r->objects_est.size());
  EXPECT_GE(r->matched_pairs, static_cast<int>(r->objects_est.size()) - 1);
  EXPECT_LT(r->mean_pair_error_m, 0.1);

  // Against the true objects: most found, centroids within decimetres, no false positives.
  ASSERT_TRUE(r->synth_est.has_value());
  EXPECT_GT(r->synth_est->gt_count, 0);
  EXPECT_LE(r->synth_est->count_error, 0.5);
  EXPECT_LT(r->synth_est->mean_centroid_error_m, 0.15);
  EXPECT_TRUE(r->synth_est->false_positive_ids.empty());

  // The object-only cloud is a part of the dense cloud on the same grid.
  EXPECT_GT(r->cloud_points, 1000u);
  EXPECT_GT(r->object_voxel_points, 0u);
  EXPECT_LT(r->object_voxel_points, r->cloud_points);
  EXPECT_GT(r->octomap_nodes, 0u);
  EXPECT_GT(r->octomap_bytes, 0u);
  EXPECT_GT(r->bytes_per_keyframe, 10'000.0);  // JPEG + 16-bit PNG of 640x480
  EXPECT_GT(r->track_ms_per_frame, 0.0);
  EXPECT_EQ(r->detect_ms_per_keyframe, 0.0);  // detections from the file

  const std::string md = FormatMarkdown(*r, o, "synth");
  for (const char* heading : {"### Trajectory", "### Objects per class", "### Object centroids",
                              "### Against the synthetic scene", "### Map size", "### Timing"}) {
    EXPECT_NE(md.find(heading), std::string::npos) << heading;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loci::report

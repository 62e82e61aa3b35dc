// In-memory checks of the synthetic scene generator: layout, trajectory, accelerometer,
// dynamic person, depth noise, rendered labels.
#include "synth/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>

#include "common/tum_io.h"
#include "synth/annotate.h"
#include "synth/depth_noise.h"
#include "synth/object_catalog.h"
#include "synth/renderer.h"
#include "synth/sequence_writer.h"

namespace loci::synth {
namespace {

SceneOptions Small(uint64_t seed) {
  SceneOptions o;
  o.seed = seed;
  o.num_frames = 30;
  return o;
}

const GroundTruthObject* FindById(const GroundTruthScene& gt, int64_t id) {
  for (const auto& o : gt.objects) {
    if (o.id == id) return &o;
  }
  return nullptr;
}

TEST(SynthScene, ObjectsStandOnTheirSupports) {
  for (uint64_t seed : {1, 2, 3, 4, 5}) {
    auto scene = MakeScene(Small(seed));
    ASSERT_TRUE(scene.ok()) << scene.status();
    const GroundTruthScene gt = ToGroundTruth(*scene);
    ASSERT_EQ(gt.objects.size(), 12u);  // table + shelf + 10
    EXPECT_EQ(gt.objects[0].class_name, "dining table");
    EXPECT_EQ(gt.objects[1].class_name, "shelf");
    std::map<int64_t, int> per_support;
    for (const GroundTruthObject& o : gt.objects) {
      EXPECT_GT(o.extent_m.minCoeff(), 0.005) << o.class_name;
      EXPECT_LT(o.extent_m.maxCoeff(), 1.85) << o.class_name;
      if (o.id <= 2) continue;
      ++per_support[o.on_id];
      if (o.on_id == 0) {
        EXPECT_NEAR(o.aabb_min_m.z(), 0.0, 1e-6) << o.class_name;
        continue;
      }
      const GroundTruthObject* s = FindById(gt, o.on_id);
      ASSERT_NE(s, nullptr);
      EXPECT_NEAR(o.aabb_min_m.z(), s->aabb_max_m.z(), 1e-6)
          << o.class_name << " on " << s->class_name;
      // Footprint entirely on the support's top.
      EXPECT_GE(o.aabb_min_m.x(), s->aabb_min_m.x());
      EXPECT_GE(o.aabb_min_m.y(), s->aabb_min_m.y());
      EXPECT_LE(o.aabb_max_m.x(), s->aabb_max_m.x());
      EXPECT_LE(o.aabb_max_m.y(), s->aabb_max_m.y());
    }
    EXPECT_GE(per_support[1], 4) << "seed " << seed;  // table
    EXPECT_GE(per_support[2], 1) << "seed " << seed;  // shelf
    EXPECT_GE(per_support[0], 1) << "seed " << seed;  // floor
    // No two objects on the same support overlap.
    for (size_t i = 2; i < gt.objects.size(); ++i) {
      for (size_t j = i + 1; j < gt.objects.size(); ++j) {
        const auto& a = gt.objects[i];
        const auto& b = gt.objects[j];
        if (a.on_id != b.on_id) continue;
        const bool overlap =
            a.aabb_min_m.x() < b.aabb_max_m.x() && b.aabb_min_m.x() < a.aabb_max_m.x() &&
            a.aabb_min_m.y() < b.aabb_max_m.y() && b.aabb_min_m.y() < a.aabb_max_m.y();
        EXPECT_FALSE(overlap) << a.class_name << " / " << b.class_name;
      }
    }
  }
}

TEST(SynthScene, CoreClassesWithCocoIds) {
  auto scene = MakeScene(Small(11));
  ASSERT_TRUE(scene.ok());
  std::map<std::string, int> ids;
  for (const SceneObject& o : scene->objects) ids[o.class_name] = o.coco_class_id;
  // The 9 core classes are always in a 10-object scene, with their COCO-80 indices.
  const std::map<std::string, int> expected = {
      {"book", 73},       {"cup", 41},          {"keyboard", 66}, {"mouse", 64},
      {"bottle", 39},     {"tv", 62},           {"laptop", 63},   {"chair", 56},
      {"teddy bear", 77}, {"dining table", 60}, {"shelf", -1}};
  for (const auto& [name, id] : expected) {
    ASSERT_TRUE(ids.count(name)) << name;
    EXPECT_EQ(ids[name], id) << name;
  }
}

TEST(SynthScene, RejectsBadOptionsAndTooManyObjects) {
  SceneOptions o;
  o.num_frames = 0;
  EXPECT_FALSE(MakeScene(o).ok());
  o = SceneOptions();
  o.num_objects = 41;
  EXPECT_FALSE(MakeScene(o).ok());
  o = SceneOptions();
  o.max_depth_m = 20.0;  // beyond 16-bit PNG range at 5000 / m
  EXPECT_FALSE(MakeScene(o).ok());
  o = SceneOptions();
  o.num_objects = 40;  // crowded but must either fit or say so
  auto s = MakeScene(o);
  if (!s.ok()) {
    EXPECT_EQ(s.status().code(), absl::StatusCode::kFailedPrecondition);
  }
}

TEST(SynthScene, HandHeldSpeedsAndTableInView) {
  auto scene = MakeScene(SceneOptions());  // 300 frames
  ASSERT_TRUE(scene.ok());
  const SceneOptions& o = scene->options;
  const Vec3d table_top = ToGroundTruth(*scene).objects[0].centroid_m +
                          Vec3d(0, 0, ToGroundTruth(*scene).objects[0].extent_m.z() / 2);
  double dist_m = 0, angle_rad = 0;
  int in_view = 0;
  SE3d prev = CameraPoseAt(*scene, FrameStampNs(o, 0));
  for (int i = 0; i < o.num_frames; ++i) {
    const SE3d T = CameraPoseAt(*scene, FrameStampNs(o, i));
    const auto uv = scene->camera.Project(T.inverse() * table_top);
    if (uv && scene->camera.InImage(*uv)) ++in_view;
    dist_m += (T.translation() - prev.translation()).norm();
    angle_rad += RotationAngleRad(prev.inverse() * T);
    prev = T;
  }
  const double duration_s = (o.num_frames - 1) / o.fps_hz;
  EXPECT_GT(dist_m / duration_s, 0.15);
  EXPECT_LT(dist_m / duration_s, 0.6);
  EXPECT_GT(angle_rad / duration_s * 180 / M_PI, 12.0);
  EXPECT_LT(angle_rad / duration_s * 180 / M_PI, 45.0);
  EXPECT_GE(in_view, o.num_frames * 9 / 10);
}

TEST(SynthScene, GravityOnlyAccelerometerMatchesPose) {
  SceneOptions o = Small(3);
  o.accel_with_motion = false;
  auto scene = MakeScene(o);
  ASSERT_TRUE(scene.ok());
  const std::vector<AccelSample> accel = MakeAccelerometer(*scene);
  EXPECT_NEAR(static_cast<double>(accel.size()), 29 / 30.0 * 100 + 1, 1.0);
  for (size_t k = 0; k < accel.size(); k += 7) {
    const int64_t t = accel[k].t_ns;
    auto g = GravityInCamAt(accel, t, 1'000'000);  // this sample only
    ASSERT_TRUE(g.ok());
    const Vec3d g_true = CameraPoseAt(*scene, t).linear().transpose() * Vec3d(0, 0, -1);
    EXPECT_LT(std::acos(std::min(1.0, g->dot(g_true))) * 180 / M_PI, 1e-4) << "sample " << k;
    EXPECT_NEAR(accel[k].accel_mps2.norm(), 9.81, 1e-9);
  }
}

TEST(SynthScene, DynamicPersonWalksThroughTheView) {
  SceneOptions o = Small(5);
  o.dynamic = true;
  auto scene = MakeScene(o);
  ASSERT_TRUE(scene.ok());
  const SceneObject& person = scene->objects.back();
  ASSERT_EQ(person.class_name, "person");
  const GroundTruthScene gt = ToGroundTruth(*scene);
  EXPECT_TRUE(gt.objects.back().dynamic);
  EXPECT_NEAR(gt.objects.back().extent_m.z(), 1.75, 0.15);
  // Same scene otherwise: the person does not reshuffle the layout.
  auto still = MakeScene(Small(5));
  ASSERT_TRUE(still.ok());
  ASSERT_EQ(still->objects.size() + 1, scene->objects.size());
  for (size_t i = 0; i < still->objects.size(); ++i) {
    EXPECT_TRUE(still->objects[i].T_world_obj.isApprox(scene->objects[i].T_world_obj));
  }
  // It moves about 1 m/s, and the rendered person moves in the image.
  const SE3d T_cam = CameraPoseAt(*scene, FrameStampNs(o, 0));
  int seen = 0;
  double first_u = -1, moved_px = 0;
  for (int i : {0, 15, 29}) {
    const int64_t t = FrameStampNs(o, i);
    const RenderedFrame f = Render(*scene, T_cam, scene->camera, t);
    const cv::Mat mask = f.instance_id == static_cast<int32_t>(person.id);
    if (cv::countNonZero(mask) < 200) continue;
    ++seen;
    const cv::Moments m = cv::moments(mask, true);
    const double u = m.m10 / m.m00;
    if (first_u < 0) first_u = u;
    moved_px = std::max(moved_px, std::abs(u - first_u));
  }
  const double walked = (ObjectPoseAt(*scene, person, FrameStampNs(o, 29)).translation() -
                         ObjectPoseAt(*scene, person, FrameStampNs(o, 0)).translation())
                            .norm();
  EXPECT_NEAR(walked, 29 / 30.0 * person.walk_speed_mps, 0.05);
  EXPECT_GE(seen, 2);
  EXPECT_GT(moved_px, 20.0);
}

TEST(SynthScene, DepthNoiseFollowsKinectModel) {
  SceneOptions o = Small(8);
  o.depth_noise = true;
  auto scene = MakeScene(o);
  ASSERT_TRUE(scene.ok());
  const int64_t t = FrameStampNs(o, 4);
  const RenderedFrame f = Render(*scene, CameraPoseAt(*scene, t), scene->camera, t);
  int valid = 0, missing = 0;
  double sum_sq = 0, sum_sigma_sq = 0;
  for (int y = 0; y < f.depth_m.rows; ++y) {
    for (int x = 0; x < f.depth_m.cols; ++x) {
      const double z = f.depth_m.at<float>(y, x);
      if (z < o.min_depth_m || z > o.max_depth_m) continue;
      const uint16_t raw = f.depth_u16.at<uint16_t>(y, x);
      if (raw == 0) {
        ++missing;
        continue;
      }
      ++valid;
      sum_sq += std::pow(raw / o.depth_scale - z, 2);
      sum_sigma_sq += std::pow(KinectSigmaM(z), 2) + std::pow(z * z / (580 * 0.075 * 8), 2) / 12;
    }
  }
  ASSERT_GT(valid, 100000);
  const double ratio = std::sqrt(sum_sq / sum_sigma_sq);
  EXPECT_GT(ratio, 0.7);
  EXPECT_LT(ratio, 1.4);
  EXPECT_GT(missing, 100);  // depth edges lose readings
  EXPECT_LT(missing, (valid + missing) / 10);
  // Reproducible for the same stamp.
  const RenderedFrame g = Render(*scene, CameraPoseAt(*scene, t), scene->camera, t);
  EXPECT_EQ(cv::norm(f.depth_u16, g.depth_u16, cv::NORM_INF), 0.0);
}

TEST(SynthScene, DetectionsAreTheVisiblePixels) {
  auto scene = MakeScene(Small(9));
  ASSERT_TRUE(scene.ok());
  const int64_t t = FrameStampNs(scene->options, 10);
  const RenderedFrame f = Render(*scene, CameraPoseAt(*scene, t), scene->camera, t);
  const std::vector<Detection2D> dets = DetectionsFromInstances(*scene, f.instance_id);
  ASSERT_GE(dets.size(), 4u);
  bool table_seen = false;
  for (const Detection2D& d : dets) {
    table_seen = table_seen || d.class_name == "dining table";
    EXPECT_NE(d.class_name, "shelf");  // not a COCO class, not detected by default
    const cv::Mat all = f.instance_id == static_cast<int32_t>(d.track_id);
    EXPECT_EQ(cv::boundingRect(all), cv::Rect(d.box_px));
    EXPECT_EQ(cv::countNonZero(d.mask), cv::countNonZero(all));
    EXPECT_GE(cv::countNonZero(d.mask), scene->options.min_visible_px);
  }
  EXPECT_TRUE(table_seen);
}

TEST(SynthScene, RenderIndependentOfThreadCount) {
  SceneOptions o = Small(4);
  o.depth_noise = true;
  auto scene = MakeScene(o);
  ASSERT_TRUE(scene.ok());
  const int64_t t = FrameStampNs(o, 12);
  const SE3d T = CameraPoseAt(*scene, t);
  const RenderedFrame a = Render(*scene, T, scene->camera, t, 1);
  const RenderedFrame b = Render(*scene, T, scene->camera, t, 3);
  EXPECT_EQ(cv::norm(a.bgr, b.bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth_u16, b.depth_u16, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.instance_id, b.instance_id, cv::NORM_INF), 0.0);
  // Rendering at half size scales the intrinsics: same view, same objects.
  PinholeCamera half = scene->camera;
  half.fx /= 2, half.fy /= 2, half.cx = (half.cx + 0.5) / 2 - 0.5,
                              half.cy = (half.cy + 0.5) / 2 - 0.5;
  half.width_px /= 2, half.height_px /= 2;
  const RenderedFrame c = Render(*scene, T, half, t);
  ASSERT_EQ(c.bgr.cols, 320);
  cv::Mat small_ids;
  cv::resize(a.instance_id, small_ids, c.instance_id.size(), 0, 0, cv::INTER_NEAREST);
  EXPECT_GT(cv::countNonZero(small_ids == c.instance_id), 320 * 240 * 9 / 10);
  // An invalid camera is no crash, just nothing.
  PinholeCamera bad = scene->camera;
  bad.width_px = -5;
  EXPECT_TRUE(Render(*scene, T, bad, t).bgr.empty());
}

}  // namespace
}  // namespace loci::synth

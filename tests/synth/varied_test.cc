// Varied synthetic rooms (SceneOptions::varied_layout) and detector noise (synth/
// detector_noise.h): different seeds give different rooms, tables and clutter, every object
// stays inside its room and off its neighbours, and the noise's rates follow its options.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "synth/detector_noise.h"
#include "synth/scene.h"

namespace loci::synth {
namespace {

SceneOptions Varied(uint64_t seed) {
  SceneOptions o;
  o.seed = seed;
  o.num_frames = 10;
  o.num_objects = 14;
  o.varied_layout = true;
  return o;
}

TEST(SynthVaried, SeedsGiveDifferentRoomsTablesAndClutter) {
  std::set<long> room_widths_cm, table_lengths_cm, counts;
  int without_shelf = 0;
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    auto scene = MakeScene(Varied(seed));
    ASSERT_TRUE(scene.ok()) << "seed " << seed << ": " << scene.status();
    const GroundTruthScene gt = ToGroundTruth(*scene);
    room_widths_cm.insert(std::lround(100 * (scene->room_max_m - scene->room_min_m).x()));
    table_lengths_cm.insert(std::lround(100 * gt.objects[0].extent_m.x()));
    counts.insert(scene->options.num_objects);
    bool shelf = false;
    for (const GroundTruthObject& o : gt.objects) {
      shelf |= o.class_name == "shelf";
      for (int k = 0; k < 3; ++k) {  // inside the room
        EXPECT_GE(o.aabb_min_m[k], scene->room_min_m[k] - 1e-9) << o.class_name;
        EXPECT_LE(o.aabb_max_m[k], scene->room_max_m[k] + 1e-9) << o.class_name;
      }
    }
    without_shelf += !shelf;
    // Published table sizes: 1.2-2.0 m long (the legs' box), 0.72-0.78 m high.
    EXPECT_GE(gt.objects[0].extent_m.x(), 1.19);
    EXPECT_LE(gt.objects[0].extent_m.x(), 2.01);
    EXPECT_NEAR(gt.objects[0].extent_m.z(), 0.75, 0.035);
    // Things on one support never overlap.
    for (size_t i = 1; i < gt.objects.size(); ++i) {
      for (size_t j = i + 1; j < gt.objects.size(); ++j) {
        const auto& a = gt.objects[i];
        const auto& b = gt.objects[j];
        if (a.on_id != b.on_id || a.id <= 2 || b.id <= 2) continue;
        const bool overlap =
            a.aabb_min_m.x() < b.aabb_max_m.x() && b.aabb_min_m.x() < a.aabb_max_m.x() &&
            a.aabb_min_m.y() < b.aabb_max_m.y() && b.aabb_min_m.y() < a.aabb_max_m.y();
        EXPECT_FALSE(overlap) << "seed " << seed << ": " << a.class_name << " / " << b.class_name;
      }
    }
  }
  EXPECT_GE(room_widths_cm.size(), 7u);  // 12 draws at cm resolution, a few may coincide
  EXPECT_GE(table_lengths_cm.size(), 7u);
  EXPECT_GE(counts.size(), 4u);
  EXPECT_GE(without_shelf, 1);
  EXPECT_LE(without_shelf, 8);
}

TEST(SynthVaried, TheFixedRoomIsUnchangedWithoutVariedLayout) {
  SceneOptions fixed = Varied(3);
  fixed.varied_layout = false;
  auto scene = MakeScene(fixed);
  ASSERT_TRUE(scene.ok());
  EXPECT_DOUBLE_EQ(scene->room_max_m.x(), 3.0);
  EXPECT_DOUBLE_EQ(scene->room_max_m.y(), 2.5);
  EXPECT_EQ(scene->options.num_objects, 14);
  EXPECT_EQ(scene->objects[1].class_name, "shelf");
}

Detection2D Box(int64_t id, float x, float y, float w, float h) {
  Detection2D d;
  d.class_name = "cup";
  d.class_id = 41;
  d.score = 1.f;
  d.box_px = cv::Rect2f(x, y, w, h);
  d.track_id = id;
  return d;
}

TEST(DetectorNoise, RatesFollowTheOptions) {
  std::vector<FrameDetections> frames(2000);
  for (size_t i = 0; i < frames.size(); ++i) {
    frames[i].t_ns = static_cast<int64_t>(i);
    frames[i].detections = {Box(3, 100, 100, 120, 90), Box(4, 400, 300, 20, 25)};
  }
  const std::vector<FrameDetections> exact = frames;
  DetectorNoise noise;
  ApplyDetectorNoise(noise, 7, 640, 480, &frames);
  int large = 0, small = 0, false_boxes = 0, large_tracks_changed = 0;
  double jitter_x0 = 0;
  std::set<int64_t> large_tracks;
  for (const FrameDetections& f : frames) {
    for (const Detection2D& d : f.detections) {
      EXPECT_GE(d.score, noise.min_score);
      EXPECT_LE(d.score, noise.max_score);
      EXPECT_GE(d.box_px.x, 0.f);
      EXPECT_LE(d.box_px.x + d.box_px.width, 640.f);
      if (d.track_id == 0) {
        ++false_boxes;
      } else if (d.track_id % 1000 == 3) {
        ++large;
        large_tracks.insert(d.track_id);
        jitter_x0 += std::pow(d.box_px.x - 100, 2);
      } else {
        ++small;
      }
    }
  }
  const double n = frames.size();
  EXPECT_NEAR(large / n, 1 - noise.miss_p, 0.04);
  EXPECT_NEAR(small / n, 1 - noise.small_miss_p, 0.04);
  EXPECT_NEAR(false_boxes / n, noise.false_boxes_per_frame, 0.03);
  EXPECT_NEAR(std::sqrt(jitter_x0 / large), noise.box_jitter_rel * 120, 1.0);
  // About track_break_p x frames breaks: new ids, each unique.
  large_tracks_changed = static_cast<int>(large_tracks.size()) - 1;
  EXPECT_GE(large_tracks_changed, 8);
  EXPECT_LE(large_tracks_changed, 35);
  // The same seed gives the same detections.
  std::vector<FrameDetections> again = exact;
  ApplyDetectorNoise(noise, 7, 640, 480, &again);
  ASSERT_EQ(again[5].detections.size(), frames[5].detections.size());
  for (size_t k = 0; k < again[5].detections.size(); ++k) {
    EXPECT_EQ(again[5].detections[k].box_px, frames[5].detections[k].box_px);
  }
}

}  // namespace
}  // namespace loci::synth

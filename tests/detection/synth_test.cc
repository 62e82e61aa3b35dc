// Tracker and depth masks on `loci synth` frames (loci_synth: ray-cast RGB-D with exact
// instance ids and ground-truth detections, Kinect-like depth noise).
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <random>

#include "detection/decode.h"
#include "detection/depth_mask.h"
#include "detection/multi_object_tracker.h"
#include "synth/annotate.h"
#include "synth/renderer.h"
#include "synth/scene.h"
#include "tests/detection/mot_metrics.h"

namespace loci::detection {
namespace {

double MaskIou(const cv::Mat& a, const cv::Mat& b) {
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? static_cast<double>(inter) / uni : 0.0;
}

TEST(SynthTracker, KeyframesWithNoiseAndDrops) {
  // A synthetic office with a walking person, 150 frames at 30 Hz, every 3rd frame used as a
  // keyframe (50 tracker updates; the hand-held camera shifts boxes by tens of pixels between
  // them). Ground-truth boxes get 3 % noise and 15 % are dropped. Reached (seed 5): with
  // appearance 1 id switch, MOTA 0.795 (misses: 15 % dropped + first sightings); motion only
  // 2 switches, MOTA 0.752.
  synth::SceneOptions so;
  so.seed = 5;
  so.num_frames = 150;
  so.dynamic = true;
  so.num_threads = 2;
  auto scene = synth::MakeScene(so);
  ASSERT_TRUE(scene.ok()) << scene.status();
  std::vector<cv::Mat> images;
  std::vector<std::vector<Detection2D>> truth;
  for (int i = 0; i < so.num_frames; i += 3) {
    const int64_t t = synth::FrameStampNs(so, i);
    synth::RenderedFrame f =
        synth::Render(*scene, synth::CameraPoseAt(*scene, t), scene->camera, t);
    truth.push_back(synth::DetectionsFromInstances(*scene, f.instance_id));
    images.push_back(f.bgr);
  }
  for (bool with_images : {true, false}) {
    std::mt19937 rng(11);
    std::normal_distribution<float> n(0.f, 1.f);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    MultiObjectTracker tracker;
    MotCounts mot;
    for (size_t k = 0; k < truth.size(); ++k) {
      std::vector<Detection2D> dets;
      std::vector<int64_t> gt_ids;
      int dropped = 0;
      for (Detection2D d : truth[k]) {
        if (u(rng) < 0.15f) {
          ++dropped;
          continue;
        }
        gt_ids.push_back(d.track_id);
        const cv::Rect2f b = d.box_px;
        d.box_px = {b.x + 0.03f * b.width * n(rng), b.y + 0.03f * b.height * n(rng),
                    b.width * (1.f + 0.03f * n(rng)), b.height * (1.f + 0.03f * n(rng))};
        d.track_id = 0;
        d.mask.release();
        dets.push_back(d);
      }
      tracker.Update(with_images ? images[k] : cv::Mat(), &dets);
      mot.Add(dets, gt_ids, dropped);
    }
    mot.Print(with_images ? "synth keyframes+appearance" : "synth keyframes, motion only");
    EXPECT_EQ(mot.class_changes, 0);
    EXPECT_EQ(mot.non_monotonic, 0);
    EXPECT_LE(mot.id_switches, with_images ? 2 : 4);
    EXPECT_GE(mot.Mota(), with_images ? 0.75 : 0.7);
  }
}

// Mean IoU of SegmentObjectDepth against the instance-id masks over seeds 3, 4, 7 (every 12th of
// 60 frames), per class and over all boxes; with or without intrinsics and gravity.
struct MaskScores {
  std::map<std::string, std::pair<double, int>> by_class;
  double sum = 0.0;
  int count = 0;
  double Mean() const { return count > 0 ? sum / count : 0.0; }
};

MaskScores ScoreSynthMasks(bool with_gravity) {
  MaskOptions mo;
  MaskScores s;
  for (uint64_t seed : {3u, 4u, 7u}) {
    synth::SceneOptions so;
    so.seed = seed;
    so.num_frames = 60;
    so.depth_noise = true;
    so.num_threads = 2;
    auto scene = synth::MakeScene(so);
    EXPECT_TRUE(scene.ok()) << scene.status();
    if (!scene.ok()) return s;
    for (int i = 0; i < so.num_frames; i += 12) {
      const int64_t t = synth::FrameStampNs(so, i);
      const SE3d T_world_cam = synth::CameraPoseAt(*scene, t);
      const synth::RenderedFrame f = synth::Render(*scene, T_world_cam, scene->camera, t);
      // World z is up in synth scenes.
      const Vec3d gravity_cam = T_world_cam.rotation().transpose() * Vec3d(0, 0, -1);
      for (const Detection2D& d : synth::DetectionsFromInstances(*scene, f.instance_id)) {
        MaskContext context{d.class_name, std::nullopt, std::nullopt};
        if (with_gravity) {
          context.camera = scene->camera;
          context.gravity_cam = gravity_cam;
        }
        const cv::Mat m = SegmentObjectDepth(f.depth_u16, d.box_px, mo, context);
        EXPECT_EQ(m.size(), d.mask.size());
        if (m.size() != d.mask.size()) continue;
        const double iou = MaskIou(m, d.mask);
        s.by_class[d.class_name].first += iou;
        s.by_class[d.class_name].second += 1;
        s.sum += iou;
        ++s.count;
      }
    }
  }
  return s;
}

TEST(SynthMasks, DepthClusterMatchesInstanceMasks) {
  // Noisy depth (Kinect-like noise, disparity quantisation, edge dropouts); boxes are the
  // ground-truth boxes of the visible pixels; masks compared with the instance-id masks over
  // every object, the dining table included. Reached: 0.847 over 111 boxes with gravity
  // (table 0.857: the floor between its legs and the cups on it are left out), 0.804 from
  // depth alone (table 0.54: without gravity the floor seen between the legs, cut by the image
  // border, cannot be told from the table's own surfaces).
  const MaskScores with = ScoreSynthMasks(true);
  const MaskScores without = ScoreSynthMasks(false);
  for (const auto& [name, s] : with.by_class) {
    const auto& w = without.by_class.at(name);
    std::printf("  mask IoU %-14s %.3f with gravity, %.3f depth only (%d boxes)\n", name.c_str(),
                s.first / s.second, w.first / w.second, s.second);
  }
  std::printf("mean mask IoU over %d boxes: %.3f with gravity, %.3f depth only\n", with.count,
              with.Mean(), without.Mean());
  ASSERT_GT(with.count, 100);
  ASSERT_TRUE(with.by_class.count("dining table"));
  EXPECT_GE(with.Mean(), 0.8);
  EXPECT_GE(without.Mean(), 0.78);
  // Support furniture: its mask leaves out the floor and what stands on it.
  const auto& table = with.by_class.at("dining table");
  EXPECT_GE(table.first / table.second, 0.75);
}

}  // namespace
}  // namespace loci::detection

// A written `loci synth` folder: TUM reader, determinism, depth vs. ground truth geometry,
// detections, accelerometer, ORB features.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/config.h"
#include "common/detections_io.h"
#include "common/image_codec.h"
#include "common/objects_json.h"
#include "common/tum_io.h"
#include "synth/object_catalog.h"
#include "synth/sequence_writer.h"

namespace loci::synth {
namespace {
namespace fs = std::filesystem;

constexpr int kFrames = 30;

std::string TempDir(const std::string& name) {
  const fs::path p =
      fs::temp_directory_path() / ("loci_synth_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(p);
  return p.string();
}

class SynthSequence : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(TempDir("seq"));
    SceneOptions o;
    o.seed = 7;
    o.num_frames = kFrames;
    SequenceStats stats;
    const Status s = WriteSequence(o, *dir_, &stats);
    ASSERT_TRUE(s.ok()) << s;
    ASSERT_EQ(stats.frames, kFrames);
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string Bytes(const std::string& path) {
    auto b = ReadFileBytes(path);
    return b.ok() ? *b : std::string();
  }
  static std::string* dir_;
};
std::string* SynthSequence::dir_ = nullptr;

TEST_F(SynthSequence, LoadsThroughTumReader) {
  auto seq = LoadTumSequence(*dir_);
  ASSERT_TRUE(seq.ok()) << seq.status();
  ASSERT_EQ(seq->frames.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(seq->groundtruth.size(), static_cast<size_t>(kFrames));
  EXPECT_NEAR(static_cast<double>(seq->accel.size()), (kFrames - 1) / 30.0 * 100, 2.0);
  EXPECT_EQ(seq->frames[0].rgb_t_ns, 1'700'000'000'000'000'000);
  EXPECT_EQ(seq->frames[1].rgb_t_ns - seq->frames[0].rgb_t_ns, 33'333'000);
  for (size_t i = 0; i < seq->frames.size(); ++i) {
    EXPECT_EQ(seq->frames[i].rgb_t_ns, seq->frames[i].depth_t_ns);
    EXPECT_EQ(seq->frames[i].rgb_t_ns, seq->groundtruth[i].t_ns);
  }
  auto rgb = DecodeJpeg(Bytes(seq->frames[3].rgb_path), 640, 480);
  auto depth = DecodeDepthPng(Bytes(seq->frames[3].depth_path), 640, 480);
  ASSERT_TRUE(rgb.ok()) << rgb.status();
  ASSERT_TRUE(depth.ok()) << depth.status();
  auto cam = LoadYamlFile(*dir_ + "/camera.yaml");
  ASSERT_TRUE(cam.ok());
  EXPECT_DOUBLE_EQ((*cam)["camera"]["fx"].as<double>(), 517.3);
  EXPECT_DOUBLE_EQ((*cam)["depth_scale"].as<double>(), 5000.0);
}

TEST_F(SynthSequence, SameSeedSameBytesOtherSeedOtherScene) {
  const std::string again = TempDir("again"), other = TempDir("other");
  SceneOptions o;
  o.seed = 7;
  o.num_frames = kFrames;  // objects.json grades objects by how often they are seen
  ASSERT_TRUE(WriteSequence(o, again).ok());
  o.seed = 8;
  o.num_frames = 3;
  ASSERT_TRUE(WriteSequence(o, other).ok());
  auto a = LoadTumSequence(*dir_), b = LoadTumSequence(again), c = LoadTumSequence(other);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  for (int i = 0; i < 3; ++i) {
    const std::string rgb = Bytes(a->frames[i].rgb_path);
    ASSERT_FALSE(rgb.empty());
    EXPECT_EQ(rgb, Bytes(b->frames[i].rgb_path)) << "frame " << i;
    EXPECT_EQ(Bytes(a->frames[i].depth_path), Bytes(b->frames[i].depth_path)) << "frame " << i;
    EXPECT_NE(rgb, Bytes(c->frames[i].rgb_path)) << "frame " << i;
  }
  EXPECT_EQ(Bytes(*dir_ + "/objects.json"), Bytes(again + "/objects.json"));
  EXPECT_NE(Bytes(*dir_ + "/objects.json"), Bytes(other + "/objects.json"));
  fs::remove_all(again);
  fs::remove_all(other);
}

// Back-projects every detected object's masked pixels with the ground-truth pose: the points
// must fall inside the object's world AABB (exact depth, 0.2 mm PNG steps, 1e-6 pose digits;
// a half-pixel error in the projection model already shows as 2-3 mm).
TEST_F(SynthSequence, DepthAgreesWithObjectBoxes) {
  auto seq = LoadTumSequence(*dir_);
  auto gt = ReadObjectsJson(*dir_ + "/objects.json");
  auto dets = ReadDetectionsJsonl(*dir_ + "/detections.jsonl");
  ASSERT_TRUE(seq.ok() && gt.ok() && dets.ok());
  std::map<int64_t, GroundTruthObject> by_id;
  for (const auto& o : gt->objects) by_id[o.id] = o;
  const PinholeCamera cam = PinholeCamera::TumFr1();
  int64_t checked = 0;
  for (int i = 0; i < kFrames; i += 7) {
    auto depth = DecodeDepthPng(Bytes(seq->frames[i].depth_path));
    ASSERT_TRUE(depth.ok());
    const FrameDetections* fd = FindDetections(*dets, seq->frames[i].rgb_t_ns);
    ASSERT_NE(fd, nullptr);
    const SE3d& T_world_cam = seq->groundtruth[i].T_world_cam;
    for (const Detection2D& d : fd->detections) {
      ASSERT_TRUE(by_id.count(d.track_id));
      const GroundTruthObject& o = by_id[d.track_id];
      EXPECT_EQ(o.class_name, d.class_name);
      const cv::Rect r = MaskRect(d.box_px, 640, 480);
      double worst_m = 0;
      for (int y = 0; y < r.height; ++y) {
        for (int x = 0; x < r.width; ++x) {
          const uint16_t raw = depth->at<uint16_t>(r.y + y, r.x + x);
          if (!d.mask.at<uint8_t>(y, x) || raw == 0) continue;
          const Vec3d p = T_world_cam * cam.BackProject(r.x + x, r.y + y, raw / 5000.0);
          const Vec3d out = (o.aabb_min_m - p).cwiseMax(p - o.aabb_max_m).cwiseMax(0.0);
          worst_m = std::max(worst_m, out.norm());
          ++checked;
        }
      }
      EXPECT_LT(worst_m, 0.001) << d.class_name << " frame " << i;
    }
  }
  EXPECT_GT(checked, 50000);
}

TEST_F(SynthSequence, DetectionBoxesAreMaskExtents) {
  auto dets = ReadDetectionsJsonl(*dir_ + "/detections.jsonl");
  ASSERT_TRUE(dets.ok()) << dets.status();
  ASSERT_EQ(dets->size(), static_cast<size_t>(kFrames));
  // COCO-80 names file shipped with the detector, when present.
  std::vector<std::string> coco;
  std::ifstream names(std::string(LOCI_SOURCE_DIR) + "/models/yolox_nano/coco80.names");
  for (std::string line; std::getline(names, line);) coco.push_back(line);
  int table_frames = 0;
  for (const FrameDetections& f : *dets) {
    bool table = false;
    for (const Detection2D& d : f.detections) {
      table = table || d.class_name == "dining table";
      ASSERT_FALSE(d.mask.empty());
      const cv::Rect r = MaskRect(d.box_px, 640, 480);
      EXPECT_EQ(d.mask.size(), r.size());
      EXPECT_EQ(cv::boundingRect(d.mask), cv::Rect(0, 0, r.width, r.height));
      EXPECT_GE(cv::countNonZero(d.mask), 150);
      EXPECT_EQ(d.class_id, CocoClassId(d.class_name));
      if (coco.size() == 80) {
        EXPECT_EQ(coco[d.class_id], d.class_name);
      }
      EXPECT_FLOAT_EQ(d.score, 1.f);
      EXPECT_GT(d.track_id, 0);
    }
    table_frames += table;
  }
  EXPECT_GE(table_frames, kFrames * 9 / 10);
}

TEST_F(SynthSequence, AccelerometerGivesGroundTruthGravity) {
  auto seq = LoadTumSequence(*dir_);
  ASSERT_TRUE(seq.ok());
  for (const StampedPose& p : seq->groundtruth) {
    auto g = GravityInCamAt(seq->accel, p.t_ns);
    ASSERT_TRUE(g.ok()) << g.status();
    const Vec3d g_true = p.T_world_cam.linear().transpose() * Vec3d(0, 0, -1);
    // The camera's own acceleration (< 0.5 m/s^2) tilts the reading by < 2 degrees.
    EXPECT_LT(std::acos(std::min(1.0, g->dot(g_true))) * 180 / M_PI, 3.0);
  }
}

TEST_F(SynthSequence, OrbFindsFeaturesToTrack) {
  auto seq = LoadTumSequence(*dir_);
  ASSERT_TRUE(seq.ok());
  cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
  for (int i = 0; i < kFrames; i += 6) {
    auto rgb = DecodeJpeg(Bytes(seq->frames[i].rgb_path));
    ASSERT_TRUE(rgb.ok());
    cv::Mat gray;
    cv::cvtColor(*rgb, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> kps;
    orb->detect(gray, kps);
    EXPECT_GE(kps.size(), 300u) << "frame " << i;
  }
}

}  // namespace
}  // namespace loci::synth

// Server-side keyframe detection (server/detect/): which keyframes each mode detects, prefetch
// ahead of Apply, the robot's boxes as the fallback, and track inheritance by overlap.
#include "server/detect/keyframe_detection.h"

#include <gtest/gtest.h>

#include <atomic>

namespace loci::server {
namespace {

Detection2D Box(const std::string& cls, float x, float y, float w, float h, int64_t track = 0) {
  Detection2D d;
  d.class_name = cls;
  d.score = 0.9f;
  d.box_px = cv::Rect2f(x, y, w, h);
  d.track_id = track;
  return d;
}

// Boxes a fixed set, or fails on odd stamps when asked to.
class FixedDetector final : public detection::Detector {
 public:
  StatusOr<std::vector<Detection2D>> Detect(const cv::Mat&, int64_t t_ns) override {
    calls.fetch_add(1);
    if (fail_odd && t_ns % 2 == 1) return absl::InternalError("model failed");
    return std::vector<Detection2D>{Box("cup", 100, 100, 40, 50), Box("book", 300, 200, 80, 30)};
  }
  std::string Name() const override { return "fixed"; }
  std::atomic<int> calls{0};
  bool fail_odd = false;
};

MapperKeyframe Keyframe(int64_t id, std::vector<Detection2D> robot_boxes) {
  MapperKeyframe kf;
  kf.keyframe_id = id;
  kf.t_ns = id;
  kf.bgr = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  kf.detections = std::move(robot_boxes);
  return kf;
}

KeyframeDetection Make(std::shared_ptr<FixedDetector> d, DetectMode mode) {
  KeyframeDetectionOptions o;
  o.mode = mode;
  return KeyframeDetection({std::move(d)}, o);
}

TEST(KeyframeDetection, ModeMissingDetectsOnlyKeyframesWithoutBoxes) {
  auto d = std::make_shared<FixedDetector>();
  KeyframeDetection detection = Make(d, DetectMode::kMissing);
  MapperKeyframe with = Keyframe(2, {Box("chair", 0, 0, 100, 200, 7)});
  MapperKeyframe without = Keyframe(4, {});
  ASSERT_TRUE(detection.Apply(&with).ok());
  ASSERT_TRUE(detection.Apply(&without).ok());
  EXPECT_EQ(d->calls, 1);
  ASSERT_EQ(with.detections.size(), 1u);
  EXPECT_EQ(with.detections[0].class_name, "chair");
  EXPECT_EQ(without.detections.size(), 2u);
}

TEST(KeyframeDetection, ModeAllReplacesTheRobotsBoxesAndKeepsThemWhenTheDetectorFails) {
  auto d = std::make_shared<FixedDetector>();
  d->fail_odd = true;
  KeyframeDetection detection = Make(d, DetectMode::kAll);
  MapperKeyframe ok = Keyframe(2, {Box("chair", 0, 0, 100, 200, 7)});
  MapperKeyframe failing = Keyframe(3, {Box("chair", 0, 0, 100, 200, 7)});
  EXPECT_TRUE(detection.Apply(&ok).ok());
  EXPECT_FALSE(detection.Apply(&failing).ok());
  EXPECT_EQ(ok.detections.size(), 2u);
  ASSERT_EQ(failing.detections.size(), 1u);
  EXPECT_EQ(failing.detections[0].class_name, "chair");
  EXPECT_EQ(detection.detected(), 1);
  EXPECT_EQ(detection.failed(), 1);
  EXPECT_EQ(detection.Name(), "all:fixed");
}

TEST(KeyframeDetection, PrefetchedKeyframesAreDetectedOnceAndInOrderOfApply) {
  auto d = std::make_shared<FixedDetector>();
  KeyframeDetection detection = Make(d, DetectMode::kAll);
  std::vector<MapperKeyframe> kfs;
  for (int64_t id = 10; id < 30; id += 2) kfs.push_back(Keyframe(id, {}));
  for (const MapperKeyframe& kf : kfs) detection.Prefetch(kf);
  for (MapperKeyframe& kf : kfs) {
    ASSERT_TRUE(detection.Apply(&kf).ok());
    EXPECT_EQ(kf.detections.size(), 2u);
  }
  EXPECT_EQ(d->calls, 10);
  EXPECT_EQ(detection.detected(), 10);
}

TEST(KeyframeDetection, ServerBoxesInheritTheTrackOfTheSameClassRobotBoxTheyOverlapMost) {
  const std::vector<Detection2D> robot = {Box("cup", 102, 98, 40, 52, 5),
                                          Box("book", 300, 200, 80, 30, 9),
                                          Box("cup", 120, 100, 40, 50, 6)};
  std::vector<Detection2D> server = {Box("cup", 100, 100, 40, 50), Box("book", 500, 50, 80, 30),
                                     Box("bowl", 300, 200, 80, 30)};
  InheritTracks(robot, 0.5, &server);
  EXPECT_EQ(server[0].track_id, 5);  // IoU 0.85 beats the other cup's 0.43
  EXPECT_EQ(server[1].track_id, 0);  // no overlap with the robot's book
  EXPECT_EQ(server[2].track_id, 0);  // same box, other class
}

TEST(KeyframeDetection, UnknownModeIsRefusedByName) {
  EXPECT_TRUE(ParseDetectMode("all").ok());
  const auto bad = ParseDetectMode("sometimes");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("sometimes"), std::string::npos);
}

}  // namespace
}  // namespace loci::server

// Depth captured at another instant than its colour image (the Kinect v1's depth stamps lie up to
// 20 ms from the colour stamps): WarpDepth moves it to another camera pose, and the tracker's
// constant-velocity motion (Tracker::PredictedMotion) gives the pose at the colour stamp.
#include "client/tracking/depth_time_warp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>

#include "client/tracking/tracker.h"
#include "synth/renderer.h"
#include "tests/support/depth_compare.h"
#include "synth/scene.h"

namespace loci {
namespace {

int ValidPixels(const cv::Mat& depth_u16) { return cv::countNonZero(depth_u16); }

SE3d Motion(double angle_deg, const Vec3d& axis, const Vec3d& t_m) {
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180, axis.normalized()).toRotationMatrix();
  T.translation() = t_m;
  return T;
}

class DepthTimeWarpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    synth::SceneOptions so;
    so.seed = 7;
    so.num_frames = 60;
    auto scene = synth::MakeScene(so);
    ASSERT_TRUE(scene.ok()) << scene.status();
    scene_ = std::move(*scene);
  }
  // A tracker (depth alignment on or off) that has tracked frames 0 .. n-1.
  std::unique_ptr<Tracker> TrackerAfter(int n, bool align_depth_time) const {
    TrackerOptions opt;
    opt.camera = scene_.camera;
    opt.align_depth_time = align_depth_time;
    auto tracker = Tracker::Create(opt);
    EXPECT_TRUE(tracker.ok()) << tracker.status();
    if (!tracker.ok()) return nullptr;
    for (int i = 0; i < n; ++i) {
      const synth::RenderedFrame f = RenderAt(i);
      EXPECT_TRUE((*tracker)->Track(f.bgr, f.depth_u16, f.t_ns).ok());
    }
    return std::move(*tracker);
  }
  synth::RenderedFrame RenderAt(int frame, const SE3d& T_cam_moved = SE3d::Identity()) const {
    const int64_t t_ns = synth::FrameStampNs(scene_.options, frame);
    return synth::Render(scene_, synth::CameraPoseAt(scene_, t_ns) * T_cam_moved, scene_.camera,
                         t_ns);
  }
  synth::Scene scene_;
};

// A room with a table and objects, the camera turned by 2 deg (fr1_rpy's speed over 20 ms) and
// moved 1 cm: the moved depth agrees with the depth rendered at the new pose almost everywhere,
// where the unmoved one agrees only on the parts the motion barely changes.
TEST_F(DepthTimeWarpTest, MovedDepthMatchesTheDepthRenderedAtTheNewPose) {
  const SE3d T_old_new = Motion(2.0, Vec3d(0.3, 1.0, 0.2), Vec3d(0.01, -0.004, 0.003));
  const synth::RenderedFrame old_f = RenderAt(20);
  const synth::RenderedFrame new_f = RenderAt(20, T_old_new);
  const cv::Mat moved =
      WarpDepth(old_f.depth_u16, scene_.options.depth_scale, scene_.camera, T_old_new.inverse());
  const double before = testing::AgreeingDepthShare(old_f.depth_u16, new_f.depth_u16);
  const double after = testing::AgreeingDepthShare(moved, new_f.depth_u16);
  const double coverage = static_cast<double>(ValidPixels(moved)) / ValidPixels(new_f.depth_u16);
  std::cout << "depth within 1 %: unmoved " << before << ", moved " << after << "; moved covers "
            << coverage << " of the rendered pixels\n";
  EXPECT_GT(after, 0.97);
  EXPECT_LT(before, after - 0.2);
  // Cracks are filled; what came into view (2 deg: about 18 px along one side) has no depth.
  EXPECT_GT(coverage, 0.9);
}

TEST_F(DepthTimeWarpTest, IdentityKeepsEveryDepth) {
  const cv::Mat depth = RenderAt(5).depth_u16;
  const cv::Mat same =
      WarpDepth(depth, scene_.options.depth_scale, scene_.camera, SE3d::Identity());
  EXPECT_EQ(cv::countNonZero(same != depth), 0);
}

// The tracker's motion model over part of a frame interval is that part of the last motion: it
// turns the depth rendered 10 ms after a colour frame back to the colour frame's pose.
TEST_F(DepthTimeWarpTest, TrackerMotionMovesLateDepthToTheColourStamp) {
  const std::unique_ptr<Tracker> first = TrackerAfter(1, true);
  ASSERT_NE(first, nullptr);
  const int64_t t0 = synth::FrameStampNs(scene_.options, 0);
  EXPECT_FALSE(first->PredictedMotion(t0, t0 + 1000).has_value());  // no motion model yet
  const int last = 12;
  const std::unique_ptr<Tracker> tracker = TrackerAfter(last + 1, true);
  ASSERT_NE(tracker, nullptr);
  const int64_t t_rgb = synth::FrameStampNs(scene_.options, last + 1);
  const int64_t t_depth = t_rgb + 10'000'000;
  const SE3d T_world_rgb = synth::CameraPoseAt(scene_, t_rgb);
  const SE3d T_world_depth = synth::CameraPoseAt(scene_, t_depth);
  const SE3d T_rgb_depth_true = T_world_rgb.inverse() * T_world_depth;
  const std::optional<SE3d> T_rgb_depth = tracker->PredictedMotion(t_depth, t_rgb);
  ASSERT_TRUE(T_rgb_depth.has_value());
  const double true_deg = RotationAngleRad(T_rgb_depth_true) * 180 / M_PI;
  const double err_deg = RotationAngleRad(T_rgb_depth->inverse() * T_rgb_depth_true) * 180 / M_PI;
  std::cout << "10 ms of motion: " << true_deg << " deg, predicted within " << err_deg << " deg\n";
  EXPECT_LT(err_deg, 0.25 * true_deg);
  EXPECT_TRUE(tracker->PredictedMotion(t_rgb, t_rgb)->isApprox(SE3d::Identity()));
  // Not extrapolated beyond the model's own frame interval (a depth stamp 0.5 s off).
  EXPECT_FALSE(tracker->PredictedMotion(t_rgb + 500'000'000, t_rgb).has_value());

  const synth::RenderedFrame at_rgb = synth::Render(scene_, T_world_rgb, scene_.camera, t_rgb);
  cv::Mat depth = synth::Render(scene_, T_world_depth, scene_.camera, t_depth).depth_u16;
  const double before = testing::AgreeingDepthShare(depth, at_rgb.depth_u16);
  AlignDepthToColourTime(*tracker, t_depth, t_rgb, &depth);
  const double after = testing::AgreeingDepthShare(depth, at_rgb.depth_u16);
  std::cout << "late depth within 1 % of the colour stamp's: " << before << " -> " << after << "\n";
  EXPECT_GT(after, before);
  EXPECT_GT(after, 0.97);
}

TEST_F(DepthTimeWarpTest, AlignmentOffOrEqualStampsLeaveTheDepthAlone) {
  const synth::RenderedFrame f = RenderAt(4);
  for (const bool on : {false, true}) {
    const std::unique_ptr<Tracker> tracker = TrackerAfter(4, on);
    ASSERT_NE(tracker, nullptr);
    cv::Mat depth = f.depth_u16.clone();
    // Off: a depth stamp 15 ms late changes nothing; on: equal stamps change nothing.
    AlignDepthToColourTime(*tracker, on ? f.t_ns : f.t_ns + 15'000'000, f.t_ns, &depth);
    EXPECT_EQ(cv::countNonZero(depth != f.depth_u16), 0) << (on ? "on" : "off");
  }
}

}  // namespace
}  // namespace loci

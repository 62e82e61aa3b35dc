// A rolling-shutter camera that turns sees each row from another orientation: RectifyColour and
// RectifyDepth give back the images a global shutter would have taken at the centre row's
// instant. The rolling-shutter frames are rendered band by band (8 rows per band) from a
// loci_synth room, the camera turning at fr1_rpy's fastest (125 deg/s).
#include "client/tracking/rolling_shutter.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "synth/renderer.h"
#include "tests/support/depth_compare.h"
#include "synth/scene.h"

namespace loci {
namespace {

const Vec3d kTurn(0.6, 2.0, 0.5);  // rad/s in the camera frame, |w| = 2.2 rad/s
constexpr double kLineS = 50e-6;    // the Kinect v1's 50 us between rows
constexpr int kBandRows = 8;

// A loci_synth room with its camera path (60 frames); the frame looked at is the 30th.
synth::SceneOptions Room() {
  synth::SceneOptions so;
  so.seed = 5;
  so.num_frames = 60;
  return so;
}

class RollingShutterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    StatusOr<synth::Scene> scene = synth::MakeScene(Room());
    ASSERT_TRUE(scene.ok()) << scene.status();
    scene_ = std::move(*scene);
    T_world_centre_ = synth::CameraPoseAt(scene_, synth::FrameStampNs(scene_.options, 30));
    global_ = synth::Render(scene_, T_world_centre_, scene_.camera, 0);
    rolling_ = RenderRollingShutter();
  }
  // Row band by row band, each from the camera turned to the band's centre row's instant.
  synth::RenderedFrame RenderRollingShutter() const {
    synth::RenderedFrame f = global_;
    f.bgr = global_.bgr.clone();
    f.depth_u16 = global_.depth_u16.clone();
    const PinholeCamera& cam = scene_.camera;
    for (int v0 = 0; v0 < cam.height_px; v0 += kBandRows) {
      const int rows = std::min(kBandRows, cam.height_px - v0);
      const Vec3d turn = kTurn * ((v0 + 0.5 * (rows - 1) - cam.cy) * kLineS);
      SE3d T_row_centre = SE3d::Identity();  // p_row = exp([w t]x) p_centre
      T_row_centre.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).matrix();
      const synth::RenderedFrame band =
          synth::Render(scene_, T_world_centre_ * T_row_centre.inverse(), cam, 0);
      const cv::Rect r(0, v0, cam.width_px, rows);
      band.bgr(r).copyTo(f.bgr(r));
      band.depth_u16(r).copyTo(f.depth_u16(r));
    }
    return f;
  }
  synth::Scene scene_;
  SE3d T_world_centre_;
  synth::RenderedFrame global_, rolling_;
};

// Mean absolute grey-level difference over the image's inner part (20 px border left out).
double MeanGreyDifference(const cv::Mat& a_bgr, const cv::Mat& b_bgr) {
  cv::Mat a, b, d;
  cv::cvtColor(a_bgr, a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b_bgr, b, cv::COLOR_BGR2GRAY);
  const cv::Rect inner(20, 20, a.cols - 40, a.rows - 40);
  cv::absdiff(a(inner), b(inner), d);
  return cv::mean(d)[0];
}

TEST_F(RollingShutterTest, ImagesReturnToTheCentreRowsView) {
  const PinholeCamera& cam = scene_.camera;
  const double depth_scale = scene_.options.depth_scale;
  const cv::Mat bgr = RectifyColour(rolling_.bgr, cam, kTurn, kLineS);
  const cv::Mat depth = RectifyDepth(rolling_.depth_u16, depth_scale, cam, kTurn, kLineS);
  const double grey_before = MeanGreyDifference(rolling_.bgr, global_.bgr);
  const double grey_after = MeanGreyDifference(bgr, global_.bgr);
  const double depth_before = testing::AgreeingDepthShare(rolling_.depth_u16, global_.depth_u16);
  const double depth_after = testing::AgreeingDepthShare(depth, global_.depth_u16);
  std::cout << "grey difference " << grey_before << " -> " << grey_after
            << "; depth agreeing within 1 % " << depth_before << " -> " << depth_after << "\n";
  EXPECT_LT(grey_after, 0.25 * grey_before);
  EXPECT_GT(depth_after, 0.97);
  EXPECT_LT(depth_before, 0.9);
}

TEST_F(RollingShutterTest, TheWrongReadoutDirectionMakesItWorse) {
  const cv::Mat bgr = RectifyColour(rolling_.bgr, scene_.camera, kTurn, -kLineS);
  EXPECT_GT(MeanGreyDifference(bgr, global_.bgr), MeanGreyDifference(rolling_.bgr, global_.bgr));
}

TEST_F(RollingShutterTest, AGlobalShutterOrAStillCameraIsLeftAlone) {
  const PinholeCamera& cam = scene_.camera;
  const double depth_scale = scene_.options.depth_scale;
  for (const auto& [w, line_s] : {std::pair{kTurn, 0.0}, std::pair{Vec3d::Zero().eval(), kLineS}}) {
    EXPECT_EQ(cv::norm(RectifyColour(rolling_.bgr, cam, w, line_s), rolling_.bgr, cv::NORM_INF),
              0);
    EXPECT_EQ(cv::norm(RectifyDepth(rolling_.depth_u16, depth_scale, cam, w, line_s),
                       rolling_.depth_u16, cv::NORM_INF),
              0);
  }
}

}  // namespace
}  // namespace loci

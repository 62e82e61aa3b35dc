// Depth support of an observation (server/map/mask_cover.h): a dark screen without depth, whose
// box holds only the wall around it, gives no observation; the same screen with depth does.
#include "server/map/mask_cover.h"

#include <gtest/gtest.h>

#include <random>

#include "server/map/keyframe_products.h"

namespace loci::server {
namespace {

TEST(MaskCover, ARingCoversTheMiddleLessThanTheWholeAndOtherLabelsCountNeitherWay) {
  cv::Mat labels(100, 100, CV_16SC1, cv::Scalar(kBackgroundLabel));
  const cv::Rect box(10, 10, 80, 80);
  labels(box).setTo(1);
  labels(cv::Rect(30, 30, 40, 40)).setTo(kBackgroundLabel);  // the middle half is empty
  MaskCover ring = CoverOf(labels, box, 1, kBackgroundLabel);
  EXPECT_DOUBLE_EQ(ring.centre, 0.0);
  EXPECT_DOUBLE_EQ(ring.whole, 0.75);
  EXPECT_TRUE(IsHollow(ring, 0.3));
  EXPECT_FALSE(IsHollow(ring, 0.0));  // off

  labels(cv::Rect(30, 30, 40, 40)).setTo(2);  // another detection's box took the middle
  const MaskCover taken = CoverOf(labels, box, 1, kBackgroundLabel);
  EXPECT_DOUBLE_EQ(taken.centre, 1.0);  // no free pixel in the middle
  EXPECT_DOUBLE_EQ(taken.whole, 1.0);
  EXPECT_FALSE(IsHollow(taken, 0.3));

  labels(box).setTo(1);
  labels(cv::Rect(10, 10, 80, 20)).setTo(kBackgroundLabel);  // a mask that misses its top
  const MaskCover partial = CoverOf(labels, box, 1, kBackgroundLabel);
  EXPECT_DOUBLE_EQ(partial.centre, 1.0);
  EXPECT_FALSE(IsHollow(partial, 0.3));

  MapOptions options;  // the option is a share
  options.observation.min_centre_cover = 1.5;
  EXPECT_FALSE(options.Validate().ok());
  options.observation.min_centre_cover = 0;
  EXPECT_TRUE(options.Validate().ok());
}

// A wall 3.2 m away with Kinect-like noise (sigma 0.0015 z^2) and a 0.45 x 0.40 m monitor 2.5 m
// away in front of it, whose screen and bezel return depth or not.
cv::Mat WallWithMonitor(const PinholeCamera& cam, bool screen_has_depth, cv::Rect* monitor_px) {
  std::mt19937 rng(7);
  std::normal_distribution<float> unit(0.0f, 1.0f);
  const double wall_m = 3.2, monitor_m = 2.5;
  const int w = static_cast<int>(0.45 * cam.fx / monitor_m),
            h = static_cast<int>(0.40 * cam.fy / monitor_m);
  *monitor_px = cv::Rect(400, 150, w, h);
  cv::Mat depth(cam.height_px, cam.width_px, CV_32FC1);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const bool on_monitor = monitor_px->contains({u, v});
      const double z = on_monitor ? monitor_m : wall_m;
      depth.at<float>(v, u) = on_monitor && !screen_has_depth
                                  ? 0.0f
                                  : static_cast<float>(z + 0.0015 * z * z * unit(rng));
    }
  }
  return depth;
}

// Median depth of the observations' points, one per observation.
std::vector<double> ObservationDepthsM(const KeyframeProducts& products) {
  std::vector<double> out;
  for (const ObjectObservation& o : products.observations) {
    std::vector<float> z;
    for (const auto& p : o.cloud_kf) z.push_back(p.z);
    std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
    out.push_back(z[z.size() / 2]);
  }
  return out;
}

TEST(MaskCover, ADarkScreenWithoutDepthGivesNoObservationOfTheWallBehindIt) {
  const PinholeCamera cam = PinholeCamera::TumFr1();
  cv::Rect monitor;
  Detection2D tv;
  tv.class_name = "tv";
  tv.score = 0.6f;
  const cv::Mat bgr(cam.height_px, cam.width_px, CV_8UC3, cv::Scalar(40, 40, 40));

  const cv::Mat dark = WallWithMonitor(cam, false, &monitor);
  tv.box_px = cv::Rect2f(monitor.x - 12, monitor.y - 12, monitor.width + 24, monitor.height + 24);
  MapOptions off;
  off.observation.min_centre_cover = 0;
  const std::vector<double> without_gate =
      ObservationDepthsM(BuildKeyframeProducts(bgr, dark, cam, {tv}, off));
  ASSERT_EQ(without_gate.size(), 1u);  // the mask took the wall: a "tv" 0.7 m behind the monitor
  EXPECT_NEAR(without_gate[0], 3.2, 0.05);
  EXPECT_TRUE(BuildKeyframeProducts(bgr, dark, cam, {tv}, MapOptions()).observations.empty());

  const cv::Mat lit = WallWithMonitor(cam, true, &monitor);
  const std::vector<double> with_depth =
      ObservationDepthsM(BuildKeyframeProducts(bgr, lit, cam, {tv}, MapOptions()));
  ASSERT_EQ(with_depth.size(), 1u);
  EXPECT_NEAR(with_depth[0], 2.5, 0.05);
}

}  // namespace
}  // namespace loci::server

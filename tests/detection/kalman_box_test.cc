#include "detection/kalman_box.h"

#include <gtest/gtest.h>

namespace loci::detection {
namespace {

TEST(KalmanBoxFilter, LearnsConstantVelocity) {
  // Box moving +6 px/step in x, -2 px/step in y, growing 1 px/step in height, aspect 1.5.
  auto truth = [](int k) {
    const float h = 60.f + k;
    return cv::Rect2f(100.f + 6.f * k, 200.f - 2.f * k, 1.5f * h, h);
  };
  KalmanBoxFilter kf(truth(0));
  for (int k = 1; k <= 30; ++k) {
    kf.Predict();
    kf.Update(truth(k));
  }
  EXPECT_NEAR(kf.state()(4), 6.0 + 0.75, 0.3);  // centre moves 6 px + half the 1.5 px widening
  EXPECT_NEAR(kf.state()(5), -2.0 + 0.5, 0.3);
  EXPECT_NEAR(kf.state()(7), 1.0, 0.2);
  kf.Predict();
  const cv::Rect2f p = kf.Box(), t = truth(31);
  EXPECT_NEAR(p.x, t.x, 2.0);
  EXPECT_NEAR(p.y, t.y, 2.0);
  EXPECT_NEAR(p.width, t.width, 2.0);
  EXPECT_NEAR(p.height, t.height, 2.0);
  EXPECT_LT(kf.MahalanobisSq(t), 9.4877);
  EXPECT_GT(kf.MahalanobisSq(cv::Rect2f(t.x + 80, t.y, t.width, t.height)), 9.4877);
}

TEST(KalmanBoxFilter, UncertaintyGrowsWithoutUpdates) {
  KalmanBoxFilter kf(cv::Rect2f(0, 0, 50, 100));
  kf.Predict();
  kf.Update(cv::Rect2f(0, 0, 50, 100));
  const double before = kf.covariance()(0, 0);
  for (int i = 0; i < 5; ++i) kf.Predict();
  EXPECT_GT(kf.covariance()(0, 0), before);
  EXPECT_TRUE(kf.covariance().isApprox(kf.covariance().transpose()));
}

}  // namespace
}  // namespace loci::detection

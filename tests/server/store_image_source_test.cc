// StoreImageSource: a keyframe's images read back from a real SQLite map database for the dense
// refinement of place matches, and the cases that give none (unknown keyframe, images dropped
// by retention) or an error (images that do not decode).
#include <gtest/gtest.h>

#include "common/image_codec.h"
#include "server/runtime/store_image_source.h"
#include "server/storage/sqlite_store.h"
#include "tests/support/temp_dir.h"

namespace loci::server {
namespace {

const PinholeCamera kCamera{50, 50, 32, 24, 64, 48};

// A 64 x 48 keyframe whose grey level and depth (0.5 m + seq cm) tell it apart.
KeyframeRecord Keyframe(int64_t session_row, int64_t seq) {
  KeyframeRecord kf;
  kf.session_row = session_row;
  kf.seq = seq;
  kf.t_ns = 1'700'000'000'000'000'000 + seq * 33'000'000;
  kf.T_odom_cam = SE3d::Identity();
  kf.camera = kCamera;
  kf.depth_scale = 5000;
  const cv::Mat bgr(48, 64, CV_8UC3, cv::Scalar::all(40 + 50 * static_cast<double>(seq)));
  const cv::Mat depth(48, 64, CV_16UC1, cv::Scalar(5000 * (0.5 + 0.01 * seq)));
  kf.rgb_jpeg = *EncodeJpeg(bgr);
  kf.depth_png = *EncodeDepthPng(depth);
  return kf;
}

// A fresh database with robot A's session.
class StoreImageSourceTest : public testing::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    auto opened = SqliteStore::Open(Path("loci.db"));
    ASSERT_TRUE(opened.ok()) << opened.status();
    store_ = std::move(*opened);
    SessionRecord s;
    s.robot_name = "A";
    s.camera = kCamera;
    auto session = store_->CreateSession(s);
    ASSERT_TRUE(session.ok()) << session.status();
    session_row_ = session->row_id;
  }
  std::unique_ptr<SqliteStore> store_;
  int64_t session_row_ = 0;
};

TEST_F(StoreImageSourceTest, ReadsTheKeyframesOwnImagesAndNothingForDroppedOrUnknownOnes) {
  std::vector<int64_t> ids;
  for (int seq = 0; seq < 3; ++seq) {
    auto r = store_->InsertKeyframe(Keyframe(session_row_, seq));
    ASSERT_TRUE(r.ok()) << r.status();
    ids.push_back(r->keyframe_id);
  }
  StoreImageSource source(store_.get());
  for (int seq = 0; seq < 3; ++seq) {
    auto images = source.Read(ids[seq]);
    ASSERT_TRUE(images.ok()) << images.status();
    ASSERT_TRUE(images->has_value());
    const place::KeyframeImages& im = **images;
    EXPECT_EQ(im.bgr.size(), cv::Size(64, 48));
    EXPECT_NEAR(cv::mean(im.bgr)[0], 40 + 50 * seq, 2.0);
    ASSERT_EQ(im.depth_m.type(), CV_32FC1);
    EXPECT_NEAR(im.depth_m.at<float>(10, 10), 0.5 + 0.01 * seq, 1e-3);
    EXPECT_EQ(im.camera.width_px, 64);
  }
  auto unknown = source.Read(ids.back() + 100);
  ASSERT_TRUE(unknown.ok()) << unknown.status();
  EXPECT_FALSE(unknown->has_value());
  // Retention empties the images of keyframes with products: nothing to refine with.
  ASSERT_TRUE(store_->PutProducts(ids[0], "fp", "products").ok());
  auto dropped = store_->DropRawImages(/*before_stored_ns=*/INT64_MAX, /*keep_last=*/0);
  ASSERT_TRUE(dropped.ok()) << dropped.status();
  EXPECT_EQ(*dropped, 1u);
  auto gone = source.Read(ids[0]);
  ASSERT_TRUE(gone.ok()) << gone.status();
  EXPECT_FALSE(gone->has_value());
  EXPECT_TRUE(source.Read(ids[1]).ok() && source.Read(ids[1])->has_value());
}

TEST_F(StoreImageSourceTest, ImagesThatDoNotDecodeAreDataLoss) {
  KeyframeRecord kf = Keyframe(session_row_, 0);
  kf.rgb_jpeg = std::string("\xff\xd8 not a jpeg", 13);
  auto r = store_->InsertKeyframe(kf);
  ASSERT_TRUE(r.ok()) << r.status();
  auto read = StoreImageSource(store_.get()).Read(r->keyframe_id);
  EXPECT_EQ(read.status().code(), absl::StatusCode::kDataLoss) << read.status();
}

}  // namespace
}  // namespace loci::server

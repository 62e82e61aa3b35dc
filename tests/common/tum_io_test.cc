#include "common/tum_io.h"

#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "common/time.h"

namespace loci {
namespace {

const std::string kSample = std::string(LOCI_SOURCE_DIR) + "/tests/data/tum_fr1_rpy_sample";

TEST(TumIo, AssociatesLikeAssociatePy) {
  // a: 0, 10, 20 ms; b: 1, 9, 30, 60 ms; window 5 ms.
  const std::vector<int64_t> a{0, 10'000'000, 20'000'000};
  const std::vector<int64_t> b{1'000'000, 9'000'000, 30'000'000, 60'000'000};
  const auto m = AssociateStamps(a, b, 5'000'000);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(size_t{0}, size_t{0}));
  EXPECT_EQ(m[1], std::make_pair(size_t{1}, size_t{1}));
  // Greedy by |dt|: b=5 is closer to a=4 than to a=0, so a=0 stays unmatched.
  const auto g = AssociateStamps({0, 4'000'000}, {5'000'000}, 10'000'000);
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(g[0].first, 1u);
}

TEST(TumIo, LoadsShippedSample) {
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->frames.size(), 60u);
  for (const TumFrame& f : seq->frames) {
    EXPECT_LT(std::llabs(f.rgb_t_ns - f.depth_t_ns), 20'000'000);
    EXPECT_TRUE(std::filesystem::exists(f.rgb_path)) << f.rgb_path;
    EXPECT_TRUE(std::filesystem::exists(f.depth_path)) << f.depth_path;
  }
  EXPECT_GT(seq->groundtruth.size(), 200u);
  EXPECT_GT(seq->accel.size(), 1000u);
}

TEST(TumIo, GravityFromAccelerometerMatchesGroundTruthUp) {
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(seq.ok());
  // Mocap world z is up; gravity in cam = R_world_cam^T * (0,0,-1). The hand-held camera
  // accelerates, so allow 15 degrees.
  int checked = 0;
  for (size_t k = 0; k < seq->groundtruth.size(); k += 20) {
    const StampedPose& p = seq->groundtruth[k];
    auto g = GravityInCamAt(seq->accel, p.t_ns);
    if (!g.ok()) continue;
    const Vec3d g_gt = p.T_world_cam.rotation().transpose() * Vec3d(0, 0, -1);
    EXPECT_GT(g->dot(g_gt), std::cos(15.0 * M_PI / 180.0));
    ++checked;
  }
  EXPECT_GT(checked, 5);
}

TEST(TumIo, TrajectoryWriteReadRoundTrip) {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    t.push_back({1305031229'000000000LL + i * 33'000'000LL,
                 SE3FromTum(0.1 * i, 0.2, -0.3, 0.0, 0.0, std::sin(0.05 * i), std::cos(0.05 * i))});
  }
  const std::string path = ::testing::TempDir() + "/traj.txt";
  ASSERT_TRUE(WriteTumTrajectory(path, t).ok());
  auto back = ReadTumTrajectory(path);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ((*back)[i].t_ns, t[i].t_ns);
    EXPECT_TRUE((*back)[i].T_world_cam.isApprox(t[i].T_world_cam, 1e-5));
  }
}

// The shipped sample's ground truth (100 Hz, the camera turning at 50-70 deg/s) with every other
// pose left out: each left-out pose is recovered by interpolating its neighbours far better than
// by taking the nearer of them, as a 100 Hz ground truth is used at a camera image's stamp.
TEST(TumIo, InterpolatedPoseBeatsTheNearestSampleOnRealGroundTruth) {
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(seq.ok());
  Trajectory half;
  for (size_t k = 0; k < seq->groundtruth.size(); k += 2) half.push_back(seq->groundtruth[k]);
  std::vector<double> interpolated_deg, nearest_deg;
  for (size_t k = 1; k + 1 < seq->groundtruth.size(); k += 2) {
    const StampedPose& truth = seq->groundtruth[k];
    const auto T = InterpolatePose(half, truth.t_ns, 50'000'000);
    ASSERT_TRUE(T.has_value());
    const StampedPose* near = NearestByTime<StampedPose>(half, truth.t_ns, 50'000'000);
    ASSERT_NE(near, nullptr);
    auto deg = [&](const SE3d& a) {
      return Eigen::AngleAxisd(a.rotation().transpose() * truth.T_world_cam.rotation()).angle() *
             180.0 / M_PI;
    };
    interpolated_deg.push_back(deg(*T));
    nearest_deg.push_back(deg(near->T_world_cam));
  }
  ASSERT_GT(interpolated_deg.size(), 100u);
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  EXPECT_GT(median(nearest_deg), 0.2);  // the camera does turn between samples
  EXPECT_LT(median(interpolated_deg), 0.5 * median(nearest_deg));
  // Outside the trajectory, or across a gap longer than allowed: nothing.
  EXPECT_FALSE(InterpolatePose(half, half.front().t_ns - 1, 50'000'000).has_value());
  EXPECT_FALSE(InterpolatePose(half, half.back().t_ns + 1, 50'000'000).has_value());
  EXPECT_FALSE(InterpolatePose(half, half[3].t_ns + 1, 1'000'000).has_value());
  EXPECT_TRUE(InterpolatePose(half, half[3].t_ns, 0)->isApprox(half[3].T_world_cam));
}

TEST(TumIo, MissingFolderAndBadLines) {
  EXPECT_EQ(LoadTumSequence("/nonexistent").status().code(), absl::StatusCode::kNotFound);
  const std::string path = ::testing::TempDir() + "/bad.txt";
  FILE* f = std::fopen(path.c_str(), "w");
  std::fputs("# comment\n1.0 1 2 3\n", f);
  std::fclose(f);
  EXPECT_EQ(ReadTumTrajectory(path).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace loci

// The loci-track program end to end (offline) on the shipped sample, and the dynamic-feature
// test of paper 004 on exact geometry.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "client/tracking/dynamic_filter.h"
#include "common/config.h"
#include "common/trajectory_eval.h"
#include "common/tum_io.h"

namespace loci {
namespace {

const std::string kSample = SourceDir() + "/tests/data/tum_fr1_rpy_sample";

int RunTrack(const std::string& args) {
  const std::string cmd =
      std::string(LOCI_TRACK_BIN) + " --no-progress --log-level warn " + args + " > /dev/null 2>&1";
  return std::system(cmd.c_str());
}

class LociTrackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("loci_track_test_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::filesystem::path dir_;
};

TEST_F(LociTrackTest, OfflineOdometryWritesTrajectories) {
  ASSERT_EQ(RunTrack("--tum " + kSample + " --offline --detections none --trajectory " +
                     Path("traj.txt") + " --keyframes " + Path("kf.txt")),
            0);
  auto traj = ReadTumTrajectory(Path("traj.txt"));
  auto kfs = ReadTumTrajectory(Path("kf.txt"));
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(traj.ok() && kfs.ok() && seq.ok());
  EXPECT_EQ(traj->size(), seq->frames.size());
  EXPECT_GE(kfs->size(), 3u);
  EXPECT_LT(kfs->size(), traj->size());
  auto ate = ComputeAte(seq->groundtruth, *traj);
  ASSERT_TRUE(ate.ok());
  EXPECT_LT(ate->trans_m.rmse, 0.05);
}

TEST_F(LociTrackTest, PosesFromFileAreUsedAsGiven) {
  ASSERT_EQ(RunTrack("--tum " + kSample + " --offline --detections none --poses " + kSample +
                     "/groundtruth.txt --trajectory " + Path("traj.txt")),
            0);
  auto traj = ReadTumTrajectory(Path("traj.txt"));
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(traj.ok() && seq.ok());
  ASSERT_FALSE(traj->empty());
  auto ate = ComputeAte(seq->groundtruth, *traj);
  ASSERT_TRUE(ate.ok());
  EXPECT_LT(ate->trans_m.rmse, 0.005);  // nearest ground-truth pose within 20 ms
}

TEST_F(LociTrackTest, BadInputFailsWithError) {
  EXPECT_NE(RunTrack("--tum " + Path("missing") + " --offline --detections none"), 0);
  EXPECT_NE(RunTrack("--tum " + kSample + " --offline --detections " + Path("none.jsonl")), 0);
  // No server listening: a clear error, not a hang.
  EXPECT_NE(RunTrack("--tum " + kSample + " --detections none --server 127.0.0.1:1"), 0);
}

TEST_F(LociTrackTest, StrictConfigTurnsAMisspeltKeyIntoAnError) {
  std::ofstream(Path("client.yaml")) << "tracker:\n  min_depth_m: 0.1\n  max_dept_m: 4.0\n";
  const std::string run = "--tum " + kSample +
                          " --offline --detections none --max-frames 3 --config " +
                          Path("client.yaml");
  EXPECT_EQ(RunTrack(run), 0);  // a warning only
  const std::string err = Path("strict.err");
  const std::string cmd = std::string(LOCI_TRACK_BIN) + " --no-progress " + run +
                          " --strict-config > /dev/null 2> " + err;
  const int status = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status;
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(Path("client.yaml") + ":3: unknown key 'max_dept_m' in 'tracker'"),
            std::string::npos)
      << text;
}

TEST(DynamicFilterTest, MovingPointScoresAboveThresholdStaticBelow) {
  TrackerOptions opt;
  DynamicFilter f(opt);
  const PinholeCamera& cam = opt.camera;
  SE3d T_world_prev = SE3d::Identity();
  SE3d T_world_cur = SE3d::Identity();
  T_world_cur.translation() = Vec3d(0.05, 0.0, 0.0);  // camera moved 5 cm right
  const SE3d T_cur_world = T_world_cur.inverse();
  const Vec3d p_world(0.3, -0.2, 2.0);
  const Eigen::Vector2d prev_uv = *cam.Project(T_world_prev.inverse() * p_world);
  // Static: observed where it projects, with its true depth.
  const Vec3d p_cur = T_cur_world * p_world;
  const double d_static = f.DynamicValue(*cam.Project(p_cur), p_cur.z(), p_world, T_cur_world, true,
                                         prev_uv, T_world_prev);
  // Moving: the point moved 10 cm down and 20 cm back since the previous observation.
  const Vec3d p_moved = T_cur_world * (p_world + Vec3d(0, 0.1, 0.2));
  const double d_moving = f.DynamicValue(*cam.Project(p_moved), p_moved.z(), p_world, T_cur_world,
                                         true, prev_uv, T_world_prev);
  const float kPerson = static_cast<float>(f.ClassWeight("person"));
  EXPECT_LT(d_static, 1e-6);
  EXPECT_GT(d_moving, f.Threshold(kPerson));
  // Outside boxes the threshold is looser (weight 0.25) and unknown classes are static (w 0).
  EXPECT_GT(f.Threshold(-1.f), f.Threshold(kPerson));
  EXPECT_TRUE(std::isinf(f.Threshold(static_cast<float>(f.ClassWeight("wall")))));
}

}  // namespace
}  // namespace loci

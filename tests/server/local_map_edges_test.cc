// Odometry edges within a client's local map (graph.odometry.local_map_keyframes): a tracker that
// matches every keyframe against the points of its last N keyframes errs by a bounded amount
// between two keyframes of one window, not by a chain of independent steps. On a real hand-held
// sequence the server's verified loops are noisier than that odometry; with consecutive edges
// only, the graph takes their noise into the map. Synthetic, exact truth.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/trajectory_eval.h"
#include "server/graph/graph_math.h"
#include "server/graph/pose_graph.h"
#include "server/graph/synthetic_graph.h"

namespace loci::server {
namespace {

Vec6d Gaussian6(double trans_sigma_m, double rot_sigma_rad, std::mt19937* rng) {
  std::normal_distribution<double> t(0, trans_sigma_m), r(0, rot_sigma_rad);
  Vec6d e;
  e << t(*rng), t(*rng), t(*rng), r(*rng), r(*rng), r(*rng);
  return e;
}

// A camera 1.5 m above the floor swinging its yaw and pitch back and forth about one spot (as
// fr1_rpy's does), 150 keyframes at 10 Hz. Its odometry errs per keyframe with independent
// noise (a local-map tracker's: nothing accumulates), 0.3 deg and 3 mm per axis (loci-track on
// fr1_rpy: 0.66 deg median between two keyframes, `loci eval loops`).
SyntheticRobot SwingingCamera(std::mt19937* rng) {
  SyntheticRobot robot;
  robot.robot = "robot1";
  std::vector<SE3d> estimate;
  for (int i = 0; i < 150; ++i) {
    const double yaw = 0.6 * std::sin(0.21 * i), pitch = 0.25 * std::sin(0.13 * i);
    SE3d T = SE3d::Identity();
    T.linear() = (Eigen::AngleAxisd(yaw, Vec3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch, Vec3d::UnitY())).toRotationMatrix();
    T.translation() = Vec3d(0.05 * std::sin(0.07 * i), 0, 1.5);
    robot.T_map_kf_true.push_back(T);
    estimate.push_back(i == 0 ? T : T * PoseFromError6(Gaussian6(0.003, 0.005, rng)));
  }
  for (size_t i = 0; i < estimate.size(); ++i) {
    robot.nodes.push_back({static_cast<int64_t>(i + 1), robot.robot,
                           static_cast<int64_t>(i) * 100'000'000, estimate[i], false,
                           Vec3d::Zero()});
    robot.T_prev_kf.push_back(i == 0 ? SE3d::Identity() : estimate[i - 1].inverse() * estimate[i]);
  }
  return robot;
}

// Loops 20-60 keyframes apart, every 3rd keyframe, measured with 0.67 deg and 1.2 cm of noise
// per axis (the server's verified loops on fr1_rpy: median error 1.03 deg and 0.018 m, `loci eval
// loops`), weighed as the server does (0.02 m, 0.01 rad).
std::vector<GraphEdge> NoisyLoops(const SyntheticRobot& robot, std::mt19937* rng) {
  std::vector<GraphEdge> loops;
  const Information6 info = IsotropicInformation(0.02, 0.01);
  for (size_t b = 60; b < robot.nodes.size(); b += 3) {
    for (size_t gap : {20, 40, 60}) {
      const size_t a = b - gap;
      const SE3d T_a_b = robot.T_map_kf_true[a].inverse() * robot.T_map_kf_true[b] *
                         PoseFromError6(Gaussian6(0.012, 0.0117, rng));
      loops.push_back({EdgeKind::kLoop, robot.nodes[a].keyframe_id, robot.nodes[b].keyframe_id,
                       T_a_b, info});
    }
  }
  return loops;
}

// The mean rotation error of the graph's keyframes (after a rigid alignment by positions is
// not meaningful for a camera that barely moves): angle of T_true^-1 T_est, deg.
double MeanRotationErrorDeg(const SyntheticRobot& robot, const PoseGraph& graph) {
  double sum = 0;
  for (size_t i = 0; i < robot.nodes.size(); ++i) {
    sum += RotationAngleRad(robot.T_map_kf_true[i].inverse() * graph.nodes()[i].T_map_kf);
  }
  return sum / static_cast<double>(robot.nodes.size()) * 180.0 / M_PI;
}

double SolvedErrorDeg(const SyntheticRobot& robot, const std::vector<GraphEdge>& loops,
                      int local_map_keyframes) {
  GraphOptions options;
  options.odometry.local_map_keyframes = local_map_keyframes;
  PoseGraph graph(options);
  EXPECT_TRUE(AddRobot(robot, &graph).ok());
  EXPECT_TRUE(AddConstraints(loops, &graph).ok());
  const auto r = graph.Optimize();
  EXPECT_TRUE(r.ok()) << r.status();
  return MeanRotationErrorDeg(robot, graph);
}

TEST(LocalMapEdges, NoisyLoopsDoNotDegradeALocalMapTrackersOdometry) {
  std::mt19937 rng(11);
  const SyntheticRobot robot = SwingingCamera(&rng);
  const std::vector<GraphEdge> loops = NoisyLoops(robot, &rng);
  PoseGraph odometry(GraphOptions{});
  ASSERT_TRUE(AddRobot(robot, &odometry).ok());
  const double before = MeanRotationErrorDeg(robot, odometry);
  const double chain = SolvedErrorDeg(robot, loops, 0);
  const double window = SolvedErrorDeg(robot, loops, 30);
  std::printf("mean rotation error: odometry %.3f deg; solved with %zu loops, consecutive edges "
              "only %.3f deg, with a 30-keyframe local map %.3f deg\n",
              before, loops.size(), chain, window);
  // Measured: 0.49 deg odometry, 0.84 deg solved on consecutive edges, 0.55 deg with the
  // window's edges: they hold the odometry where it is good; the loops beyond the window (40 and
  // 60 keyframes apart) still pull it a little, as their information says they may.
  EXPECT_GT(chain, before * 1.5);  // the failure the window's edges are for
  EXPECT_LT(window, chain * 0.8);
  EXPECT_LT(window, before * 1.35);
}

// The drifting odometry of a robot driving two laps: loops beyond the window still correct it.
TEST(LocalMapEdges, LoopsStillCutADriftingOdometrysAteToAThird) {
  std::mt19937 rng(7);
  const std::vector<SE3d> truth = SquarePath(SquarePathOptions{});
  const SyntheticRobot robot =
      MakeSyntheticRobot("robot1", 1, truth, OdometryNoiseOptions{}, truth.front(), false, &rng);
  const std::vector<GraphEdge> loops =
      ProximityEdges(robot, robot, EdgeKind::kLoop, ProximityEdgeOptions{}, &rng);
  ASSERT_GE(loops.size(), 10u);
  GraphOptions options;
  options.odometry.local_map_keyframes = 30;
  PoseGraph graph(options);
  ASSERT_TRUE(AddRobot(robot, &graph).ok());
  ASSERT_TRUE(AddConstraints(loops, &graph).ok());
  const auto before = ComputeAte(TrueTrajectory(robot), EstimatedTrajectory(robot, graph));
  ASSERT_TRUE(before.ok());
  const auto r = graph.Optimize();
  ASSERT_TRUE(r.ok()) << r.status();
  const auto after = ComputeAte(TrueTrajectory(robot), EstimatedTrajectory(robot, graph));
  ASSERT_TRUE(after.ok());
  std::printf("ATE before %.4f m, after %.4f m (30-keyframe local map edges)\n",
              before->trans_m.rmse, after->trans_m.rmse);
  EXPECT_GT(before->trans_m.rmse, 0.10);
  EXPECT_LE(after->trans_m.rmse, before->trans_m.rmse / 3);
  EXPECT_EQ(r->stats.loops_rejected, 0u);
}

// Poses whose tracking quality the client did not report (loci-track --poses: a file's poses,
// tracked against no local map) keep consecutive edges only: the solution is the same with and
// without the window.
TEST(LocalMapEdges, PosesOfUnknownQualityGetNoWindowEdges) {
  std::mt19937 rng(11);
  const SyntheticRobot robot = SwingingCamera(&rng);
  const std::vector<GraphEdge> loops = NoisyLoops(robot, &rng);
  std::vector<SE3d> solved[2];
  for (const int window : {0, 30}) {
    GraphOptions options;
    options.odometry.local_map_keyframes = window;
    PoseGraph graph(options);
    for (size_t i = 0; i < robot.nodes.size(); ++i) {
      ASSERT_TRUE(graph.AddKeyframe(robot.nodes[i]).ok());
      if (i == 0) continue;
      ASSERT_TRUE(graph.AddOdometryEdge(robot.nodes[i - 1].keyframe_id, robot.nodes[i].keyframe_id,
                                        robot.T_prev_kf[i], TrackingQuality{}).ok());
    }
    ASSERT_TRUE(AddConstraints(loops, &graph).ok());
    ASSERT_TRUE(graph.Optimize().ok());
    for (const KeyframeNode& n : graph.nodes()) solved[window > 0].push_back(n.T_map_kf);
  }
  ASSERT_EQ(solved[0].size(), solved[1].size());
  for (size_t i = 0; i < solved[0].size(); ++i) {
    EXPECT_TRUE(solved[0][i].isApprox(solved[1][i], 1e-12)) << "keyframe " << i;
  }
}

TEST(LocalMapEdges, NegativeWindowIsRefused) {
  GraphOptions options;
  options.odometry.local_map_keyframes = -1;
  EXPECT_FALSE(options.Validate().ok());
}

}  // namespace
}  // namespace loci::server

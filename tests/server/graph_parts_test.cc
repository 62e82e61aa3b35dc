// Parts of the pose graph: options from YAML, odometry information from tracking quality, the
// greedy clique, the pairwise cycle test, and the graph's input checks.
#include <gtest/gtest.h>

#include <random>

#include "common/config.h"
#include "server/graph/graph_math.h"
#include "server/graph/max_clique.h"
#include "server/graph/odometry_information.h"
#include "server/graph/pcm.h"
#include "server/graph/pose_graph.h"
#include "server/graph/synthetic_graph.h"

namespace loci::server {
namespace {

TEST(GraphOptions, ShippedSectionParsesStrictlyAndStatesTheDefaults) {
  SetStrictConfig(true);
  const auto root = LoadYamlFile(SourceDir() + "/config/server.yaml");
  ASSERT_TRUE(root.ok()) << root.status();
  ASSERT_TRUE((*root)["graph"]);
  GraphOptions parsed;
  const Status s = parsed.FromYaml((*root)["graph"]);
  SetStrictConfig(false);
  ASSERT_TRUE(s.ok()) << s;
  const GraphOptions d;
  EXPECT_EQ(parsed.dof, d.dof);
  EXPECT_EQ(parsed.odometry.sigma_trans_m, d.odometry.sigma_trans_m);
  EXPECT_EQ(parsed.odometry.sigma_rot_per_rad, d.odometry.sigma_rot_per_rad);
  EXPECT_EQ(parsed.odometry.full_quality_inliers, d.odometry.full_quality_inliers);
  EXPECT_EQ(parsed.pcm.chi2_threshold, d.pcm.chi2_threshold);
  EXPECT_EQ(parsed.pcm.min_set_size, d.pcm.min_set_size);
  EXPECT_EQ(parsed.pcm.residual_chi2, d.pcm.residual_chi2);
  EXPECT_EQ(parsed.loss.type, d.loss.type);
  EXPECT_EQ(parsed.loss.scale, d.loss.scale);
  EXPECT_EQ(parsed.landmarks.enabled, d.landmarks.enabled);
  EXPECT_EQ(parsed.landmarks.sigma_m, d.landmarks.sigma_m);
  EXPECT_EQ(parsed.solver.function_tolerance, d.solver.function_tolerance);
  EXPECT_EQ(parsed.place_rot_rad, d.place_rot_rad);
  EXPECT_EQ(parsed.moved_trans_m, d.moved_trans_m);
}

TEST(GraphOptions, UnknownKeysFailStrictlyAndBadValuesAreRefused) {
  SetStrictConfig(true);
  GraphOptions o;
  const Status s = o.FromYaml(YAML::Load("pcm:\n  chi2: 3\n"));
  SetStrictConfig(false);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("unknown key 'chi2' in 'graph.pcm'"), std::string::npos) << s;

  GraphOptions read;
  ASSERT_TRUE(read.FromYaml(YAML::Load("dof: 6dof\nloss: {type: cauchy, scale: 2}\n")).ok());
  EXPECT_EQ(read.dof, "6dof");
  EXPECT_EQ(read.loss.type, "cauchy");
  EXPECT_EQ(read.loss.scale, 2.0);
  EXPECT_FALSE(GraphOptions().FromYaml(YAML::Load("dof: 5dof\n")).ok());
  EXPECT_FALSE(GraphOptions().FromYaml(YAML::Load("loss: {type: l1}\n")).ok());
  EXPECT_FALSE(GraphOptions().FromYaml(YAML::Load("odometry: {min_quality: 0}\n")).ok());
  EXPECT_FALSE(GraphOptions().FromYaml(YAML::Load("pcm: {min_set_size: 0}\n")).ok());
  EXPECT_TRUE(GraphOptions().Validate().ok());
}

TEST(OdometryInformation, QualityScalesTheStandardDeviations) {
  const OdometryInformationOptions o;
  SE3d step = SE3d::Identity();
  step.translation() = Vec3d(0.1, 0, 0);
  const Information6 full = OdometryInformation(step, {}, o);  // unknown quality: 1
  const double sigma_t = o.sigma_trans_m + o.sigma_trans_per_m * 0.1;
  EXPECT_NEAR(full(0, 0), 1 / (sigma_t * sigma_t), 1e-6);
  EXPECT_NEAR(full(5, 5), 1 / (o.sigma_rot_rad * o.sigma_rot_rad), 1e-6);
  const Information6 half = OdometryInformation(step, {0.5, -1}, o);
  EXPECT_NEAR(half(0, 0), full(0, 0) / 4, 1e-6);  // quality 0.5: sigmas doubled
  const Information6 inliers = OdometryInformation(step, {-1, 50}, o);
  EXPECT_NEAR(inliers(3, 3), full(3, 3) / 4, 1e-6);  // 50 of 100 inliers = quality 0.5
  const Information6 lost = OdometryInformation(step, {0.0, -1}, o);
  EXPECT_NEAR(lost(0, 0), full(0, 0) * o.min_quality * o.min_quality, 1e-6);  // the floor
  EXPECT_EQ(EffectiveQuality({-1, 400}, o), 1.0);
}

std::vector<std::vector<char>> Graph(int n, const std::vector<std::pair<int, int>>& edges) {
  std::vector<std::vector<char>> adj(n, std::vector<char>(n, 0));
  for (const auto& [a, b] : edges) adj[a][b] = adj[b][a] = 1;
  return adj;
}

TEST(GreedyMaxClique, FindsTheConsistentSetBesideOutliers) {
  // 0-4 form a clique; 5 is joined to 0 and 1 only; 6 to nothing; 7-8 a pair.
  std::vector<std::pair<int, int>> e;
  for (int a = 0; a < 5; ++a) {
    for (int b = a + 1; b < 5; ++b) e.push_back({a, b});
  }
  e.insert(e.end(), {{5, 0}, {5, 1}, {7, 8}});
  EXPECT_EQ(GreedyMaxClique(Graph(9, e)), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(GreedyMaxClique(Graph(3, {})).size(), 1u);
  EXPECT_TRUE(GreedyMaxClique({}).empty());
}

TEST(Pcm, TwoTrueLoopsAreConsistentAndAWrongOneIsNot) {
  std::mt19937 rng(3);
  SquarePathOptions path;
  const auto truth = SquarePath(path);
  const SyntheticRobot r =
      MakeSyntheticRobot("r", 1, truth, OdometryNoiseOptions{}, truth.front(), false, &rng);
  std::vector<ChainLink> links;
  const OdometryInformationOptions info_options;
  for (size_t k = 1; k < truth.size(); ++k) {
    links.push_back({k - 1, k, r.T_prev_kf[k], OdometryInformation(r.T_prev_kf[k], {}, info_options)});
  }
  const OdometryChains chains = BuildChains(truth.size(), links);
  ASSERT_EQ(chains.members.size(), 1u);
  const Covariance6 cov = IsotropicInformation(0.01, 0.005).inverse();
  auto loop = [&](size_t a, size_t b, size_t claimed_a) {
    return PcmEdge{a, b, truth[claimed_a].inverse() * truth[b], cov};
  };
  const PcmEdge l1 = loop(20, 120, 20), l2 = loop(40, 140, 40), wrong = loop(52, 160, 60);
  const double good = PairwiseCycleChi2(chains, l1, l2);
  const double bad = PairwiseCycleChi2(chains, l1, wrong);
  std::printf("chi2: true pair %.2f, with the wrong loop %.1f\n", good, bad);
  EXPECT_LT(good, PcmOptions{}.chi2_threshold);
  EXPECT_GT(bad, PcmOptions{}.chi2_threshold);
  // The offset form the selection uses agrees with the cycle form (first order).
  const double good_offset = PairwiseOffsetChi2(chains, l1, l2);
  const double bad_offset = PairwiseOffsetChi2(chains, l1, wrong);
  std::printf("offset form: %.2f, %.1f\n", good_offset, bad_offset);
  EXPECT_NEAR(good_offset, good, 0.1 * good + 0.05);
  EXPECT_NEAR(bad_offset, bad, 0.1 * bad);
  const std::vector<bool> keep = SelectConsistentEdges(chains, {l1, wrong, l2}, PcmOptions{});
  EXPECT_EQ(keep, (std::vector<bool>{true, false, true}));
  // A lone loop is a set of one, below min_set_size 2.
  EXPECT_EQ(SelectConsistentEdges(chains, {l1}, PcmOptions{}), std::vector<bool>{false});
}

TEST(PoseGraph, RefusesMalformedInput) {
  const GraphOptions options;
  PoseGraph g(options);
  ASSERT_TRUE(g.AddKeyframe({1, "a", 0, SE3d::Identity(), false}).ok());
  ASSERT_TRUE(g.AddKeyframe({2, "a", 1, SE3d::Identity(), false}).ok());
  ASSERT_TRUE(g.AddKeyframe({3, "b", 2, SE3d::Identity(), false}).ok());
  EXPECT_FALSE(g.AddKeyframe({1, "a", 0, SE3d::Identity(), false}).ok());  // id twice
  EXPECT_FALSE(g.AddOdometryEdge(2, 1, SE3d::Identity(), {}).ok());        // backwards
  EXPECT_FALSE(g.AddOdometryEdge(2, 3, SE3d::Identity(), {}).ok());        // across robots
  EXPECT_TRUE(g.AddOdometryEdge(1, 2, SE3d::Identity(), {}).ok());
  EXPECT_FALSE(g.AddOdometryEdge(1, 2, SE3d::Identity(), {}).ok());  // a second successor
  const Information6 info = Information6::Identity();
  EXPECT_FALSE(g.AddLoopEdge(1, 3, SE3d::Identity(), info).ok());   // a loop across robots
  EXPECT_FALSE(g.AddMergeEdge(1, 2, SE3d::Identity(), info).ok());  // a merge within one
  EXPECT_FALSE(g.AddMergeEdge(1, 3, SE3d::Identity(), -info).ok());  // not positive definite
  EXPECT_EQ(g.AddLoopEdge(1, 9, SE3d::Identity(), info).code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(g.AddMergeEdge(1, 3, SE3d::Identity(), info).ok());
}

}  // namespace
}  // namespace loci::server

// Parts of the pose graph: options from YAML, odometry information from tracking quality, the
// greedy clique, the pairwise cycle test, and the graph's input checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "common/config.h"
#include "server/graph/graph_math.h"
#include "server/graph/max_clique.h"
#include "server/graph/odometry_information.h"
#include "server/graph/pcm.h"
#include "server/graph/pcm_cache.h"
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
  // The one default the server's file changes: the library solves 4-DoF when every keyframe is
  // gravity-aligned ("auto"); the server solves 6-DoF, so that two robots' odometry tilt drifts
  // do not stand against each other in one map.
  EXPECT_EQ(d.dof, "auto");
  EXPECT_EQ(parsed.dof, "6dof");
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

// The conflict lists (pairs not joined) of the graph with these edges.
std::vector<std::vector<int>> Graph(int n, const std::vector<std::pair<int, int>>& edges) {
  std::vector<std::vector<char>> adj(n, std::vector<char>(n, 0));
  for (const auto& [a, b] : edges) adj[a][b] = adj[b][a] = 1;
  std::vector<std::vector<int>> conflicts(n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      if (a != b && !adj[a][b]) conflicts[a].push_back(b);
    }
  }
  return conflicts;
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

// The cache's selection equals testing every pair, solve after solve, while the graph grows
// (keyframes appended, loops added, a loop re-measured, a chain cut short); it tests only the
// pairs it has not seen.
TEST(PcmCache, GrowingGraphGivesTheSameSelectionWithFewerTests) {
  std::mt19937 rng(5);
  SquarePathOptions path;
  path.keyframes = 400;
  const auto truth = SquarePath(path);
  const SyntheticRobot r =
      MakeSyntheticRobot("r", 1, truth, OdometryNoiseOptions{}, truth.front(), false, &rng);
  const OdometryInformationOptions info_options;
  auto chains_of = [&](size_t n, size_t skip) {  // the first n nodes, without `skip`'s link
    std::vector<ChainLink> links;
    for (size_t k = 1; k < n; ++k) {
      if (k == skip) continue;
      links.push_back(
          {k - 1, k, r.T_prev_kf[k], OdometryInformation(r.T_prev_kf[k], {}, info_options)});
    }
    return BuildChains(n, links);
  };
  const Covariance6 cov = IsotropicInformation(0.01, 0.005).inverse();
  std::vector<PcmEdge> loops;
  for (size_t b = 100; b < truth.size(); b += 3) {  // true loops one lap back, some wrong
    const size_t a = b - 100;
    const bool wrong = b % 37 == 1;
    const size_t claimed_a = wrong ? a + 8 : a;
    loops.push_back({a, b, truth[claimed_a].inverse() * truth[b], cov,
                     {static_cast<int64_t>(a), static_cast<int64_t>(b)}});
  }
  std::vector<int64_t> ids(truth.size());
  for (size_t k = 0; k < ids.size(); ++k) ids[k] = static_cast<int64_t>(k) + 1000;
  PcmCache cache;
  size_t full_pairs = 0;
  auto check = [&](size_t n, size_t skip, const std::vector<PcmEdge>& edges) {
    const OdometryChains chains = chains_of(n, skip);
    cache.BeginSolve(chains, std::vector<int64_t>(ids.begin(), ids.begin() + n), 16.81);
    const std::vector<bool> cached = SelectConsistentEdges(chains, edges, PcmOptions{}, &cache);
    cache.EndSolve();
    EXPECT_EQ(cached, SelectConsistentEdges(chains, edges, PcmOptions{})) << n << " nodes";
    full_pairs += edges.size() * (edges.size() - 1) / 2;
    return std::count(cached.begin(), cached.end(), false);
  };
  std::vector<PcmEdge> edges;
  int rejected = 0;
  for (size_t n = 160; n <= truth.size(); n += 60) {
    for (const PcmEdge& e : loops) {
      if (e.b < n && (edges.empty() || e.b > edges.back().b)) edges.push_back(e);
    }
    rejected = check(n, 0, edges);
  }
  EXPECT_GE(rejected, 2);  // the wrong loops
  const size_t incremental = cache.pairs_tested();
  std::printf("pairs tested: %zu with the cache, %zu without\n", incremental, full_pairs);
  EXPECT_EQ(incremental, edges.size() * (edges.size() - 1) / 2);  // each pair once
  EXPECT_LT(incremental, full_pairs / 2);
  // A re-measured loop is tested again; a chain cut in two starts the cache afresh.
  edges[3].T_a_b = truth[edges[3].a + 8].inverse() * truth[edges[3].b];
  check(truth.size(), 0, edges);
  EXPECT_EQ(cache.pairs_tested(), incremental + edges.size() - 1);
  check(truth.size(), 250, edges);
  EXPECT_GT(cache.pairs_tested(), incremental + edges.size());
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

// LoopCloser (server/align/loop_closer.h): the server's bookkeeping around the pose graph, on
// synthetic trajectories with exact ground truth (server/graph/synthetic_graph.h). The robot's
// odometry poses and verified matches go in as the server records them; the map poses handed
// to Optimize are the drifted ones the map holds. Loops cut the drift, a wrong match does not
// move the map, a tracking loss (new odometry segment) gets no odometry edge, and a second
// session joins through merges.
#include "server/align/loop_closer.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "common/trajectory_eval.h"
#include "server/graph/synthetic_graph.h"

namespace loci::server {
namespace {

struct Scene {
  SyntheticRobot robot;
  std::vector<GraphEdge> loops;
};

// Two laps of a 4 m square, 200 keyframes, 0.11 deg/keyframe yaw drift (gravity-aligned nodes).
Scene MakeScene(uint32_t seed = 11) {
  std::mt19937 rng(seed);
  const std::vector<SE3d> truth = SquarePath(SquarePathOptions{});
  Scene s;
  s.robot = MakeSyntheticRobot("r", 1, truth, OdometryNoiseOptions{}, truth.front(), true, &rng);
  s.loops = ProximityEdges(s.robot, s.robot, EdgeKind::kLoop, ProximityEdgeOptions{}, &rng);
  return s;
}

LoopOptions Options() {
  LoopOptions o;
  o.sigma_trans_m = 0.01;  // the synthetic matches' noise
  o.sigma_rot_rad = 0.005;
  return o;
}

// Records the robot as session `row` (odometry = its drifted estimates, which start at its
// first keyframe), with `segment_break_at` starting a new odometry segment there (0 = none).
void Record(const SyntheticRobot& r, int64_t row, LoopCloser* closer, int segment_break_at = 0) {
  for (size_t k = 0; k < r.nodes.size(); ++k) {
    const KeyframeNode& n = r.nodes[k];
    const int segment = (segment_break_at > 0 && static_cast<int>(k) >= segment_break_at) ? 1 : 0;
    closer->AddKeyframe({n.keyframe_id, row, segment, n.t_ns, n.T_map_kf});
    closer->NoteRecognised();
  }
}

void AddMatches(const std::vector<GraphEdge>& edges, bool loop, LoopCloser* closer) {
  for (const GraphEdge& e : edges) closer->AddMatch({e.from_id, e.to_id, e.T_a_b, 100, 0.01, loop});
}

std::vector<MappedKeyframe> Mapped(const SyntheticRobot& r) {
  std::vector<MappedKeyframe> out;
  for (const KeyframeNode& n : r.nodes) out.push_back({n.keyframe_id, n.T_map_kf});
  return out;
}

// The mapped poses after applying the updates.
std::map<int64_t, SE3d> Apply(const std::vector<MappedKeyframe>& mapped, const GraphResult& r) {
  std::map<int64_t, SE3d> poses;
  for (const MappedKeyframe& m : mapped) poses[m.keyframe_id] = m.T_map_kf;
  for (const KeyframePoseUpdate& u : r.updates) poses[u.keyframe_id] = u.T_map_kf;
  return poses;
}

double Ate(const SyntheticRobot& robot, const std::map<int64_t, SE3d>& poses) {
  Trajectory est;
  for (const KeyframeNode& n : robot.nodes) est.push_back({n.t_ns, poses.at(n.keyframe_id)});
  auto ate = ComputeAte(TrueTrajectory(robot), est);
  EXPECT_TRUE(ate.ok()) << ate.status();
  return ate.ok() ? ate->trans_m.rmse : 1e9;
}

TEST(LoopCloser, RecordedLoopsCutTheDriftToAThirdAndStatsSaySo) {
  const Scene s = MakeScene();
  LoopCloser closer(GraphOptions{}, Options());
  Record(s.robot, 1, &closer);
  EXPECT_FALSE(closer.Due());  // no match yet
  AddMatches(s.loops, true, &closer);
  ASSERT_TRUE(closer.Due());
  const std::vector<MappedKeyframe> mapped = Mapped(s.robot);
  std::map<int64_t, SE3d> before;
  for (const MappedKeyframe& m : mapped) before[m.keyframe_id] = m.T_map_kf;
  auto r = closer.Optimize(mapped, /*gravity_aligned=*/true);
  ASSERT_TRUE(r.ok()) << r.status();
  const double ate_before = Ate(s.robot, before), ate_after = Ate(s.robot, Apply(mapped, *r));
  std::printf("ATE %.4f m -> %.4f m, %zu loops kept\n", ate_before, ate_after,
              r->stats.loops_accepted);
  EXPECT_GT(ate_before, 0.10);
  EXPECT_LE(ate_after, ate_before / 3);
  EXPECT_TRUE(r->stats.four_dof);
  EXPECT_EQ(r->stats.odometry_edges, s.robot.nodes.size() - 1);
  EXPECT_FALSE(closer.Due());  // reset by the solve
  // New matches alone are not enough: keyframes must have gone through place recognition too.
  AddMatches(s.loops, true, &closer);
  EXPECT_FALSE(closer.Due());
  for (int i = 0; i < Options().optimize_min_keyframes; ++i) closer.NoteRecognised();
  EXPECT_TRUE(closer.Due());
  const LoopStats st = closer.Stats();
  EXPECT_EQ(st.loop_matches, 2 * s.loops.size());  // again after the solve
  EXPECT_EQ(st.optimizations, 1u);
  EXPECT_EQ(st.keyframes_moved, r->updates.size());
}

TEST(LoopCloser, AWrongMatchDoesNotMoveTheMapBeyondTwoCentimetres) {
  const Scene s = MakeScene();
  const std::vector<MappedKeyframe> mapped = Mapped(s.robot);
  LoopCloser clean(GraphOptions{}, Options()), dirty(GraphOptions{}, Options());
  Record(s.robot, 1, &clean);
  Record(s.robot, 1, &dirty);
  AddMatches(s.loops, true, &clean);
  AddMatches(s.loops, true, &dirty);
  // A keyframe of the second lap "recognised" at a place 1.2 m along the square from where it
  // really is (a look-alike corner), measured as if it were the same spot.
  const int64_t a = s.robot.nodes[20].keyframe_id, b = s.robot.nodes[160].keyframe_id;
  dirty.AddMatch({a, b, SE3d::Identity(), 200, 0.005, true});
  auto rc = clean.Optimize(mapped, true);
  auto rd = dirty.Optimize(mapped, true);
  ASSERT_TRUE(rc.ok() && rd.ok());
  const auto pc = Apply(mapped, *rc), pd = Apply(mapped, *rd);
  double worst_m = 0;
  for (const auto& [id, T] : pc)
    worst_m = std::max(worst_m, (T.translation() - pd.at(id).translation()).norm());
  std::printf("wrong match: %zu loops rejected, map moved by %.4f m\n", rd->stats.loops_rejected,
              worst_m);
  EXPECT_GE(rd->stats.loops_rejected, 1u);
  EXPECT_LT(worst_m, 0.02);
}

TEST(LoopCloser, ANewOdometrySegmentHasNoOdometryEdge) {
  const Scene s = MakeScene();
  LoopCloser closer(GraphOptions{}, Options());
  Record(s.robot, 1, &closer, /*segment_break_at=*/120);
  AddMatches(s.loops, true, &closer);
  auto r = closer.Optimize(Mapped(s.robot), true);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->stats.odometry_edges, s.robot.nodes.size() - 2);
}

TEST(LoopCloser, MatchesOfKeyframesNotInTheMapWait) {
  const Scene s = MakeScene();
  LoopCloser closer(GraphOptions{}, Options());
  Record(s.robot, 1, &closer);
  AddMatches(s.loops, true, &closer);
  // Only the first lap is mapped: every loop's later keyframe is missing, so no loop is used.
  std::vector<MappedKeyframe> first_lap = Mapped(s.robot);
  first_lap.resize(100);
  auto r = closer.Optimize(first_lap, true);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->stats.nodes, 100u);
  EXPECT_EQ(r->stats.loop_edges, 0u);
}

TEST(LoopCloser, ASecondSessionJoinsThroughMerges) {
  std::mt19937 rng(5);
  SquarePathOptions path;
  path.keyframes = 200;
  const std::vector<SE3d> truth = SquarePath(path);
  const std::vector<SE3d> truth_a(truth.begin(), truth.begin() + 120);
  const std::vector<SE3d> truth_b(truth.begin() + 80, truth.end());
  const SyntheticRobot a =
      MakeSyntheticRobot("a", 1, truth_a, OdometryNoiseOptions{}, truth_a.front(), true, &rng);
  // b was placed by the aligner 10 cm and 3 deg off its truth (one match's error).
  SE3d off = SE3d::Identity();
  off.linear() = Eigen::AngleAxisd(0.05, Vec3d::UnitZ()).toRotationMatrix();
  off.translation() = Vec3d(0.1, 0, 0);
  const SyntheticRobot b = MakeSyntheticRobot("b", 1001, truth_b, OdometryNoiseOptions{},
                                              off * truth_b.front(), true, &rng);
  ProximityEdgeOptions near;
  near.every = 2;
  const std::vector<GraphEdge> merges = ProximityEdges(a, b, EdgeKind::kMerge, near, &rng);
  ASSERT_GE(merges.size(), 5u);
  LoopCloser closer(GraphOptions{}, Options());
  Record(a, 1, &closer);
  Record(b, 2, &closer);
  AddMatches(merges, false, &closer);
  std::vector<MappedKeyframe> mapped = Mapped(a);
  for (const MappedKeyframe& m : Mapped(b)) mapped.push_back(m);
  auto r = closer.Optimize(mapped, true);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->stats.merges_accepted, merges.size());
  EXPECT_EQ(r->stats.islands, 1u);
  // b's first keyframe and a's keyframe 80 are the same true pose: after the merge the map
  // puts them together (a's own drift moves both alike).
  auto gap = [&](const std::map<int64_t, SE3d>& poses) {
    const SE3d d = poses.at(a.nodes[80].keyframe_id).inverse() * poses.at(b.nodes[0].keyframe_id);
    return std::pair<double, double>(d.translation().norm(),
                                     Eigen::AngleAxisd(d.linear()).angle() * 180 / M_PI);
  };
  std::map<int64_t, SE3d> before;
  for (const MappedKeyframe& m : mapped) before[m.keyframe_id] = m.T_map_kf;
  const auto [t0_m, r0_deg] = gap(before);
  const auto [t1_m, r1_deg] = gap(Apply(mapped, *r));
  std::printf("same true pose in a and b: %.4f m, %.2f deg apart before, %.4f m, %.2f deg after\n",
              t0_m, r0_deg, t1_m, r1_deg);
  EXPECT_GT(t0_m, 0.10);
  EXPECT_LT(t1_m, 0.03);
  EXPECT_LT(r1_deg, 1.0);
  EXPECT_EQ(closer.Stats().merge_matches, merges.size());
}

// A robot aligned before its merge edges were in leaves the graph in two parts at its next
// solve (loci bench merge behind a backlog with server.queue_capacity 8: b's placement stayed
// 10 cm off until the graph had grown by its share). Merges that come after such a solve make
// the graph due after optimize_min_keyframes, not optimize_growth x its size; once joined, the
// share applies again, and matches within one session do not count as merges.
TEST(LoopCloser, AGraphLeftInPartsIsDueAsSoonAsMergesCome) {
  std::mt19937 rng(5);
  const std::vector<SE3d> truth = SquarePath(SquarePathOptions{});
  const std::vector<SE3d> truth_a(truth.begin(), truth.begin() + 120);
  const std::vector<SE3d> truth_b(truth.begin() + 80, truth.end());
  const SyntheticRobot a =
      MakeSyntheticRobot("a", 1, truth_a, OdometryNoiseOptions{}, truth_a.front(), true, &rng);
  const SyntheticRobot b =
      MakeSyntheticRobot("b", 1001, truth_b, OdometryNoiseOptions{}, truth_b.front(), true, &rng);
  ProximityEdgeOptions near;
  near.every = 2;
  const std::vector<GraphEdge> loops_a = ProximityEdges(a, a, EdgeKind::kLoop, near, &rng);
  const std::vector<GraphEdge> merges = ProximityEdges(a, b, EdgeKind::kMerge, near, &rng);
  ASSERT_GE(loops_a.size(), 6u);
  ASSERT_GE(merges.size(), 6u);
  LoopOptions options = Options();
  options.optimize_growth = 0.2;  // 48 of the 240 keyframes, against optimize_min_keyframes 10
  LoopCloser closer(GraphOptions{}, options);
  Record(a, 1, &closer);
  Record(b, 2, &closer);
  std::vector<MappedKeyframe> mapped = Mapped(a);
  for (const MappedKeyframe& m : Mapped(b)) mapped.push_back(m);
  AddMatches({loops_a.begin(), loops_a.begin() + 3}, true, &closer);
  ASSERT_TRUE(closer.Due());
  auto parts = closer.Optimize(mapped, true);
  ASSERT_TRUE(parts.ok()) << parts.status();
  ASSERT_EQ(parts->stats.islands, 2u);  // b has no edge to a yet

  auto recognise = [&](int n) {
    for (int i = 0; i < n; ++i) closer.NoteRecognised();
  };
  AddMatches({loops_a.begin() + 3, loops_a.begin() + 6}, true, &closer);
  recognise(10);
  EXPECT_FALSE(closer.Due());  // loops within a join nothing: the share applies
  AddMatches({merges.begin(), merges.begin() + 3}, false, &closer);
  EXPECT_TRUE(closer.Due());  // merges: 10 keyframes are enough
  auto joined = closer.Optimize(mapped, true);
  ASSERT_TRUE(joined.ok()) << joined.status();
  EXPECT_EQ(joined->stats.islands, 1u);

  AddMatches({merges.begin() + 3, merges.begin() + 6}, false, &closer);
  recognise(10);
  EXPECT_FALSE(closer.Due());  // joined: the share applies again
  recognise(38);
  EXPECT_TRUE(closer.Due());
}

// An island's graph (keyed by its island row) counts its own matches: they make it due, not the
// shared map's; its solve is counted apart once applied; when the island is aligned its pending
// matches count for the shared graph.
TEST(LoopCloser, AnIslandsGraphIsDueOnItsOwnMatchesAndMovesToTheShared) {
  const Scene s = MakeScene();
  LoopCloser closer(GraphOptions{}, Options());
  constexpr int64_t kIsland = 7;
  for (const KeyframeNode& n : s.robot.nodes) {
    closer.AddKeyframe({n.keyframe_id, kIsland, 0, n.t_ns, n.T_map_kf});
    closer.NoteRecognised(kIsland);
  }
  for (const GraphEdge& e : s.loops) {
    closer.AddMatch({e.from_id, e.to_id, e.T_a_b, 100, 0.01, true}, true, kIsland);
  }
  const int64_t size = static_cast<int64_t>(s.robot.nodes.size());
  EXPECT_TRUE(closer.Due(kIsland, size));
  EXPECT_FALSE(closer.Due(kSharedGraph));
  const std::vector<MappedKeyframe> mapped = Mapped(s.robot);
  auto r = closer.Optimize(mapped, true, kIsland);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_LT(Ate(s.robot, Apply(mapped, *r)), Ate(s.robot, Apply(mapped, GraphResult{})) / 3);
  EXPECT_FALSE(closer.Due(kIsland, size));      // reset by the solve
  EXPECT_EQ(closer.Stats().optimizations, 0u);  // the shared map's figures are untouched
  EXPECT_TRUE(closer.Stats().islands.empty());  // counted once applied
  closer.NoteIslandApplied(kIsland, r->stats);
  ASSERT_EQ(closer.Stats().islands.count(kIsland), 1u);
  EXPECT_EQ(closer.Stats().islands.at(kIsland).optimizations, 1u);
  EXPECT_GT(closer.Stats().islands.at(kIsland).last.loops_accepted, 0u);
  // New island matches pending, then the island is aligned: the shared graph is due.
  for (size_t i = 0; i < 3; ++i) {
    const GraphEdge& e = s.loops[i];
    closer.AddMatch({e.from_id, e.to_id, e.T_a_b, 100, 0.01, true}, true, kIsland);
  }
  for (size_t i = 0; i < s.robot.nodes.size(); ++i) closer.NoteRecognised(kIsland);
  EXPECT_TRUE(closer.Due(kIsland, size));
  closer.MoveDue(kIsland, kSharedGraph);
  EXPECT_FALSE(closer.Due(kIsland, size));
  EXPECT_TRUE(closer.Due(kSharedGraph));
  EXPECT_TRUE(closer.Stats().islands.empty());
}

// The objects' centroids as the map's keyframes saw them (MapServer passes Mapper::SeenCentroids)
// go into the graph as landmarks when graph.landmarks.enabled: without a single loop match they
// cut the drift; off, they are ignored. Views from keyframes the graph does not hold are left out.
TEST(LoopCloser, ObjectCentroidsTheMapRecordsCutTheDriftWhenEnabled) {
  const Scene s = MakeScene();
  std::mt19937 rng(5);
  const auto objects = ObjectsAroundSquare(SquarePathOptions{}, 30, &rng);
  std::vector<CentroidObservation> seen = ObserveCentroids(s.robot, objects, 3.0, 0.03, &rng);
  ASSERT_GT(seen.size(), 100u);
  seen.push_back({999999, 1, Vec3d(0, 0, 1)});  // a keyframe that is not mapped
  const std::vector<MappedKeyframe> mapped = Mapped(s.robot);
  std::map<int64_t, SE3d> before;
  for (const MappedKeyframe& m : mapped) before[m.keyframe_id] = m.T_map_kf;
  GraphOptions with;
  with.landmarks.enabled = true;
  LoopCloser on(with, Options()), off(GraphOptions{}, Options());
  Record(s.robot, 1, &on);
  Record(s.robot, 1, &off);
  auto r_on = on.Optimize(mapped, /*gravity_aligned=*/true, kSharedGraph, seen);
  auto r_off = off.Optimize(mapped, /*gravity_aligned=*/true, kSharedGraph, seen);
  ASSERT_TRUE(r_on.ok()) << r_on.status();
  ASSERT_TRUE(r_off.ok()) << r_off.status();
  const double ate_before = Ate(s.robot, before);
  const double ate_on = Ate(s.robot, Apply(mapped, *r_on));
  std::printf("landmarks %zu (%zu views): ATE %.4f m -> %.4f m\n", r_on->stats.landmarks,
              r_on->stats.centroid_observations, ate_before, ate_on);
  EXPECT_GE(r_on->stats.landmarks, 20u);
  EXPECT_EQ(r_on->stats.centroid_observations, seen.size() - 1);
  EXPECT_LE(ate_on, ate_before / 3);
  EXPECT_EQ(r_off->stats.landmarks, 0u);
  EXPECT_NEAR(Ate(s.robot, Apply(mapped, *r_off)), ate_before, 1e-6);
}

}  // namespace
}  // namespace loci::server

// `loci bench graph [--keyframes 1000,10000] [--wrong-loops 5] [--yaw-drift 0.02]
// [--scale-drift 0.01] [--dof auto|4dof|6dof] [--landmarks] [--no-loops] [--seed 1]
// [--config FILE]`: the keyframe pose graph (server/graph/) on SYNTHETIC trajectories (laps of
// a square with drifting odometry, loop edges from the true poses plus noise, hand-made wrong
// loops): prints the consistency-check and solve times, the loops kept and rejected, and the
// keyframe ATE before and after optimisation. Graph options: the `graph:` section of
// config/server.yaml (or --config).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>

#include "cli/commands.h"
#include "common/config.h"
#include "common/trajectory_eval.h"
#include "server/graph/pose_graph.h"
#include "server/graph/synthetic_graph.h"

namespace loci::cli {
namespace {

using server::EdgeKind;
using server::GraphEdge;
using server::GraphOptions;
using server::PoseGraph;
using server::SyntheticRobot;

struct BenchGraphArgs {
  std::vector<int> keyframes = {1000, 10000};
  int per_lap = 250;
  double side_m = 10;
  int wrong_loops = 5;
  double yaw_drift_deg = 0.02;  // per keyframe
  double scale_drift = 0.01;
  bool landmarks = false;
  bool no_loops = false;
  int objects = 60;
  unsigned seed = 1;
  std::string dof;
  std::string config;
};

struct Scene {
  SyntheticRobot robot;
  std::vector<GraphEdge> loops, wrong;
  std::vector<server::CentroidObservation> centroids;
};

// A wrong loop: keyframe b joined to a keyframe 8-30 steps away from its true match (same or
// earlier lap), with the true match's relative pose, as place recognition fooled by a
// look-alike spot would report it.
std::vector<GraphEdge> WrongLoops(const Scene& s, int count, int per_lap, std::mt19937* rng) {
  const int n = static_cast<int>(s.robot.nodes.size());
  std::uniform_int_distribution<int> pick_b(per_lap + 40, n - 1), offset(8, 30), sign(0, 1);
  std::vector<GraphEdge> wrong;
  while (static_cast<int>(wrong.size()) < count && n > per_lap + 40) {
    const int b = pick_b(*rng), match = b - per_lap;
    const int a = match + (sign(*rng) ? offset(*rng) : -offset(*rng));
    if (a < 0 || a > b - 30) continue;
    GraphEdge e = s.loops.front();
    e.from_id = s.robot.nodes[a].keyframe_id;
    e.to_id = s.robot.nodes[b].keyframe_id;
    e.T_a_b = s.robot.T_map_kf_true[match].inverse() * s.robot.T_map_kf_true[b];
    wrong.push_back(e);
  }
  return wrong;
}

Scene MakeScene(const BenchGraphArgs& a, int keyframes, bool gravity) {
  std::mt19937 rng(a.seed);
  server::SquarePathOptions path;
  path.keyframes = keyframes;
  path.keyframes_per_lap = a.per_lap;
  path.side_m = a.side_m;
  Scene s;
  const auto truth = server::SquarePath(path);
  server::OdometryNoiseOptions noise;
  noise.yaw_bias_rad = a.yaw_drift_deg * M_PI / 180;
  noise.scale_bias = a.scale_drift;
  s.robot = server::MakeSyntheticRobot("robot1", 1, truth, noise, truth.front(), gravity, &rng);
  s.loops = server::ProximityEdges(s.robot, s.robot, EdgeKind::kLoop,
                                   server::ProximityEdgeOptions{}, &rng);
  if (a.no_loops) s.loops.clear();
  if (!s.loops.empty()) s.wrong = WrongLoops(s, a.wrong_loops, a.per_lap, &rng);
  if (a.landmarks) {
    const auto objects = server::ObjectsAroundSquare(path, a.objects, &rng);
    s.centroids = server::ObserveCentroids(s.robot, objects, 3.0, 0.03, &rng);
  }
  return s;
}

StatusOr<PoseGraph> BuildGraph(const Scene& s, const GraphOptions& options, bool wrong) {
  PoseGraph graph(options);
  LOCI_RETURN_IF_ERROR(server::AddRobot(s.robot, &graph));
  LOCI_RETURN_IF_ERROR(server::AddConstraints(s.loops, &graph));
  if (wrong) LOCI_RETURN_IF_ERROR(server::AddConstraints(s.wrong, &graph));
  for (const auto& c : s.centroids) LOCI_RETURN_IF_ERROR(graph.AddCentroidObservation(c));
  return graph;
}

StatusOr<double> Ate(const SyntheticRobot& robot, const PoseGraph& graph) {
  LOCI_ASSIGN_OR_RETURN(const AteResult ate,
                        ComputeAte(server::TrueTrajectory(robot),
                                   server::EstimatedTrajectory(robot, graph)));
  return ate.trans_m.rmse;
}

double MaxShiftM(const PoseGraph& x, const PoseGraph& y) {
  double worst = 0;
  for (size_t i = 0; i < x.nodes().size(); ++i) {
    worst = std::max(worst, (x.nodes()[i].T_map_kf.translation() -
                             y.nodes()[i].T_map_kf.translation()).norm());
  }
  return worst;
}

size_t WrongRejected(const Scene& s, const server::GraphResult& r) {
  size_t n = 0;
  for (const auto& rej : r.rejected) {
    for (const GraphEdge& w : s.wrong) n += (rej.from_id == w.from_id && rej.to_id == w.to_id);
  }
  return n;
}

Status RunOne(const BenchGraphArgs& a, const GraphOptions& options, int keyframes) {
  const Scene s = MakeScene(a, keyframes, options.dof != "6dof");
  LOCI_ASSIGN_OR_RETURN(PoseGraph graph, BuildGraph(s, options, /*wrong=*/true));
  LOCI_ASSIGN_OR_RETURN(const double before, Ate(s.robot, graph));
  LOCI_ASSIGN_OR_RETURN(const server::GraphResult r, graph.Optimize());
  LOCI_ASSIGN_OR_RETURN(const double after, Ate(s.robot, graph));
  LOCI_ASSIGN_OR_RETURN(PoseGraph clean, BuildGraph(s, options, /*wrong=*/false));
  LOCI_RETURN_IF_ERROR(clean.Optimize().status());
  const size_t wrong_rejected = WrongRejected(s, r);
  const auto& st = r.stats;
  const size_t true_kept = s.loops.size() - (st.loops_rejected - wrong_rejected);
  std::printf("| %d | %zu | %zu / %zu | %zu / %zu | %zu | %zu | %.0f | %.0f | %d | %.3g -> %.3g "
              "| %.4f | %.4f | %.4f |\n",
              keyframes, st.odometry_edges, true_kept, s.loops.size(), wrong_rejected,
              s.wrong.size(), st.rejected_after_solve, st.landmarks, st.pcm_ms, st.solve_ms, st.iterations,
              st.initial_cost, st.final_cost, before, after, MaxShiftM(clean, graph));
  std::fflush(stdout);
  return absl::OkStatus();
}

StatusOr<GraphOptions> LoadOptions(const BenchGraphArgs& a) {
  GraphOptions options;
  const std::string path = a.config.empty() ? SourceDir() + "/config/server.yaml" : a.config;
  LOCI_ASSIGN_OR_RETURN(const YAML::Node root, LoadYamlFile(path));
  const ConfigFileScope scope(path);
  LOCI_RETURN_IF_ERROR(options.FromYaml(root["graph"]));
  if (a.landmarks) options.landmarks.enabled = true;
  if (!a.dof.empty()) options.dof = a.dof;
  LOCI_RETURN_IF_ERROR(options.Validate());
  return options;
}

int RunBenchGraph(const BenchGraphArgs& a) {
  const auto options = LoadOptions(a);
  if (!options.ok()) {
    std::cerr << "error: " << options.status().message() << "\n";
    return 1;
  }
  std::printf("SYNTHETIC pose graphs: laps of a %.0f m square, %d keyframes per lap, odometry "
              "noise 3 mm + 0.11 deg per keyframe, drift %.3g deg/keyframe of yaw and %.3g %% of "
              "scale; loop edges (1 cm, 0.3 deg noise) from every 5th keyframe that revisits a "
              "place; %d wrong loops per graph; dof %s; landmarks %s; seed %u\n\n",
              a.side_m, a.per_lap, a.yaw_drift_deg, 100 * a.scale_drift, a.wrong_loops,
              options->dof.c_str(), options->landmarks.enabled ? "on" : "off", a.seed);
  std::printf("| keyframes | odometry edges | true loops kept | wrong loops rejected | rejected after "
              "solve | landmarks | PCM ms | solve ms | iterations | cost | ATE before m | ATE "
              "after m | max shift by wrong loops m |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const int n : a.keyframes) {
    if (const Status s = RunOne(a, *options, n); !s.ok()) {
      std::cerr << "error: " << n << " keyframes: " << s.message() << "\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace

void RegisterBenchGraphCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchGraphArgs>();
  CLI::App* c = bench->add_subcommand(
      "graph", "pose-graph solve time and ATE on synthetic loops with drift (server/graph)");
  c->add_option("--keyframes", args->keyframes, "graph sizes")->delimiter(',')
      ->capture_default_str();
  c->add_option("--per-lap", args->per_lap, "keyframes per lap of the square")
      ->capture_default_str();
  c->add_option("--side", args->side_m, "side of the square, m")->capture_default_str();
  c->add_option("--wrong-loops", args->wrong_loops, "hand-made wrong loops per graph")
      ->capture_default_str();
  c->add_option("--yaw-drift", args->yaw_drift_deg, "odometry yaw drift, deg per keyframe")
      ->capture_default_str();
  c->add_option("--scale-drift", args->scale_drift, "odometry scale error (0.01 = 1 %)")
      ->capture_default_str();
  c->add_flag("--landmarks", args->landmarks, "add object-centroid landmarks (graph.landmarks)");
  c->add_flag("--no-loops", args->no_loops, "no loop edges (odometry, and landmarks if on)");
  c->add_option("--objects", args->objects, "objects around the square (--landmarks)")
      ->capture_default_str();
  c->add_option("--dof", args->dof, "auto|4dof|6dof (default: the config's graph.dof)");
  c->add_option("--seed", args->seed, "random seed")->capture_default_str();
  c->add_option("--config", args->config, "server YAML (default: config/server.yaml)");
  c->callback([args] { ExitCode() = RunBenchGraph(*args); });
}

}  // namespace loci::cli

#include "server/graph/pose_graph.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>

#include "common/time.h"
#include "server/graph/graph_islands.h"
#include "server/graph/graph_math.h"
#include "server/graph/graph_problem.h"
#include "server/graph/odometry_information.h"
#include "server/graph/pcm.h"

namespace loci::server {
namespace {

bool IsConstraint(const GraphEdge& e) { return e.kind != EdgeKind::kOdometry; }

void CountConstraints(const std::vector<GraphEdge>& edges, const std::vector<bool>& keep,
                      GraphResult* r) {
  GraphStats& s = r->stats;
  size_t k = 0;
  for (const GraphEdge& e : edges) {
    if (!IsConstraint(e)) {
      ++s.odometry_edges;
      continue;
    }
    const bool kept = keep[k++];
    if (e.kind == EdgeKind::kLoop) {
      ++s.loop_edges;
      ++(kept ? s.loops_accepted : s.loops_rejected);
    } else {
      ++s.merge_edges;
      ++(kept ? s.merges_accepted : s.merges_rejected);
    }
    if (!kept) r->rejected.push_back({e.kind, e.from_id, e.to_id});
  }
}

// Landmarks seen by at least min_observations keyframes, initialised at the mean of their
// observations moved into the map by the keyframes' current poses.
void AddLandmarks(const std::vector<CentroidObservation>& observations,
                  const std::unordered_map<int64_t, size_t>& index, const LandmarkOptions& o,
                  SolverInput* in) {
  std::unordered_map<int64_t, std::vector<const CentroidObservation*>> by_object;
  for (const CentroidObservation& obs : observations) by_object[obs.object_id].push_back(&obs);
  for (const auto& [object_id, seen] : by_object) {
    if (static_cast<int>(seen.size()) < o.min_observations) continue;
    const size_t landmark = in->landmarks_map.size();
    Vec3d sum = Vec3d::Zero();
    for (const CentroidObservation* obs : seen) {
      const size_t node = index.at(obs->keyframe_id);
      sum += in->T_map_kf[node] * obs->c_kf_m;
      in->observations.push_back({node, landmark, obs->c_kf_m});
    }
    in->landmarks_map.push_back(sum / static_cast<double>(seen.size()));
  }
}

}  // namespace

PoseGraph::PoseGraph(GraphOptions options) : options_(std::move(options)) {}

StatusOr<size_t> PoseGraph::Index(int64_t keyframe_id) const {
  const auto it = index_.find(keyframe_id);
  if (it == index_.end()) {
    return absl::NotFoundError(absl::StrCat("pose graph: no keyframe ", keyframe_id));
  }
  return it->second;
}

Status PoseGraph::AddKeyframe(const KeyframeNode& node) {
  if (index_.count(node.keyframe_id)) {
    return absl::InvalidArgumentError(
        absl::StrCat("pose graph: keyframe ", node.keyframe_id, " added twice"));
  }
  if (!IsFinite(node.T_map_kf) || !node.up_kf.allFinite()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "pose graph: keyframe ", node.keyframe_id, " has a non-finite pose or gravity"));
  }
  index_[node.keyframe_id] = nodes_.size();
  nodes_.push_back(node);
  has_next_.push_back(false);
  has_prev_.push_back(false);
  quality_.emplace_back();
  return absl::OkStatus();
}

Status PoseGraph::AddOdometryEdge(int64_t a_id, int64_t b_id, const SE3d& T_a_b,
                                  const TrackingQuality& quality) {
  LOCI_ASSIGN_OR_RETURN(const size_t a, Index(a_id));
  LOCI_ASSIGN_OR_RETURN(const size_t b, Index(b_id));
  if (nodes_[a].robot != nodes_[b].robot || a >= b || has_next_[a] || has_prev_[b]) {
    return absl::InvalidArgumentError(absl::StrCat(
        "pose graph: odometry edge ", a_id, " -> ", b_id,
        " must join one robot's keyframes in the order added, each once"));
  }
  if (!IsFinite(T_a_b)) return absl::InvalidArgumentError("pose graph: non-finite odometry");
  has_next_[a] = has_prev_[b] = true;
  quality_[b] = quality;
  edges_.push_back({EdgeKind::kOdometry, a_id, b_id, T_a_b,
                    OdometryInformation(T_a_b, quality, options_.odometry)});
  return absl::OkStatus();
}

Status PoseGraph::AddConstraint(EdgeKind kind, int64_t a_id, int64_t b_id, const SE3d& T_a_b,
                                const Information6& info) {
  LOCI_ASSIGN_OR_RETURN(const size_t a, Index(a_id));
  LOCI_ASSIGN_OR_RETURN(const size_t b, Index(b_id));
  const bool same_robot = nodes_[a].robot == nodes_[b].robot;
  if (a == b || (kind == EdgeKind::kLoop) != same_robot) {
    return absl::InvalidArgumentError(absl::StrCat(
        "pose graph: ", EdgeKindName(kind), " edge ", a_id, " -> ", b_id,
        kind == EdgeKind::kLoop ? " must join two keyframes of one robot"
                                : " must join keyframes of two robots"));
  }
  if (!IsFinite(T_a_b) || !info.allFinite() || info.llt().info() != Eigen::Success) {
    return absl::InvalidArgumentError(absl::StrCat(
        "pose graph: edge ", a_id, " -> ", b_id,
        " needs a finite pose and a symmetric positive definite information"));
  }
  edges_.push_back({kind, a_id, b_id, T_a_b, info});
  return absl::OkStatus();
}

Status PoseGraph::AddLoopEdge(int64_t a_id, int64_t b_id, const SE3d& T_a_b,
                              const Information6& info) {
  return AddConstraint(EdgeKind::kLoop, a_id, b_id, T_a_b, info);
}

Status PoseGraph::AddMergeEdge(int64_t a_id, int64_t b_id, const SE3d& T_a_b,
                               const Information6& info) {
  return AddConstraint(EdgeKind::kMerge, a_id, b_id, T_a_b, info);
}

Status PoseGraph::AddCentroidObservation(const CentroidObservation& observation) {
  LOCI_RETURN_IF_ERROR(Index(observation.keyframe_id).status());
  if (!observation.c_kf_m.allFinite()) {
    return absl::InvalidArgumentError("pose graph: non-finite centroid observation");
  }
  observations_.push_back(observation);
  return absl::OkStatus();
}

OdometryChains PoseGraph::Chains() const {
  std::vector<ChainLink> links;
  for (const GraphEdge& e : edges_) {
    if (e.kind != EdgeKind::kOdometry) continue;
    links.push_back({index_.at(e.from_id), index_.at(e.to_id), e.T_a_b, e.information});
  }
  return BuildChains(nodes_.size(), links);
}

std::vector<bool> PoseGraph::GuardConstraints(const OdometryChains& chains) const {
  std::vector<PcmEdge> constraints;
  for (const GraphEdge& e : edges_) {
    if (!IsConstraint(e)) continue;
    constraints.push_back({index_.at(e.from_id), index_.at(e.to_id), e.T_a_b,
                           e.information.inverse(), {e.from_id, e.to_id}});
  }
  if (pcm_cache_ == nullptr || !options_.pcm.enabled) {
    return SelectConsistentEdges(chains, constraints, options_.pcm);
  }
  std::vector<int64_t> node_ids;
  node_ids.reserve(nodes_.size());
  for (const KeyframeNode& n : nodes_) node_ids.push_back(n.keyframe_id);
  pcm_cache_->BeginSolve(chains, node_ids, options_.pcm.chi2_threshold);
  std::vector<bool> keep = SelectConsistentEdges(chains, constraints, options_.pcm, pcm_cache_);
  pcm_cache_->EndSolve();
  return keep;
}

int PoseGraph::ReferenceChain(const OdometryChains& chains) const {
  for (size_t i = 0; i < nodes_.size(); ++i) {
    if (options_.reference_robot.empty() || nodes_[i].robot == options_.reference_robot) {
      return chains.chain_of[i];
    }
  }
  return 0;
}

bool PoseGraph::FourDof() const {
  if (options_.dof == "6dof") return false;
  bool all_measured = true;
  for (const KeyframeNode& n : nodes_) {
    if (!n.gravity_aligned) return false;
    all_measured = all_measured && n.up_kf.squaredNorm() > 0;
  }
  return options_.dof == "4dof" || !(options_.gravity.sigma_rad > 0 && all_measured);
}

SolverInput PoseGraph::BuildSolverInput(const OdometryChains& chains,
                                        const std::vector<bool>& keep, bool four_dof,
                                        const std::vector<SE3d>& start, size_t* islands) const {
  SolverInput in;
  in.four_dof = four_dof;
  in.T_map_kf = start;
  std::vector<ChainJoin> joins;
  size_t k = 0;
  for (const GraphEdge& e : edges_) {
    const size_t a = index_.at(e.from_id), b = index_.at(e.to_id);
    const bool constraint = IsConstraint(e);
    if (constraint && !keep[k++]) continue;
    in.edges.push_back({a, b, e.T_a_b, e.information, constraint});
    if (constraint && chains.chain_of[a] != chains.chain_of[b]) joins.push_back({a, b, e.T_a_b});
  }
  AddLocalMapEdges(chains, &in);
  const Islands found = FindIslands(chains, joins, ReferenceChain(chains));
  PlaceChains(chains, joins, found, four_dof, options_.place_trans_m, options_.place_rot_rad,
              &in.T_map_kf);
  in.anchors = found.anchor_nodes;
  *islands = found.root_chain.size();
  if (options_.landmarks.enabled) AddLandmarks(observations_, index_, options_.landmarks, &in);
  if (!four_dof && options_.gravity.sigma_rad > 0) {
    for (size_t i = 0; i < nodes_.size(); ++i) {
      if (nodes_[i].up_kf.squaredNorm() > 0) in.gravity.emplace_back(i, nodes_[i].up_kf);
    }
  }
  return in;
}

// Anchors every kSpacing keyframes of a chain: a keyframe gets an edge from the last anchor
// before it, an anchor from the anchors kSpacing, 2 kSpacing, 4 kSpacing ... (< the window)
// before it. Any two keyframes of one window are then at most three edges apart; the graph keeps
// its sparsity: edges straight from the keyframes 2, 4, 8 and 16 before each one made the solve
// 8-27 times slower (`loci bench graph`, server/graph/README.md).
void PoseGraph::AddLocalMapEdges(const OdometryChains& chains, SolverInput* in) const {
  constexpr size_t kSpacing = 8;
  const size_t window = static_cast<size_t>(options_.odometry.local_map_keyframes);
  if (window <= 2) return;
  const auto known = [](const TrackingQuality& q) { return q.quality >= 0 || q.inliers >= 0; };
  const auto add = [&](size_t a, size_t b) {
    const SE3d T_a_b = ChainRelative(chains, a, b);
    in->edges.push_back(
        {a, b, T_a_b, OdometryInformation(T_a_b, quality_[b], options_.odometry), false});
  };
  for (const std::vector<size_t>& chain : chains.members) {
    size_t tracked = 0;  // consecutive steps up to p whose quality the client reported
    for (size_t p = 1; p < chain.size(); ++p) {
      tracked = known(quality_[chain[p]]) ? tracked + 1 : 0;
      const size_t from_anchor = p % kSpacing;
      if (from_anchor >= 2 && from_anchor <= tracked && from_anchor < window) {
        add(chain[p - from_anchor], chain[p]);
      }
      if (from_anchor != 0) continue;
      for (size_t k = kSpacing; k < window && k <= tracked; k *= 2) {
        add(chain[p - k], chain[p]);
      }
    }
  }
}

size_t PoseGraph::RejectByResidual(const std::vector<SE3d>& T_map_kf,
                                   std::vector<bool>* keep) const {
  if (!(options_.pcm.residual_chi2 > 0)) return 0;
  size_t k = 0, dropped = 0;
  for (const GraphEdge& e : edges_) {
    if (!IsConstraint(e)) continue;
    const size_t i = k++;
    if (!(*keep)[i]) continue;
    const SE3d T_a_b = T_map_kf[index_.at(e.from_id)].inverse() * T_map_kf[index_.at(e.to_id)];
    const Vec6d r = PoseError6(e.T_a_b.inverse() * T_a_b);
    if (r.dot(e.information * r) > options_.pcm.residual_chi2) {
      (*keep)[i] = false;
      ++dropped;
    }
  }
  return dropped;
}

void PoseGraph::ApplySolution(const SolverOutput& out, GraphResult* result) {
  for (size_t i = 0; i < nodes_.size(); ++i) {
    const SE3d delta = nodes_[i].T_map_kf.inverse() * out.T_map_kf[i];
    nodes_[i].T_map_kf = out.T_map_kf[i];
    if (delta.translation().norm() > options_.moved_trans_m ||
        RotationAngleRad(delta) > options_.moved_rot_rad) {
      result->updates.push_back({nodes_[i].keyframe_id, out.T_map_kf[i]});
    }
  }
  std::sort(result->updates.begin(), result->updates.end(),
            [](const KeyframePoseUpdate& x, const KeyframePoseUpdate& y) {
              return x.keyframe_id < y.keyframe_id;
            });
  GraphStats& s = result->stats;
  s.moved = result->updates.size();
  s.solve_ms = out.solve_ms;
  s.initial_cost = out.initial_cost;
  s.final_cost = out.final_cost;
  s.iterations = out.iterations;
  s.converged = out.converged;
}

StatusOr<GraphResult> PoseGraph::Optimize() {
  GraphResult result;
  result.stats.nodes = nodes_.size();
  if (nodes_.empty()) return result;
  const bool four_dof = FourDof();
  if (options_.dof == "4dof" && !four_dof) {
    return absl::FailedPreconditionError(
        "pose graph: dof 4dof needs every keyframe gravity-aligned");
  }
  const auto pcm_start = std::chrono::steady_clock::now();
  const OdometryChains chains = Chains();
  std::vector<bool> keep = GuardConstraints(chains);
  result.stats.pcm_ms = MsSince(pcm_start);

  std::vector<SE3d> start;
  for (const KeyframeNode& n : nodes_) start.push_back(n.T_map_kf);
  size_t islands = 0;
  SolverInput in = BuildSolverInput(chains, keep, four_dof, start, &islands);
  LOCI_ASSIGN_OR_RETURN(SolverOutput out, SolvePoseGraph(in, options_));
  const size_t dropped = RejectByResidual(out.T_map_kf, &keep);
  if (dropped > 0) {  // solve again without them, from the solution
    const SolverOutput first = out;
    in = BuildSolverInput(chains, keep, four_dof, first.T_map_kf, &islands);
    LOCI_ASSIGN_OR_RETURN(out, SolvePoseGraph(in, options_));
    out.solve_ms += first.solve_ms;
    out.iterations += first.iterations;
    out.initial_cost = first.initial_cost;
  }
  CountConstraints(edges_, keep, &result);
  GraphStats& s = result.stats;
  s.rejected_after_solve = dropped;
  s.islands = islands;
  s.four_dof = four_dof;
  s.landmarks = in.landmarks_map.size();
  s.centroid_observations = in.observations.size();
  s.gravity_priors = in.gravity.size();
  ApplySolution(out, &result);
  return result;
}

}  // namespace loci::server

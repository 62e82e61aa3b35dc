#include "server/graph/pcm.h"

#include <Eigen/Cholesky>
#include <functional>
#include <map>
#include <utility>

#include "server/graph/graph_math.h"
#include "server/graph/max_clique.h"

namespace loci::server {
namespace {

// Cov of a product's right perturbation: factor k's right covariance moved to the product's
// frame through the factors after it, Ad(after^-1).
Covariance6 MoveRight(const SE3d& after, const Covariance6& cov) {
  const Covariance6 ad = Adjoint(after.inverse());
  return ad * cov * ad.transpose();
}

// Orients an edge from the lower chain to the higher one, within one chain from the earlier
// keyframe to the later, so that the odometry segments of a cycle join nearby keyframes.
PcmEdge Oriented(const OdometryChains& chains, const PcmEdge& e) {
  const int ca = chains.chain_of[e.a], cb = chains.chain_of[e.b];
  if (ca < cb || (ca == cb && chains.position[e.a] <= chains.position[e.b])) return e;
  return {e.b, e.a, e.T_a_b.inverse(), InverseCovariance(e.T_a_b, e.cov), e.edge_ids};
}

// What one edge implies about chain B's placement in chain A (see pcm.h).
struct OffsetHypothesis {
  size_t a = 0, b = 0;
  SE3d X = SE3d::Identity();           // T_A_B implied by the edge
  Covariance6 ad_X = Covariance6::Identity();
  Covariance6 edge_cov = Covariance6::Zero();  // the edge's noise, left perturbation in A
};

OffsetHypothesis Hypothesis(const OdometryChains& chains, const PcmEdge& e) {
  OffsetHypothesis h;
  h.a = e.a;
  h.b = e.b;
  const SE3d T_A_b = chains.T_chain_kf[e.a] * e.T_a_b;
  h.X = T_A_b * chains.T_chain_kf[e.b].inverse();
  h.ad_X = Adjoint(h.X);
  const Covariance6 ad = Adjoint(T_A_b);
  h.edge_cov = ad * e.cov * ad.transpose();
  return h;
}

// Covariance (left, chain frame) of the odometry links between two nodes of one chain.
Covariance6 Segment(const OdometryChains& c, size_t i, size_t j) {
  return c.position[j] >= c.position[i] ? Covariance6(c.prefix_cov[j] - c.prefix_cov[i])
                                        : Covariance6(c.prefix_cov[i] - c.prefix_cov[j]);
}

double OffsetChi2(const OdometryChains& chains, const OffsetHypothesis& hi,
                  const OffsetHypothesis& hj) {
  const Vec6d r = PoseError6(hj.X * hi.X.inverse());
  const Covariance6 cov = hi.edge_cov + hj.edge_cov + Segment(chains, hi.a, hj.a) +
                          hi.ad_X * Segment(chains, hi.b, hj.b) * hi.ad_X.transpose();
  return r.dot(cov.ldlt().solve(r));
}

// The inconsistent pairs of a group (max_clique.h), each pair tested once.
std::vector<std::vector<int>> AllConflicts(size_t n,
                                           const std::function<bool(size_t, size_t)>& consistent) {
  std::vector<std::vector<int>> conflicts(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      if (consistent(i, j)) continue;
      conflicts[i].push_back(static_cast<int>(j));
      conflicts[j].push_back(static_cast<int>(i));
    }
  }
  return conflicts;
}

std::vector<int> ConsistentSet(const OdometryChains& chains, const std::vector<PcmEdge>& group,
                               double chi2_threshold, std::pair<int64_t, int64_t> group_key,
                               PcmCache* cache) {
  std::vector<OffsetHypothesis> h;
  h.reserve(group.size());
  for (const PcmEdge& e : group) h.push_back(Hypothesis(chains, e));
  auto consistent = [&](size_t i, size_t j) {
    return OffsetChi2(chains, h[i], h[j]) <= chi2_threshold;
  };
  if (cache == nullptr) return GreedyMaxClique(AllConflicts(group.size(), consistent));
  std::vector<PcmCachedEdge> cached;
  cached.reserve(group.size());
  for (const PcmEdge& e : group) cached.push_back({e.edge_ids, e.T_a_b, e.cov});
  return GreedyMaxClique(cache->GroupConflicts(group_key, cached, consistent));
}

}  // namespace

double PairwiseCycleChi2(const OdometryChains& chains, const PcmEdge& ei, const PcmEdge& ej) {
  const SE3d F1 = ei.T_a_b;
  const SE3d F2 = ChainRelative(chains, ei.b, ej.b);
  const SE3d F3 = ej.T_a_b.inverse();
  const SE3d F4 = ChainRelative(chains, ej.a, ei.a);
  const SE3d C = F1 * F2 * F3 * F4;
  const Covariance6 cov = MoveRight(F2 * F3 * F4, ei.cov) +
                          MoveRight(F3 * F4, ChainRelativeCovariance(chains, ei.b, ej.b)) +
                          MoveRight(F4, InverseCovariance(ej.T_a_b, ej.cov)) +
                          ChainRelativeCovariance(chains, ej.a, ei.a);
  const Vec6d r = PoseError6(C);
  return r.dot(cov.ldlt().solve(r));
}

double PairwiseOffsetChi2(const OdometryChains& chains, const PcmEdge& ei, const PcmEdge& ej) {
  return OffsetChi2(chains, Hypothesis(chains, ei), Hypothesis(chains, ej));
}

std::vector<bool> SelectConsistentEdges(const OdometryChains& chains,
                                        const std::vector<PcmEdge>& edges,
                                        const PcmOptions& options, PcmCache* cache) {
  std::vector<bool> keep(edges.size(), !options.enabled);
  if (!options.enabled) return keep;
  std::map<std::pair<int, int>, std::vector<size_t>> groups;
  for (size_t k = 0; k < edges.size(); ++k) {
    const int ca = chains.chain_of[edges[k].a], cb = chains.chain_of[edges[k].b];
    groups[{std::min(ca, cb), std::max(ca, cb)}].push_back(k);
  }
  for (const auto& [pair, members] : groups) {
    std::vector<PcmEdge> group;
    for (const size_t k : members) group.push_back(Oriented(chains, edges[k]));
    const std::vector<int> set =
        ConsistentSet(chains, group, options.chi2_threshold,
                      cache ? cache->GroupKey(chains, pair.first, pair.second)
                            : std::pair<int64_t, int64_t>{0, 0},
                      cache);
    if (static_cast<int>(set.size()) < options.min_set_size) continue;
    for (const int i : set) keep[members[i]] = true;
  }
  return keep;
}

}  // namespace loci::server

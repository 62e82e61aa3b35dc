// The wrong-loop guard: pairwise consistency maximisation (PCM, Mangelson et al., ICRA 2018)
// over loop and merge edges. Two edges i, j joining the same pair of odometry chains (A, B;
// A = B for loops within one chain) close the cycle
//   C = Z_i * T_bi_bj * Z_j^-1 * T_aj_ai
// with T_bi_bj, T_aj_ai from odometry alone; C is the identity when both are right. Its
// covariance is the edges' and the two odometry segments' (graph_chains.h), transported into
// C's frame; i and j are consistent when PoseError6(C)' cov^-1 PoseError6(C) <= chi2_threshold.
// Correlation between overlapping odometry segments is ignored. Per chain pair the largest
// pairwise consistent set (max_clique.h) is kept, if it has at least min_set_size edges.
//
// The selection evaluates the same test in an equivalent, cheaper form (first order): each edge
// implies the offset of chain B in chain A, X_i = T_A_ai * Z_i * T_B_bi^-1, with a covariance
// (left perturbation in A's frame) computed once per edge; a pair is consistent when
// X_j * X_i^-1 is the identity within the two edges' covariances plus the odometry segments
// ai..aj and bi..bj. PairwiseCycleChi2 is the cycle form, kept as the reference.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "server/graph/graph_chains.h"
#include "server/graph/graph_options.h"
#include "server/graph/pcm_cache.h"

namespace loci::server {

// A loop or merge edge between node indices, with the covariance of T_a_b's right
// perturbation (the inverse of its information).
struct PcmEdge {
  size_t a = 0, b = 0;
  SE3d T_a_b = SE3d::Identity();
  Covariance6 cov = Covariance6::Identity();
  std::pair<int64_t, int64_t> edge_ids{0, 0};  // the graph edge's keyframe ids (PcmCache key)
};

// Squared Mahalanobis distance of the cycle of two edges; both must run from chain A to chain
// B in the same direction (SelectConsistentEdges orients them).
double PairwiseCycleChi2(const OdometryChains& chains, const PcmEdge& ei, const PcmEdge& ej);

// The offset form of PairwiseCycleChi2 (same orientation requirement).
double PairwiseOffsetChi2(const OdometryChains& chains, const PcmEdge& ei, const PcmEdge& ej);

// Per edge, whether it is kept. PCM disabled: every edge is kept. With a cache (BeginSolve
// called with these chains), pairs it knows from earlier solves are not tested again; the
// result is the same.
std::vector<bool> SelectConsistentEdges(const OdometryChains& chains,
                                        const std::vector<PcmEdge>& edges,
                                        const PcmOptions& options, PcmCache* cache = nullptr);

}  // namespace loci::server

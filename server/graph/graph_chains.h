// Odometry chains: the runs of keyframes joined by consecutive odometry edges (one per robot
// and odometry segment). Along a chain, poses are composed from the odometry measurements alone
// and their uncertainty is accumulated, for the pairwise consistency test (pcm.h).
#pragma once

#include <cstddef>
#include <vector>

#include "server/graph/graph_types.h"

namespace loci::server {

// An odometry edge between node indices (a precedes b on its chain).
struct ChainLink {
  size_t a = 0, b = 0;
  SE3d T_a_b = SE3d::Identity();
  Information6 information = Information6::Identity();
};

struct OdometryChains {
  std::vector<int> chain_of;                 // per node
  std::vector<size_t> position;              // per node: index in its chain
  std::vector<std::vector<size_t>> members;  // per chain: node indices in chain order
  std::vector<SE3d> T_chain_kf;              // per node: odometry pose, chain start = identity
  // Per node: covariance of its odometry pose as a left perturbation in the chain frame,
  // P_k = sum over the links before k of Ad(T_chain_b) * Sigma_link * Ad(T_chain_b)^T.
  std::vector<Covariance6> prefix_cov;
};

// `links` must give each node at most one successor and one predecessor (PoseGraph checks).
OdometryChains BuildChains(size_t node_count, const std::vector<ChainLink>& links);

// Odometry-only T_i_j between two nodes of one chain.
SE3d ChainRelative(const OdometryChains& chains, size_t i, size_t j);

// Covariance of ChainRelative(i, j) as a right perturbation (in frame j): the odometry links
// between i and j, transported: Ad(T_chain_j^-1) * |P_j - P_i| * Ad(T_chain_j^-1)^T.
Covariance6 ChainRelativeCovariance(const OdometryChains& chains, size_t i, size_t j);

}  // namespace loci::server

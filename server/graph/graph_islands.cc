#include "server/graph/graph_islands.h"

#include <Eigen/Geometry>
#include <deque>

#include "server/graph/graph_math.h"

namespace loci::server {
namespace {

// Joins per chain, each oriented away from that chain: (other chain, join, reversed).
struct Neighbour {
  int chain = 0;
  const ChainJoin* join = nullptr;
  bool reversed = false;
};

std::vector<std::vector<Neighbour>> Neighbours(const OdometryChains& chains,
                                               const std::vector<ChainJoin>& joins) {
  std::vector<std::vector<Neighbour>> n(chains.members.size());
  for (const ChainJoin& j : joins) {
    const int ca = chains.chain_of[j.a], cb = chains.chain_of[j.b];
    n[ca].push_back({cb, &j, false});
    n[cb].push_back({ca, &j, true});
  }
  return n;
}

struct Correction {
  SE3d fix = SE3d::Identity();  // T_map_new_map_old of the child chain
  double shift_m = 0;           // how far it moves the joined keyframe
};

// The correction moving the child chain's estimate so that the join from the placed chain holds.
Correction CorrectionFor(const Neighbour& nb, const std::vector<SE3d>& T_map_kf, bool four_dof) {
  const ChainJoin& j = *nb.join;
  const size_t placed = nb.reversed ? j.b : j.a, child = nb.reversed ? j.a : j.b;
  const SE3d T_placed_child = nb.reversed ? j.T_a_b.inverse() : j.T_a_b;
  SE3d fix = T_map_kf[placed] * T_placed_child * T_map_kf[child].inverse();
  if (four_dof) {
    const Vec3d t_child = T_map_kf[child].translation();
    const Vec3d t_target = fix * t_child;
    fix.linear() = Eigen::AngleAxisd(YawOf(fix.rotation()), Vec3d::UnitZ()).toRotationMatrix();
    fix.translation() = t_target - fix.linear() * t_child;  // the child's keyframe lands exactly
  }
  return {fix, (fix * T_map_kf[child].translation() - T_map_kf[child].translation()).norm()};
}

}  // namespace

Islands FindIslands(const OdometryChains& chains, const std::vector<ChainJoin>& joins,
                    int reference_chain) {
  const auto neighbours = Neighbours(chains, joins);
  const int n = static_cast<int>(chains.members.size());
  Islands is;
  is.island_of_chain.assign(n, -1);
  std::vector<int> roots = {reference_chain};
  for (int c = 0; c < n; ++c) roots.push_back(c);
  for (const int root : roots) {
    if (root < 0 || root >= n || is.island_of_chain[root] >= 0) continue;
    const int island = static_cast<int>(is.root_chain.size());
    is.root_chain.push_back(root);
    is.anchor_nodes.push_back(chains.members[root].front());
    std::deque<int> queue = {root};
    is.island_of_chain[root] = island;
    while (!queue.empty()) {
      const int c = queue.front();
      queue.pop_front();
      for (const Neighbour& nb : neighbours[c]) {
        if (is.island_of_chain[nb.chain] >= 0) continue;
        is.island_of_chain[nb.chain] = island;
        queue.push_back(nb.chain);
      }
    }
  }
  return is;
}

size_t PlaceChains(const OdometryChains& chains, const std::vector<ChainJoin>& joins,
                   const Islands& islands, bool four_dof, double place_trans_m,
                   double place_rot_rad, std::vector<SE3d>* T_map_kf) {
  const auto neighbours = Neighbours(chains, joins);
  std::vector<bool> visited(chains.members.size(), false);
  size_t moved = 0;
  for (const int root : islands.root_chain) {
    std::deque<int> queue = {root};
    visited[root] = true;
    while (!queue.empty()) {
      const int c = queue.front();
      queue.pop_front();
      for (const Neighbour& nb : neighbours[c]) {
        if (visited[nb.chain]) continue;
        visited[nb.chain] = true;
        queue.push_back(nb.chain);
        const Correction corr = CorrectionFor(nb, *T_map_kf, four_dof);
        if (corr.shift_m <= place_trans_m && RotationAngleRad(corr.fix) <= place_rot_rad) continue;
        for (const size_t k : chains.members[nb.chain]) (*T_map_kf)[k] = corr.fix * (*T_map_kf)[k];
        ++moved;
      }
    }
  }
  return moved;
}

}  // namespace loci::server

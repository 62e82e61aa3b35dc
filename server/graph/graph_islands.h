// Islands: odometry chains joined by kept loop or merge edges. Each island has one anchor
// (held constant in the solve), and a chain joined to its island far from where the joining
// edge says (a robot that started unaligned) is first moved there rigidly, so that the solver
// starts near the answer.
#pragma once

#include <vector>

#include "server/graph/graph_chains.h"

namespace loci::server {

// A kept loop or merge edge between node a of chain_a and node b of chain_b (chain_a != chain_b).
struct ChainJoin {
  size_t a = 0, b = 0;
  SE3d T_a_b = SE3d::Identity();
};

struct Islands {
  std::vector<int> island_of_chain;
  std::vector<int> root_chain;       // per island: the chain its anchor belongs to
  std::vector<size_t> anchor_nodes;  // per island: the first keyframe of the root chain
};

// The reference chain roots its island; other islands are rooted at their lowest chain.
Islands FindIslands(const OdometryChains& chains, const std::vector<ChainJoin>& joins,
                    int reference_chain);

// Walks each island from its root over the joins; a chain reached through a join whose
// measurement disagrees with the current estimates by more than place_trans_m (the joined
// keyframe's shift) or place_rot_rad is moved rigidly (its every node) so the join holds exactly, with the
// correction reduced to yaw and translation when four_dof. Returns the number of chains moved.
size_t PlaceChains(const OdometryChains& chains, const std::vector<ChainJoin>& joins,
                   const Islands& islands, bool four_dof, double place_trans_m,
                   double place_rot_rad, std::vector<SE3d>* T_map_kf);

}  // namespace loci::server

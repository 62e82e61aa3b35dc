// A large clique of an undirected graph, greedily (the heuristic of Pattabiraman et al. 2015
// that PCM uses): from every vertex in order of falling degree, grow a clique by repeatedly
// adding the candidate of highest degree among those adjacent to every member, pruning
// vertices whose degree cannot beat the best clique so far. Exact when the consistent edges
// form one clique and the others are joined to few of them (one or a few wrong loops); in
// general a lower bound of the maximum, which PCM accepts (the alternative is exponential).
#pragma once

#include <vector>

namespace loci::server {

// adjacency[i][j] != 0: i and j are joined (symmetric, diagonal ignored). Returns the vertex
// indices of the clique found, ascending; empty for an empty graph.
std::vector<int> GreedyMaxClique(const std::vector<std::vector<char>>& adjacency);

}  // namespace loci::server

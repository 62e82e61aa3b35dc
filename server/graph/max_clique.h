// A large clique of an undirected graph, greedily (the heuristic of Pattabiraman et al. 2015
// that PCM uses): from every vertex in order of falling degree, grow a clique by repeatedly
// adding the candidate of highest degree among those adjacent to every member, pruning
// vertices whose degree cannot beat the best clique so far. Exact when the consistent edges
// form one clique and the others are joined to few of them (one or a few wrong loops); in
// general a lower bound of the maximum, which PCM accepts (the alternative is exponential).
//
// The graph is given by its complement: the pairs that are NOT joined (PCM's inconsistent
// pairs, which are few), so memory and time follow the vertices and those pairs, not n^2.
#pragma once

#include <vector>

namespace loci::server {

// conflicts[i]: the vertices i is not joined to (symmetric, without i itself, no repeats);
// every other pair is joined. Returns the vertex indices of the clique found, ascending; empty
// for an empty graph.
std::vector<int> GreedyMaxClique(const std::vector<std::vector<int>>& conflicts);

}  // namespace loci::server

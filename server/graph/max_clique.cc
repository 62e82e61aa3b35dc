#include "server/graph/max_clique.h"

#include <algorithm>
#include <numeric>

namespace loci::server {
namespace {

using Adjacency = std::vector<std::vector<char>>;

std::vector<int> Degrees(const Adjacency& adj) {
  const int n = static_cast<int>(adj.size());
  std::vector<int> degree(n, 0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) degree[i] += (i != j && adj[i][j]) ? 1 : 0;
  }
  return degree;
}

// Grows a clique from `seed` among vertices whose degree could still beat `best_size`.
std::vector<int> GrowClique(const Adjacency& adj, const std::vector<int>& degree, int seed,
                            size_t best_size) {
  std::vector<int> clique = {seed};
  std::vector<int> candidates;
  for (int u = 0; u < static_cast<int>(adj.size()); ++u) {
    if (u != seed && adj[seed][u] && static_cast<size_t>(degree[u]) >= best_size) {
      candidates.push_back(u);
    }
  }
  while (!candidates.empty()) {
    const auto pick = std::max_element(candidates.begin(), candidates.end(),
                                       [&](int x, int y) { return degree[x] < degree[y]; });
    const int u = *pick;
    clique.push_back(u);
    std::erase_if(candidates, [&](int v) { return v == u || !adj[u][v]; });
  }
  return clique;
}

}  // namespace

std::vector<int> GreedyMaxClique(const Adjacency& adj) {
  const std::vector<int> degree = Degrees(adj);
  std::vector<int> order(adj.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int x, int y) { return degree[x] > degree[y]; });
  std::vector<int> best;
  for (const int v : order) {
    if (static_cast<size_t>(degree[v]) + 1 <= best.size()) break;  // sorted: none can beat it
    std::vector<int> clique = GrowClique(adj, degree, v, best.size());
    if (clique.size() > best.size()) best = std::move(clique);
  }
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace loci::server

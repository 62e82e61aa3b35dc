#include "server/graph/max_clique.h"

#include <algorithm>
#include <numeric>

namespace loci::server {
namespace {

using Conflicts = std::vector<std::vector<int>>;

// Grows a clique from `seed`: walks the vertices in order of falling degree and adds each one
// still joined to every member, i.e. repeatedly the candidate of highest degree. Vertices
// whose degree cannot beat `best_size` are skipped.
std::vector<int> GrowClique(const Conflicts& conflicts, const std::vector<int>& order,
                            const std::vector<int>& degree, int seed, size_t best_size) {
  std::vector<char> candidate(conflicts.size(), 1);
  auto take = [&](int v) {
    candidate[v] = 0;
    for (const int c : conflicts[v]) candidate[c] = 0;
  };
  std::vector<int> clique = {seed};
  take(seed);
  for (const int u : order) {
    if (static_cast<size_t>(degree[u]) < best_size) break;  // sorted: the rest cannot help
    if (!candidate[u]) continue;
    clique.push_back(u);
    take(u);
  }
  return clique;
}

}  // namespace

std::vector<int> GreedyMaxClique(const Conflicts& conflicts) {
  const int n = static_cast<int>(conflicts.size());
  std::vector<int> degree(n);
  for (int i = 0; i < n; ++i) degree[i] = n - 1 - static_cast<int>(conflicts[i].size());
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int x, int y) { return degree[x] > degree[y]; });
  std::vector<int> best;
  for (const int v : order) {
    if (static_cast<size_t>(degree[v]) + 1 <= best.size()) break;  // sorted: none can beat it
    std::vector<int> clique = GrowClique(conflicts, order, degree, v, best.size());
    if (clique.size() > best.size()) best = std::move(clique);
  }
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace loci::server

#include "server/graph/max_clique.h"

#include <algorithm>
#include <cstdint>
#include <numeric>

namespace loci::server {
namespace {

using Adjacency = std::vector<std::vector<char>>;

// Rows of the adjacency matrix as bit sets: intersecting a candidate set with a vertex's
// neighbours costs n / 64 words.
class BitRows {
 public:
  explicit BitRows(const Adjacency& adj)
      : words_((adj.size() + 63) / 64), rows_(adj.size(), std::vector<uint64_t>(words_, 0)) {
    for (size_t i = 0; i < adj.size(); ++i) {
      for (size_t j = 0; j < adj.size(); ++j) {
        if (i != j && adj[i][j]) rows_[i][j / 64] |= uint64_t{1} << (j % 64);
      }
    }
  }
  const std::vector<uint64_t>& row(size_t i) const { return rows_[i]; }
  static bool Has(const std::vector<uint64_t>& set, size_t j) {
    return (set[j / 64] >> (j % 64)) & 1;
  }
  static void Intersect(std::vector<uint64_t>* set, const std::vector<uint64_t>& other) {
    for (size_t w = 0; w < set->size(); ++w) (*set)[w] &= other[w];
  }

 private:
  size_t words_;
  std::vector<std::vector<uint64_t>> rows_;
};

// Grows a clique from `seed`: walks the vertices in order of falling degree and adds each one
// still adjacent to every member, i.e. repeatedly the candidate of highest degree. Vertices
// whose degree cannot beat `best_size` are skipped.
std::vector<int> GrowClique(const BitRows& bits, const std::vector<int>& order,
                            const std::vector<int>& degree, int seed, size_t best_size) {
  std::vector<int> clique = {seed};
  std::vector<uint64_t> candidates = bits.row(seed);
  for (const int u : order) {
    if (static_cast<size_t>(degree[u]) < best_size) break;  // sorted: the rest cannot help
    if (!BitRows::Has(candidates, u)) continue;
    clique.push_back(u);
    BitRows::Intersect(&candidates, bits.row(u));
  }
  return clique;
}

}  // namespace

std::vector<int> GreedyMaxClique(const Adjacency& adj) {
  std::vector<int> degree(adj.size(), 0);
  for (size_t i = 0; i < adj.size(); ++i) {
    for (size_t j = 0; j < adj.size(); ++j) degree[i] += (i != j && adj[i][j]) ? 1 : 0;
  }
  std::vector<int> order(adj.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int x, int y) { return degree[x] > degree[y]; });
  const BitRows bits(adj);
  std::vector<int> best;
  for (const int v : order) {
    if (static_cast<size_t>(degree[v]) + 1 <= best.size()) break;  // sorted: none can beat it
    std::vector<int> clique = GrowClique(bits, order, degree, v, best.size());
    if (clique.size() > best.size()) best = std::move(clique);
  }
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace loci::server

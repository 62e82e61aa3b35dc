#include "detection/hungarian.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>

namespace loci::detection {
namespace {

// Brute force: best total cost over all injective maps of min(n, m) pairs, skipping forbidden.
double BruteForce(const std::vector<std::vector<double>>& c, double forbidden, int* pairs) {
  const int n = c.size(), m = c[0].size();
  std::vector<int> cols(std::max(n, m));
  std::iota(cols.begin(), cols.end(), 0);
  double best = std::numeric_limits<double>::infinity();
  int best_pairs = -1;
  do {
    // rows 0..n-1 take cols[r] when it is < m; the most pairs wins, then the lowest cost.
    double total = 0.0;
    int count = 0;
    for (int r = 0; r < n; ++r) {
      if (cols[r] < m && c[r][cols[r]] < forbidden) {
        total += c[r][cols[r]];
        ++count;
      }
    }
    if (count > best_pairs || (count == best_pairs && total < best)) {
      best = total;
      best_pairs = count;
    }
  } while (std::next_permutation(cols.begin(), cols.end()));
  *pairs = best_pairs;
  return best;
}

TEST(Hungarian, MatchesBruteForceOnRandomMatrices) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + trial % 5, m = 1 + (trial / 5) % 5;
    std::vector<std::vector<double>> c(n, std::vector<double>(m));
    for (auto& row : c)
      for (double& v : row) v = u(rng) < 0.2 ? 1e9 : u(rng);
    const std::vector<int> a = SolveAssignment(c, 1e9);
    ASSERT_EQ(static_cast<int>(a.size()), n);
    std::vector<char> used(m, false);
    double total = 0.0;
    int pairs = 0;
    for (int r = 0; r < n; ++r) {
      if (a[r] < 0) continue;
      ASSERT_LT(a[r], m);
      ASSERT_FALSE(used[a[r]]) << "column used twice";
      used[a[r]] = true;
      ASSERT_LT(c[r][a[r]], 1e9) << "forbidden pair assigned";
      total += c[r][a[r]];
      ++pairs;
    }
    int best_pairs = 0;
    const double best = BruteForce(c, 1e9, &best_pairs);
    EXPECT_EQ(pairs, best_pairs) << "trial " << trial;
    EXPECT_NEAR(total, best, 1e-9) << "trial " << trial;
  }
}

TEST(Hungarian, KnownSquareExample) {
  // Greedy would take (0,0)=1 and then pay 10; optimum is (0,1) + (1,0) = 2 + 2.
  std::vector<std::vector<double>> c = {{1, 2}, {2, 10}};
  EXPECT_EQ(SolveAssignment(c), (std::vector<int>{1, 0}));
  EXPECT_TRUE(SolveAssignment({}).empty());
  EXPECT_EQ(SolveAssignment({{}, {}}), (std::vector<int>{-1, -1}));
}

}  // namespace
}  // namespace loci::detection

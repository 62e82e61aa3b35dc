#include "detection/hungarian.h"

#include <algorithm>
#include <limits>

namespace loci::detection {
namespace {

// Rows <= columns. a is 1-based internally (classic potentials formulation).
std::vector<int> SolveRowsLeCols(const std::vector<std::vector<double>>& a, int n, int m) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<int> p(m + 1, 0), way(m + 1, 0);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::vector<double> minv(m + 1, inf);
    std::vector<char> used(m + 1, false);
    do {
      used[j0] = true;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j) {
        if (used[j]) continue;
        const double cur = a[i0 - 1][j - 1] - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= m; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<int> row_to_col(n, -1);
  for (int j = 1; j <= m; ++j) {
    if (p[j] != 0) row_to_col[p[j] - 1] = j - 1;
  }
  return row_to_col;
}

}  // namespace

std::vector<int> SolveAssignment(const std::vector<std::vector<double>>& cost,
                                 double forbidden_cost) {
  const int n = static_cast<int>(cost.size());
  if (n == 0) return {};
  const int m = static_cast<int>(cost[0].size());
  std::vector<int> result(n, -1);
  if (m == 0) return result;
  // Forbidden entries get a cost larger than any feasible assignment, so the solver only
  // uses them when it must, and they are removed afterwards.
  double max_feasible = 0.0;
  for (const auto& row : cost) {
    for (double c : row) {
      if (c < forbidden_cost) max_feasible = std::max(max_feasible, std::abs(c));
    }
  }
  const double big = (max_feasible + 1.0) * (std::min(n, m) + 1);
  auto clamp = [&](double c) { return c < forbidden_cost ? c : big; };
  if (n <= m) {
    std::vector<std::vector<double>> a(n, std::vector<double>(m));
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < m; ++c) a[r][c] = clamp(cost[r][c]);
    result = SolveRowsLeCols(a, n, m);
  } else {
    std::vector<std::vector<double>> t(m, std::vector<double>(n));
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < m; ++c) t[c][r] = clamp(cost[r][c]);
    const std::vector<int> col_to_row = SolveRowsLeCols(t, m, n);
    for (int c = 0; c < m; ++c) {
      if (col_to_row[c] >= 0) result[col_to_row[c]] = c;
    }
  }
  for (int r = 0; r < n; ++r) {
    if (result[r] >= 0 && !(cost[r][result[r]] < forbidden_cost)) result[r] = -1;
  }
  return result;
}

}  // namespace loci::detection

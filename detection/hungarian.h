// Minimum-cost assignment (Hungarian / Kuhn-Munkres with potentials, O(n^2 m)) for a
// rectangular cost matrix.
#pragma once

#include <vector>

namespace loci::detection {

// cost[r][c] (all rows the same length). Returns, for each row, its assigned column or -1 when
// there are more rows than columns and the row is left out. Every column is used at most once
// and the total cost of the assignment is minimal. Entries >= forbidden_cost are never
// assigned (such rows/columns get -1 instead).
std::vector<int> SolveAssignment(const std::vector<std::vector<double>>& cost,
                                 double forbidden_cost = 1e9);

}  // namespace loci::detection

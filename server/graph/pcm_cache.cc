#include "server/graph/pcm_cache.h"

#include <algorithm>

namespace loci::server {
namespace {

bool StartsWith(const std::vector<int64_t>& ids, const std::vector<int64_t>& prefix) {
  return prefix.size() <= ids.size() && std::equal(prefix.begin(), prefix.end(), ids.begin());
}

}  // namespace

uint64_t PcmCache::MeasurementHash(const PcmCachedEdge& edge) {
  uint64_t h = 1469598103934665603ULL;  // FNV-1a over the doubles' bytes
  auto add = [&h](const double* v, size_t n) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(v);
    for (size_t i = 0; i < n * sizeof(double); ++i) h = (h ^ bytes[i]) * 1099511628211ULL;
  };
  add(edge.T_a_b.matrix().data(), 16);
  add(edge.cov.data(), 36);
  return h;
}

void PcmCache::BeginSolve(const OdometryChains& chains, const std::vector<int64_t>& node_ids,
                          double chi2_threshold) {
  std::map<int64_t, std::vector<int64_t>> now;
  for (const std::vector<size_t>& members : chains.members) {
    std::vector<int64_t> ids;
    ids.reserve(members.size());
    for (const size_t k : members) ids.push_back(node_ids[k]);
    now[ids.front()] = std::move(ids);
  }
  bool same = chi2_threshold == chi2_threshold_;
  for (const auto& [first, ids] : chains_) {
    auto it = now.find(first);
    if (it != now.end() && !StartsWith(it->second, ids)) same = false;
  }
  if (!same) groups_.clear();
  chains_ = std::move(now);
  node_ids_ = node_ids;
  chi2_threshold_ = chi2_threshold;
  touched_.clear();
}

void PcmCache::Forget(Group* group, Group::iterator it) {
  for (const auto& other : it->second.conflicts) {
    auto o = group->find(other);
    if (o == group->end()) continue;
    auto& list = o->second.conflicts;
    list.erase(std::remove(list.begin(), list.end(), it->first), list.end());
  }
  group->erase(it);
}

std::vector<std::vector<int>> PcmCache::GroupConflicts(
    std::pair<int64_t, int64_t> group_key, const std::vector<PcmCachedEdge>& edges,
    const std::function<bool(size_t, size_t)>& consistent) {
  touched_.insert(group_key);
  Group& group = groups_[group_key];
  std::map<std::pair<int64_t, int64_t>, size_t> index;
  for (size_t i = 0; i < edges.size(); ++i) index[edges[i].ids] = i;
  // Forget what this solve does not have, or has with another measurement.
  std::vector<uint64_t> hash(edges.size());
  for (size_t i = 0; i < edges.size(); ++i) hash[i] = MeasurementHash(edges[i]);
  for (auto it = group.begin(); it != group.end();) {
    auto at = index.find(it->first);
    const bool keep = at != index.end() && hash[at->second] == it->second.measurement;
    auto next = std::next(it);
    if (!keep) Forget(&group, it);
    it = next;
  }
  std::vector<char> known(edges.size(), 0);
  for (size_t i = 0; i < edges.size(); ++i) known[i] = group.count(edges[i].ids) ? 1 : 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    if (!known[i]) group[edges[i].ids] = Entry{hash[i], {}};
  }
  // Test every pair with a new edge in it, once, as consistent(lower, higher): the test is not
  // symmetric, and a full test runs each pair in index order too.
  for (size_t i = 0; i < edges.size(); ++i) {
    if (known[i]) continue;
    for (size_t j = 0; j < edges.size(); ++j) {
      if (j == i || (!known[j] && j < i)) continue;  // a new j < i tested (j, i) already
      ++pairs_tested_;
      if (consistent(std::min(i, j), std::max(i, j))) continue;
      group[edges[i].ids].conflicts.push_back(edges[j].ids);
      group[edges[j].ids].conflicts.push_back(edges[i].ids);
    }
  }
  std::vector<std::vector<int>> conflicts(edges.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    for (const auto& other : group.at(edges[i].ids).conflicts) {
      conflicts[i].push_back(static_cast<int>(index.at(other)));
    }
  }
  return conflicts;
}

void PcmCache::EndSolve() {
  for (auto it = groups_.begin(); it != groups_.end();) {
    it = touched_.count(it->first) ? std::next(it) : groups_.erase(it);
  }
}

}  // namespace loci::server

#include "server/graph/graph_chains.h"

#include "server/graph/graph_math.h"

namespace loci::server {

OdometryChains BuildChains(size_t node_count, const std::vector<ChainLink>& links) {
  constexpr size_t kNone = static_cast<size_t>(-1);
  std::vector<size_t> next_link(node_count, kNone);
  std::vector<bool> has_prev(node_count, false);
  for (size_t l = 0; l < links.size(); ++l) {
    next_link[links[l].a] = l;
    has_prev[links[l].b] = true;
  }
  OdometryChains c;
  c.chain_of.assign(node_count, -1);
  c.position.assign(node_count, 0);
  c.T_chain_kf.assign(node_count, SE3d::Identity());
  c.prefix_cov.assign(node_count, Covariance6::Zero());
  for (size_t start = 0; start < node_count; ++start) {
    if (has_prev[start]) continue;
    const int chain = static_cast<int>(c.members.size());
    c.members.emplace_back();
    for (size_t k = start;;) {
      c.chain_of[k] = chain;
      c.position[k] = c.members.back().size();
      c.members.back().push_back(k);
      const size_t l = next_link[k];
      if (l == kNone) break;
      const ChainLink& link = links[l];
      c.T_chain_kf[link.b] = c.T_chain_kf[k] * link.T_a_b;
      const Covariance6 ad = Adjoint(c.T_chain_kf[link.b]);
      c.prefix_cov[link.b] =
          c.prefix_cov[k] + ad * link.information.inverse() * ad.transpose();
      k = link.b;
    }
  }
  return c;
}

SE3d ChainRelative(const OdometryChains& c, size_t i, size_t j) {
  return c.T_chain_kf[i].inverse() * c.T_chain_kf[j];
}

Covariance6 ChainRelativeCovariance(const OdometryChains& c, size_t i, size_t j) {
  // Prefix sums grow along the chain: the links between are the later node's minus the earlier's.
  const Covariance6 between = c.position[j] >= c.position[i] ? c.prefix_cov[j] - c.prefix_cov[i]
                                                             : c.prefix_cov[i] - c.prefix_cov[j];
  const Covariance6 ad = Adjoint(c.T_chain_kf[j].inverse());
  return ad * between * ad.transpose();
}

}  // namespace loci::server

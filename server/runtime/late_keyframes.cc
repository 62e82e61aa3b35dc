#include "server/runtime/late_keyframes.h"

#include <map>
#include <set>

namespace loci::server {

std::vector<Mapper::KeyframePoseUpdate> LateKeyframeUpdates(
    const std::vector<Mapper::KeyframePoseUpdate>& solved,
    const std::vector<Mapper::KeyframePoseUpdate>& moved,
    const std::vector<Mapper::KeyframePoseUpdate>& now,
    const std::function<std::optional<int64_t>(int64_t)>& session_of) {
  std::map<int64_t, SE3d> moved_by_id;
  for (const Mapper::KeyframePoseUpdate& u : moved) moved_by_id[u.keyframe_id] = u.T_base_kf;
  // Per session: the correction of its newest solved keyframe (none when it did not move).
  std::map<int64_t, std::optional<SE3d>> correction;
  std::set<int64_t> solved_ids;
  for (const Mapper::KeyframePoseUpdate& p : solved) {
    solved_ids.insert(p.keyframe_id);
    const std::optional<int64_t> row = session_of(p.keyframe_id);
    if (!row) continue;
    auto it = moved_by_id.find(p.keyframe_id);
    correction[*row] = it == moved_by_id.end()
                           ? std::nullopt
                           : std::optional<SE3d>(it->second * p.T_base_kf.inverse());
  }
  std::vector<Mapper::KeyframePoseUpdate> out;
  for (const Mapper::KeyframePoseUpdate& p : now) {
    if (solved_ids.count(p.keyframe_id)) continue;
    const std::optional<int64_t> row = session_of(p.keyframe_id);
    if (!row) continue;
    auto c = correction.find(*row);
    if (c == correction.end() || !c->second) continue;
    out.push_back({p.keyframe_id, *c->second * p.T_base_kf});
  }
  return out;
}

}  // namespace loci::server

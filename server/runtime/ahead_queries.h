// An unaligned robot's newest keyframe, recognised ahead of a backlog
// (AlignOptions::query_ahead_backlog). Ingest offers a copy of each unaligned session's newest
// keyframe while keyframes wait; the aligning thread takes one between the keyframes it
// recognises in order, so a robot that streamed a backlog elsewhere is placed within about
// three keyframes of entering the shared map, not after the backlog has been worked through.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <set>

#include "server/map/mapper.h"

namespace loci::server {

class AheadQueries {
 public:
  // Ingest: kf (its images shared, its detections dropped) replaces its session's offer.
  void Offer(const MapperKeyframe& kf);
  // Aligning thread: the offer to query now, if one is due: at once for a session whose last
  // query ahead verified a match (it sees the shared map) or when `none_waiting`, else after
  // kRecognisedPerAhead keyframes recognised in order. The session offered longest ago first.
  std::optional<MapperKeyframe> Take(bool none_waiting);
  // Aligning thread: a keyframe was recognised in order.
  void NoteRecognised() { ++recognised_since_take_; }
  // Aligning thread: a query ahead of the session verified matches without aligning it.
  void NoteOutcome(int64_t session_row, bool matched_unaligned);

 private:
  std::mutex mu_;
  std::map<int64_t, MapperKeyframe> offers_;  // by session row; guarded by mu_
  std::set<int64_t> matched_;                 // guarded by mu_
  int recognised_since_take_ = 0;             // aligning thread only
};

}  // namespace loci::server

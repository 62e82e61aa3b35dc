#include "server/service/replay.h"

#include <spdlog/spdlog.h>

#include <map>

#include "server/service/keyframe_decoder.h"

namespace loci::server {

Status DetectIfNeeded(detection::Detector* detector, MapperKeyframe* kf) {
  if (detector == nullptr || !kf->detections.empty()) return absl::OkStatus();
  LOCI_ASSIGN_OR_RETURN(kf->detections, detector->Detect(kf->bgr, kf->t_ns));
  return absl::OkStatus();
}

StatusOr<int64_t> ReplayStore(MapStore& store, Mapper& mapper, detection::Detector* detector,
                              int64_t after_id, uint64_t* count) {
  LOCI_ASSIGN_OR_RETURN(std::vector<SessionRecord> sessions, store.ListSessions());
  std::map<int64_t, SessionRecord> by_row;
  for (auto& s : sessions) by_row[s.row_id] = std::move(s);
  int64_t last_id = after_id;
  uint64_t n = 0;
  LOCI_RETURN_IF_ERROR(store.ForEachKeyframe(after_id, [&](KeyframeRecord rec) -> Status {
    last_id = rec.id;
    auto it = by_row.find(rec.session_row);
    if (it == by_row.end()) {
      return absl::DataLossError(absl::StrCat("keyframe ", rec.id, " has no session"));
    }
    auto kf = DecodeKeyframe(rec, it->second);
    if (!kf.ok()) {
      // Stored keyframes were validated on ingest; a corrupt row is skipped, not fatal.
      spdlog::warn("replay: keyframe {} skipped: {}", rec.id, kf.status().ToString());
      return absl::OkStatus();
    }
    if (Status s = DetectIfNeeded(detector, &*kf); !s.ok()) {
      spdlog::warn("replay: detector failed on keyframe {}: {}", rec.id, s.ToString());
    }
    mapper.Integrate(*kf);
    ++n;
    return absl::OkStatus();
  }));
  if (count != nullptr) *count = n;
  return last_id;
}

}  // namespace loci::server

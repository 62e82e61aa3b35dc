#include "server/runtime/reindexer.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <map>
#include <set>

#include "server/runtime/keyframe_decoder.h"

namespace loci::server {

void Reindexer::Run() {
  if (!ctx_.aligner) {
    graph_->SetIndexed(true);
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  Counts counts;
  // Keyframes without a stored pose came after their graph's last solve (which stores every
  // keyframe's): with their matches they count towards its next one.
  std::map<int64_t, int64_t> unsolved;  // keyframe id -> graph
  // Pass 1: the keyframes with stored features (no images read).
  std::set<int64_t> need_images;
  KeyframeScan metadata;
  metadata.images = false;
  Status st = ctx_.store.ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        if (ctx_.stopping) return absl::CancelledError("the server is stopping");
        if (ctx_.closer) {
          ctx_.closer->AddKeyframe({rec.id, rec.session_row, rec.segment, rec.t_ns,
                                    rec.T_odom_cam, rec.tracking_inliers,
                                    rec.has_gravity ? rec.gravity_cam : Vec3d::Zero()});
        }
        const int64_t graph = graph_->GraphOf(rec.session_row);
        if (rec.T_base_kf_corrected) {  // in the frame of the map holding it
          ctx_.aligner->SetMappedPoses(graph, {{rec.id, *rec.T_base_kf_corrected}});
        } else if (ctx_.closer && !worker_->LiveKeyframe(rec.id)) {  // live: counts as it comes
          unsolved[rec.id] = graph;
          ctx_.closer->NoteRecognised(graph);
        }
        if (!ToReindex(rec)) return absl::OkStatus();
        if (!FromFeatures(rec, &counts)) need_images.insert(rec.id);
        return absl::OkStatus();
      },
      metadata);
  if (st.ok()) graph_->LoadPlaceMatches(unsolved);
  // Pass 2: the others, from their images (databases written before features were stored, or
  // features of other options).
  if (st.ok() && !need_images.empty()) {
    st = ctx_.store.ForEachKeyframe(
        *need_images.begin() - 1,
        [&](KeyframeRecord rec) -> Status {
          if (ctx_.stopping) return absl::CancelledError("the server is stopping");
          if (need_images.count(rec.id) && ToReindex(rec)) FromImages(rec, &counts);
          return absl::OkStatus();
        },
        KeyframeScan());
  }
  graph_->SetIndexed(st.ok());
  spdlog::info("place recognition: {} stored keyframes re-indexed in {:.1f} s ({} from stored "
               "features, {} without images){}",
               counts.from_features + counts.from_images,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
               counts.from_features, counts.without_images,
               st.ok() ? "" : absl::StrCat("; stopped: ", st.ToString()));
  // Matches found after a graph's last solve are solved now, not when new keyframes come.
  if (st.ok()) graph_->MaybeCloseLoops(align_->waiting() > 0);
}

namespace {

// What the aligner needs of a stored keyframe.
AlignKeyframe AlignInput(const KeyframeRecord& rec) {
  AlignKeyframe in{rec.id, rec.session_row, rec.t_ns, rec.T_odom_cam, std::nullopt};
  if (rec.has_gravity) in.gravity_cam = rec.gravity_cam;
  return in;
}

}  // namespace

bool Reindexer::ToReindex(const KeyframeRecord& rec) {
  if (worker_->LiveKeyframe(rec.id)) return false;  // the aligning thread's
  return !ctx_.aligner->Indexed(rec.id);
}

bool Reindexer::FromFeatures(const KeyframeRecord& rec, Counts* counts) {
  StatusOr<std::optional<place::KeyframeFeatures>> stored = ctx_.features->Get(rec.id);
  if (!stored.ok()) {
    spdlog::warn("re-indexing keyframe {}: {}; extracting them again", rec.id,
                 stored.status().ToString());
    return false;
  }
  if (!*stored) return false;
  worker_->DeclareSession(rec.session_row);
  if (Status st = ctx_.aligner->IndexStored(AlignInput(rec), std::move(**stored)); !st.ok()) {
    spdlog::warn("re-indexing keyframe {}: {}", rec.id, st.ToString());
    return true;  // the images would give the same features
  }
  ++counts->from_features;
  return true;
}

void Reindexer::FromImages(const KeyframeRecord& rec, Counts* counts) {
  if (rec.rgb_jpeg.empty()) {
    ++counts->without_images;  // retention dropped them
    return;
  }
  worker_->DeclareSession(rec.session_row);
  std::optional<SessionRecord> session = ctx_.sessions.ByRow(rec.session_row);
  if (!session) return;
  auto kf = DecodeKeyframe(rec, *session);
  if (!kf.ok()) return;  // validated on ingest; a corrupt row is skipped
  try {
    const Status added = ctx_.aligner->AddKeyframe(AlignInput(rec), kf->bgr, kf->depth_m,
                                                   kf->camera, /*match=*/false).status();
    if (added.ok()) ++counts->from_images;
  } catch (const std::exception& e) {
    spdlog::warn("re-indexing keyframe {}: {}", rec.id, e.what());
  }
}

}  // namespace loci::server

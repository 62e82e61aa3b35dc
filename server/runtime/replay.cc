#include "server/runtime/replay.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>

#include "server/map/product_codec.h"
#include "server/runtime/keyframe_decoder.h"

namespace loci::server {

std::optional<KeyframeProducts> StoredProducts(const KeyframeRecord& rec,
                                              const SessionRecord& session, const Mapper& mapper,
                                              KeyframeDetection* detection, MapStore* store,
                                              LoadReport* report, MapperKeyframe* meta) {
  const std::string fingerprint = mapper.options().ProductsFingerprint();
  if (!rec.products.empty()) {
    auto products = DecodeProducts(rec.products, fingerprint);
    if (products.ok()) {
      *meta = KeyframeMeta(rec, session);
      ++report->from_products;
      return std::move(*products);
    }
    spdlog::warn("load: products of keyframe {} unusable ({}); recomputing them", rec.id,
                 products.status().ToString());
  }
  if (rec.rgb_jpeg.empty()) {
    spdlog::warn("load: keyframe {} skipped: its images were dropped (retention) and it has no "
                 "products for the current options", rec.id);
    return std::nullopt;
  }
  auto kf = DecodeKeyframe(rec, session);
  if (!kf.ok()) {
    // Stored keyframes were validated on ingest; a corrupt row is skipped, not fatal.
    spdlog::warn("load: keyframe {} skipped: {}", rec.id, kf.status().ToString());
    return std::nullopt;
  }
  KeyframeProducts products = BuildAndStoreProducts(mapper, *kf, detection, store);
  *meta = std::move(*kf);
  ++report->from_raw;
  return products;
}

bool LoadKeyframe(const KeyframeRecord& rec, const SessionRecord& session, Mapper& mapper,
                  KeyframeDetection* detection, MapStore* store, LoadReport* report) {
  MapperKeyframe meta;
  const std::optional<KeyframeProducts> products =
      StoredProducts(rec, session, mapper, detection, store, report, &meta);
  if (!products) return false;
  mapper.Integrate(meta, *products);
  return true;
}

namespace {

// Restores the latest checkpoint into `mapper`; the id after which keyframes remain.
int64_t RestoreCheckpoint(MapStore& store, std::unique_ptr<Mapper>* mapper, LoadReport* report) {
  auto checkpoint = store.LatestCheckpoint();
  if (!checkpoint.ok() || !checkpoint->has_value()) {
    if (!checkpoint.ok()) report->checkpoint_skipped = checkpoint.status().ToString();
    return 0;
  }
  const Status st = (*mapper)->LoadCheckpoint((*checkpoint)->data);
  if (!st.ok()) {
    report->checkpoint_skipped = st.ToString();
    *mapper = std::make_unique<Mapper>((*mapper)->options());  // may be half loaded
    return 0;
  }
  report->checkpoint_keyframe_id = (*checkpoint)->last_keyframe_id;
  return (*checkpoint)->last_keyframe_id;
}

// Keyframes of aligned sessions up to the checkpoint's last id that the checkpoint lacks: those
// of a robot aligned just before the server stopped, held back until then while other robots'
// keyframes went on (so their ids lie below the checkpoint's), and not all mapped when the
// checkpoint was written. They are mapped now, in id order per session.
Status MapMissedByCheckpoint(MapStore& store, Mapper& mapper,
                             const std::map<int64_t, SessionRecord>& by_row, int64_t checkpoint_id,
                             KeyframeDetection* detection, MapStore* product_store,
                             LoadReport* report) {
  std::map<int64_t, std::vector<int64_t>> missed;  // session row -> keyframe ids
  KeyframeScan metadata;
  metadata.images = false;
  metadata.last_id = checkpoint_id;
  LOCI_RETURN_IF_ERROR(store.ForEachKeyframe(
      0,
      [&](KeyframeRecord rec) -> Status {
        auto it = by_row.find(rec.session_row);
        if (it != by_row.end() && it->second.aligned && !mapper.HasKeyframe(rec.id)) {
          missed[rec.session_row].push_back(rec.id);
        }
        return absl::OkStatus();
      },
      metadata));
  for (const auto& [row, ids] : missed) {
    KeyframeScan scan;
    scan.products_fingerprint = mapper.options().ProductsFingerprint();
    scan.session_row = row;
    scan.last_id = ids.back();
    const uint64_t before = report->keyframes();
    LOCI_RETURN_IF_ERROR(store.ForEachKeyframe(
        ids.front() - 1,
        [&](KeyframeRecord rec) -> Status {
          if (!std::binary_search(ids.begin(), ids.end(), rec.id)) return absl::OkStatus();
          if (!LoadKeyframe(rec, by_row.at(row), mapper, detection, product_store, report)) {
            ++report->skipped;
          }
          return absl::OkStatus();
        },
        scan));
    report->missed_by_checkpoint += report->keyframes() - before;
    spdlog::warn("load: {} keyframes of session {} were not in the checkpoint (its robot was "
                 "aligned as the server stopped); mapped now", report->keyframes() - before,
                 by_row.at(row).session_id);
  }
  return absl::OkStatus();
}

}  // namespace

KeyframeProducts BuildAndStoreProducts(const Mapper& mapper, MapperKeyframe& kf,
                                       KeyframeDetection* detection, MapStore* store) {
  if (detection != nullptr) {
    if (Status s = detection->Apply(&kf); !s.ok()) {
      spdlog::warn("server detector failed on keyframe {} (its own boxes kept): {}",
                   kf.keyframe_id, s.ToString());
    }
  }
  KeyframeProducts products = mapper.BuildProducts(kf);
  if (store != nullptr) {
    const std::string fingerprint = mapper.options().ProductsFingerprint();
    if (Status s = store->PutProducts(kf.keyframe_id, fingerprint,
                                      EncodeProducts(products, fingerprint));
        !s.ok()) {
      spdlog::warn("products of keyframe {} not stored ({}); they are recomputed on restart",
                   kf.keyframe_id, s.ToString());
    }
  }
  return products;
}

StageTimes MapAndStoreProducts(Mapper& mapper, MapperKeyframe& kf, KeyframeDetection* detection,
                               MapStore* store) {
  return mapper.Integrate(kf, BuildAndStoreProducts(mapper, kf, detection, store));
}

StatusOr<LoadReport> LoadMap(MapStore& store, std::unique_ptr<Mapper>* mapper,
                             KeyframeDetection* detection, const LoadOptions& options) {
  LoadReport report;
  const int64_t after_id = options.use_checkpoint ? RestoreCheckpoint(store, mapper, &report) : 0;
  if (!report.checkpoint_skipped.empty()) {
    spdlog::warn("load: checkpoint not used: {}", report.checkpoint_skipped);
  }
  LOCI_ASSIGN_OR_RETURN(std::vector<SessionRecord> sessions, store.ListSessions());
  std::map<int64_t, SessionRecord> by_row;
  for (auto& s : sessions) by_row[s.row_id] = std::move(s);
  LOCI_ASSIGN_OR_RETURN(const uint64_t total, store.CountKeyframes(std::nullopt));
  report.last_keyframe_id = after_id;
  KeyframeScan scan;
  scan.products_fingerprint = (*mapper)->options().ProductsFingerprint();
  MapStore* product_store = options.store_products ? &store : nullptr;
  uint64_t seen = 0;
  if (options.progress) options.progress(seen, total);
  LOCI_RETURN_IF_ERROR(store.ForEachKeyframe(
      after_id,
      [&](KeyframeRecord rec) -> Status {
        if (options.stop != nullptr && options.stop->load()) {
          return absl::CancelledError("the map load was stopped");
        }
        report.last_keyframe_id = rec.id;
        auto it = by_row.find(rec.session_row);
        if (it == by_row.end()) {
          return absl::DataLossError(absl::StrCat("keyframe ", rec.id, " has no session"));
        }
        if (!it->second.aligned) {
          ++report.held;  // an unaligned robot's: stays out of the map until it is aligned
        } else if (!LoadKeyframe(rec, it->second, **mapper, detection, product_store, &report)) {
          ++report.skipped;
        }
        if (options.progress && ++seen % 200 == 0) options.progress(seen, total);
        return absl::OkStatus();
      },
      scan));
  if (options.progress) options.progress(seen, total);
  if (after_id > 0) {
    LOCI_RETURN_IF_ERROR(MapMissedByCheckpoint(store, **mapper, by_row, after_id, detection,
                                               product_store, &report));
  }
  return report;
}

}  // namespace loci::server

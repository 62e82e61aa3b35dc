// Loads the map from the database (server start, `loci export`, `loci eval objects`,
// `loci reprocess`): the latest checkpoint of the derived map, then every keyframe after it
// from its stored products (server/map/product_codec.h), or from its raw images when it has
// none, whose new products are stored; then the keyframes of aligned sessions older than the
// checkpoint that it lacks (a robot whose held keyframes were entering the map as the server
// stopped). Keyframes are mapped in id order, the order the live server maps them in (held
// keyframes after newer ones, as it does), so a loaded map equals the live one.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "common/status.h"
#include "server/detect/keyframe_detection.h"
#include "server/map/mapper.h"
#include "server/storage/map_store.h"

namespace loci::server {

// Detects the keyframe as `detection` wants (when non-null) and builds a decoded keyframe's products; stores them when
// `store` is non-null (a failure to store is logged: the products are recomputed on the next
// start).
KeyframeProducts BuildAndStoreProducts(const Mapper& mapper, MapperKeyframe& keyframe,
                                       KeyframeDetection* detection, MapStore* store);

// Maps one decoded keyframe from its images (detector when needed, products, fusion) and
// stores its products when `store` is non-null (a failure to store is logged: the products are
// recomputed on the next start). Returns the mapping stage times.
StageTimes MapAndStoreProducts(Mapper& mapper, MapperKeyframe& keyframe,
                               KeyframeDetection* detection, MapStore* store);

struct LoadReport;

// A stored keyframe's products: decoded from the store, or built from its images (and stored
// when `store` is non-null); nullopt when it has to be skipped. `meta` gets the keyframe to
// integrate them with (counted in `report` as from products or from images).
std::optional<KeyframeProducts> StoredProducts(const KeyframeRecord& rec,
                                              const SessionRecord& session, const Mapper& mapper,
                                              KeyframeDetection* detection, MapStore* store,
                                              LoadReport* report, MapperKeyframe* meta);

// Maps one stored keyframe from its products, or from its images (whose new products are
// stored when `store` is non-null); false when it had to be skipped (counted in `report`).
bool LoadKeyframe(const KeyframeRecord& rec, const SessionRecord& session, Mapper& mapper,
                  KeyframeDetection* detection, MapStore* store, LoadReport* report);

struct LoadOptions {
  bool use_checkpoint = true;
  bool store_products = true;  // products made from raw keyframes are written back
  // Called once the checkpoint is restored, every 200 keyframes and at the end with (keyframes
  // mapped after the checkpoint so far, keyframes stored).
  std::function<void(uint64_t, uint64_t)> progress;
  // When set and true, the load stops with CANCELLED (server shutting down while loading).
  const std::atomic<bool>* stop = nullptr;
};

struct LoadReport {
  int64_t checkpoint_keyframe_id = 0;  // 0 = no checkpoint used
  std::string checkpoint_skipped;      // why a stored checkpoint was not used
  uint64_t from_products = 0, from_raw = 0, skipped = 0;
  uint64_t held = 0;  // keyframes of unaligned sessions, left out of the map
  // Keyframes of aligned sessions older than the checkpoint that it lacked (a robot aligned as
  // the server stopped), mapped after it; included in from_products / from_raw.
  uint64_t missed_by_checkpoint = 0;
  int64_t last_keyframe_id = 0;
  uint64_t keyframes() const { return from_products + from_raw; }
};

// Loads the map into `*mapper` (fresh; replaced by a fresh one when a checkpoint turns out to
// be unusable).
StatusOr<LoadReport> LoadMap(MapStore& store, std::unique_ptr<Mapper>* mapper,
                             KeyframeDetection* detection, const LoadOptions& options = {});

}  // namespace loci::server

// What the server's stages share: the options, the store, the sessions, the event fan-out, the
// checkpointer and the maps with their place recognition and pose graph. MapServer owns them and
// outlives every stage; the stages hold this view of them. The shared map and the islands are
// changed only with the map worker's mapping lock held (map_worker.h).
#pragma once

#include <atomic>
#include <memory>

#include "server/align/loop_closer.h"
#include "server/align/robot_aligner.h"
#include "server/detect/keyframe_detection.h"
#include "server/map/mapper.h"
#include "server/runtime/checkpointer.h"
#include "server/runtime/event_fanout.h"
#include "server/runtime/island_maps.h"
#include "server/runtime/server_options.h"
#include "server/runtime/session_cache.h"
#include "server/runtime/store_feature_store.h"
#include "server/storage/map_store.h"

namespace loci::server {

struct MapContext {
  const ServerOptions& options;
  MapStore& store;
  KeyframeDetection* detection;  // server-side detection of keyframes; may be null
  SessionCache& sessions;
  EventFanout& events;
  Checkpointer& checkpointer;
  const std::unique_ptr<Mapper>& mapper;  // the shared map (the load may replace the Mapper)
  RobotAligner* aligner;                  // null when align.enabled is false
  LoopCloser* closer;                     // null without the aligner or align.loops.enabled
  IslandMaps* islands;                    // with the aligner
  StoreFeatureStore* features;            // the aligner's stored place-recognition features
  const std::atomic<bool>& stopping;      // the server is shutting down
};

}  // namespace loci::server

// After a restart: every stored keyframe back into place recognition, from its stored features
// (or its images where it has none), and every stored keyframe's odometry and match into the
// pose graph, on the loading thread once the map is ready; new keyframes are indexed by the
// alignment stage meanwhile. Then the pose graph may solve (GraphStage::SetIndexed).
#pragma once

#include <cstdint>

#include "server/runtime/align_stage.h"
#include "server/runtime/graph_stage.h"
#include "server/runtime/map_context.h"
#include "server/runtime/map_worker.h"

namespace loci::server {

class Reindexer {
 public:
  Reindexer(const MapContext& ctx, MapWorker* worker, GraphStage* graph, AlignStage* align)
      : ctx_(ctx), worker_(worker), graph_(graph), align_(align) {}

  void Run();

 private:
  struct Counts {
    uint64_t from_features = 0, from_images = 0, without_images = 0;
  };
  // Whether the keyframe still has to be indexed.
  bool ToReindex(const KeyframeRecord& rec);
  // false when the keyframe has no usable stored features.
  bool FromFeatures(const KeyframeRecord& rec, Counts* counts);
  void FromImages(const KeyframeRecord& rec, Counts* counts);

  MapContext ctx_;
  MapWorker* worker_;
  GraphStage* graph_;
  AlignStage* align_;
};

}  // namespace loci::server

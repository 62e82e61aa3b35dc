// The query engine: answers English questions and structured relation / object searches over a
// snapshot of the map. Independent of the server: it takes MapObjects (map frame) and returns
// plain structs the server maps to proto (AskResponse, Relation, Object).
//
//   QueryEngine engine(options);
//   AskResult r = engine.Ask("where is the book on the table", MapView{objects, up_map, views});
//
// For many questions on one snapshot, build the index once and share it between threads:
//   auto index = engine.Index(view);          // ~O(n) copy + indexing
//   AskResult r = engine.Ask(text, *index, {now_ns, "robot-a"});
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/map_object.h"
#include "query/geometry.h"
#include "query/map_index.h"
#include "query/parser.h"
#include "query/query_options.h"
#include "query/relations.h"
#include "query/vocabulary.h"

namespace loci::query {

// A snapshot of the map as the caller holds it.
struct MapView {
  std::span<const MapObject> objects;  // map frame
  std::span<const MapObject> removed;  // objects found gone (MapObject::removed_t_ns)
  // Up direction in the map frame; nullopt = estimate (options.up_from_viewpoints) or config.
  std::optional<Vec3d> up_map;
  std::vector<Viewpoint> viewpoints;  // latest camera pose per robot, T_map_cam
  int64_t now_ns = 0;                 // for "last seen 12 s ago"; 0 = no ages in sentences
  std::string viewpoint_robot;        // left/right seen from this robot; "" = most recent pose
};

struct AskContext {
  int64_t now_ns = 0;
  std::string viewpoint_robot;
};

struct AskResult {
  Status status;       // OK, or InvalidArgument with what the parser knows (answer = message)
  std::string intent;  // "where", "what_on", "exists", "check_near", "count", "list", ...
  std::string answer;  // one plain sentence
  std::vector<MapObject> objects;         // matching objects (at most max_result_objects)
  std::vector<RelationResult> relations;  // relations behind the answer, with evidence
  int64_t count = 0;                      // number of matches (complete, not truncated)
  std::optional<bool> yes;                // yes/no questions: the answer
  std::string up_source;                  // "given", "viewpoints" or "config"
};

class QueryEngine {
 public:
  // `options` must be valid (QueryOptions::Validate() empty); invalid values are replaced by
  // the defaults with a logged warning, so the engine never runs with nonsense thresholds.
  explicit QueryEngine(QueryOptions options = QueryOptions::Defaults());

  const QueryOptions& options() const { return options_; }

  // Indexes a snapshot (copies the objects).
  std::shared_ptr<const MapIndex> Index(const MapView& view) const;
  // Indexes a snapshot the caller hands over.
  // `removed`: the objects found gone (MapObject::removed_t_ns), for questions about changes.
  std::shared_ptr<const MapIndex> Index(std::vector<MapObject> objects,
                                        std::optional<Vec3d> up_map = std::nullopt,
                                        std::vector<Viewpoint> viewpoints = {},
                                        std::vector<MapObject> removed = {}) const;

  // Answers `text` (builds a temporary index).
  AskResult Ask(std::string_view text, const MapView& view) const;
  // Answers `text` on a prebuilt index. Thread-safe.
  AskResult Ask(std::string_view text, const MapIndex& index, const AskContext& context) const;
  // Parses only (for tools and tests).
  StatusOr<ParsedQuery> Parse(std::string_view text, const MapIndex& index) const;

  // Every relation of `subject_id` to `anchor_id` (between and nearest excluded), best first;
  // only the holding ones unless `include_failed`. NotFound for unknown ids.
  StatusOr<std::vector<RelationResult>> Relations(const MapIndex& index, int64_t subject_id,
                                                  int64_t anchor_id,
                                                  const std::string& viewpoint_robot = "",
                                                  bool include_failed = false) const;
  // One named relation; for kBetween pass `anchor2_id`.
  StatusOr<RelationResult> Relation(const MapIndex& index, RelationKind kind, int64_t subject_id,
                                    int64_t anchor_id, int64_t anchor2_id = 0,
                                    const std::string& viewpoint_robot = "") const;
  // Structured search; InvalidArgument for an inconsistent filter.
  StatusOr<std::vector<MapObject>> FindObjects(const MapIndex& index,
                                               const ObjectFilter& filter) const;

 private:
  // The viewpoint of `robot` (or the most recent one), null when none is known.
  const ViewpointG* PickViewpoint(const MapIndex& index, const std::string& robot) const;

  QueryOptions options_;
  Vocabulary vocabulary_;
  RelationEvaluator evaluator_;
};

}  // namespace loci::query

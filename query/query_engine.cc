#include "query/query_engine.h"

#include <spdlog/spdlog.h>

#include "query/answer_builder.h"
#include "query/relation_search.h"

namespace loci::query {
namespace {

QueryOptions Checked(QueryOptions options) {
  const std::string err = options.Validate();
  if (err.empty()) return options;
  spdlog::warn("query options invalid ({}); using the defaults", err);
  return QueryOptions::Defaults();
}

}  // namespace

QueryEngine::QueryEngine(QueryOptions options)
    : options_(Checked(std::move(options))),
      vocabulary_(options_),
      evaluator_(options_.relations) {}

std::shared_ptr<const MapIndex> QueryEngine::Index(const MapView& view) const {
  return MapIndex::Build(std::vector<MapObject>(view.objects.begin(), view.objects.end()),
                         view.up_map, view.viewpoints, options_, vocabulary_,
                         std::vector<MapObject>(view.removed.begin(), view.removed.end()));
}

std::shared_ptr<const MapIndex> QueryEngine::Index(std::vector<MapObject> objects,
                                                   std::optional<Vec3d> up_map,
                                                   std::vector<Viewpoint> viewpoints,
                                                   std::vector<MapObject> removed) const {
  return MapIndex::Build(std::move(objects), up_map, std::move(viewpoints), options_, vocabulary_,
                         std::move(removed));
}

AskResult QueryEngine::Ask(std::string_view text, const MapView& view) const {
  const auto index = Index(view);
  return Ask(text, *index, AskContext{view.now_ns, view.viewpoint_robot});
}

StatusOr<ParsedQuery> QueryEngine::Parse(std::string_view text, const MapIndex& index) const {
  return ParseQuestion(text, index.vocabulary());
}

const ViewpointG* QueryEngine::PickViewpoint(const MapIndex& index,
                                             const std::string& robot) const {
  const auto& views = index.viewpoints();
  if (views.empty()) return nullptr;
  if (robot.empty()) return &views.front();
  for (const ViewpointG& v : views) {
    if (v.robot == robot) return &v;
  }
  return nullptr;
}

AskResult QueryEngine::Ask(std::string_view text, const MapIndex& index,
                           const AskContext& context) const {
  AskResult result;
  result.up_source = std::string(UpSourceName(index.up_source()));
  auto parsed = ParseQuestion(text, index.vocabulary());
  if (!parsed.ok()) {
    result.status = parsed.status();
    result.intent = "unknown";
    result.answer = std::string(parsed.status().message());
    return result;
  }
  result.intent = IntentName(*parsed);
  const ViewpointG* viewpoint = PickViewpoint(index, context.viewpoint_robot);
  if (viewpoint == nullptr && !context.viewpoint_robot.empty() && parsed->relation &&
      NeedsViewpoint(parsed->relation->kind)) {
    result.status = absl::NotFoundError("unknown robot");
    result.answer = absl::StrCat("I know no pose of robot \"", context.viewpoint_robot,
                                 "\" to tell left from right.");
    return result;
  }
  RelationSearch search(index, evaluator_, viewpoint);
  AnswerBuilder builder(index, search, options_, context.now_ns);
  builder.Answer(*parsed, &result);
  return result;
}

StatusOr<std::vector<RelationResult>> QueryEngine::Relations(const MapIndex& index,
                                                             int64_t subject_id, int64_t anchor_id,
                                                             const std::string& viewpoint_robot,
                                                             bool include_failed) const {
  const auto s = index.IndexOfId(subject_id);
  const auto a = index.IndexOfId(anchor_id);
  if (!s || !a) {
    return absl::NotFoundError(absl::StrCat("no object #", !s ? subject_id : anchor_id));
  }
  const ViewpointG* viewpoint = PickViewpoint(index, viewpoint_robot);
  RelationSearch search(index, evaluator_, viewpoint);
  std::vector<RelationResult> out;
  for (RelationKind kind :
       {RelationKind::kOn, RelationKind::kUnder, RelationKind::kAbove, RelationKind::kBelow,
        RelationKind::kNear, RelationKind::kNextTo, RelationKind::kInside, RelationKind::kLeftOf,
        RelationKind::kRightOf, RelationKind::kInFrontOf, RelationKind::kBehind}) {
    RelationResult r = evaluator_.Evaluate(kind, index.geom(*s), index.geom(*a), viewpoint, true);
    if (r.holds || include_failed) out.push_back(std::move(r));
  }
  std::stable_sort(out.begin(), out.end(), [](const RelationResult& x, const RelationResult& y) {
    if (x.holds != y.holds) return x.holds;
    return x.confidence > y.confidence;
  });
  return out;
}

StatusOr<RelationResult> QueryEngine::Relation(const MapIndex& index, RelationKind kind,
                                               int64_t subject_id, int64_t anchor_id,
                                               int64_t anchor2_id,
                                               const std::string& viewpoint_robot) const {
  const auto s = index.IndexOfId(subject_id);
  const auto a = index.IndexOfId(anchor_id);
  if (!s || !a) {
    return absl::NotFoundError(absl::StrCat("no object #", !s ? subject_id : anchor_id));
  }
  if (kind == RelationKind::kBetween) {
    const auto b = index.IndexOfId(anchor2_id);
    if (!b) return absl::NotFoundError(absl::StrCat("no object #", anchor2_id));
    return evaluator_.Between(index.geom(*s), index.geom(*a), index.geom(*b), true);
  }
  if (kind == RelationKind::kNearest) {
    return absl::InvalidArgumentError("nearest is a ranking, not a pairwise relation");
  }
  const ViewpointG* viewpoint = PickViewpoint(index, viewpoint_robot);
  RelationSearch search(index, evaluator_, viewpoint);
  return search.Evaluate(kind, *s, *a, true);
}

StatusOr<std::vector<MapObject>> QueryEngine::FindObjects(const MapIndex& index,
                                                          const ObjectFilter& filter) const {
  LOCI_RETURN_IF_ERROR(ValidateFilter(filter));
  std::vector<MapObject> out;
  for (int i : index.Find(filter)) out.push_back(index.object(i));
  return out;
}

}  // namespace loci::query

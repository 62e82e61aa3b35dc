// English question parser: a small hand-written grammar over word tokens, no LLM. Forms:
//   where is the X [REL the Y]          find / locate the X ...        -> kWhere
//   what is REL the Y / what Xs are REL the Y / list all Xs on the Y  -> kWhatRelation
//   is there an X [REL the Y] / do you see an X                       -> kExists
//   is the X REL the Y                                                -> kCheckRelation
//   how many Xs [are there] [REL the Y]                               -> kCount
//   list all objects / what objects are there / list the Xs           -> kList
//   which robot saw the X [last|first] / who saw the X                -> kWhichRobot
//   where is the nearest X [to the Y] / which X is closest to the Y   -> kNearest
//   what changed / moved / is new / is gone [since T] [in the R]      -> kChanges
//   where was the X before / earlier / previously                     -> kWhereBefore
// T: "N seconds|minutes|hours|days|weeks ago", "yesterday", "today", "the last N hours", a
// date "2026-12-05" (UTC); without one, the last day. R: a room name, which scopes nothing
// (the map has no rooms): the whole map.
// REL: on (top of), under/beneath, above/over, below, near/close to/by, next to/beside,
// inside/in/within, between Y and Z, left of / right of (to the, on the ... side of),
// in front of, behind. X, Y: class names, synonyms and plurals (vocabulary.h), "objects" /
// "things" for any class, "#12" or "object 12" for one object.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "query/relations.h"
#include "query/vocabulary.h"

namespace loci::query {

enum class Intent {
  kWhere,
  kWhatRelation,
  kExists,
  kCheckRelation,
  kCount,
  kList,
  kWhichRobot,
  kNearest,
  kChanges,
  kWhereBefore,
};

struct ObjectPhrase {
  std::vector<std::string> classes;  // canonical classes; empty = any class (or `id`)
  bool plural = false;
  std::optional<int64_t> id;  // "#12", "object 12"
  std::string words;          // as written, e.g. "mugs"
  bool any() const { return classes.empty() && !id; }
};

struct RelationClause {
  RelationKind kind = RelationKind::kNear;
  std::optional<ObjectPhrase> anchor;   // absent only for kNearest (nearest to the viewer)
  std::optional<ObjectPhrase> anchor2;  // second anchor of kBetween
};

struct ParsedQuery {
  Intent intent = Intent::kWhere;
  std::optional<ObjectPhrase> target;
  std::optional<RelationClause> relation;
  bool first_seen = false;  // kWhichRobot: "first" instead of "last"
  // kChanges: changes after `since_s` before now, or after the time since_t_ns (ns since the
  // epoch); neither: the last day. Which kinds: all, or only appearances ("what is new"), moves
  // or removals.
  std::optional<double> since_s;
  std::optional<int64_t> since_t_ns;
  enum class ChangeFilter { kAll, kNew, kMoved, kGone };
  ChangeFilter changes = ChangeFilter::kAll;
};

// Intent name as in AskResponse.intent: "where", "what_on", "what_left_of", "exists", "check_on",
// "count", "list", "which_robot", "nearest", "changes", "where_before".
std::string IntentName(const ParsedQuery& query);

// Parses `text`. InvalidArgument naming the unknown word(s), followed by QueryHelp().
StatusOr<ParsedQuery> ParseQuestion(std::string_view text, const Vocabulary& vocabulary);

// What the parser knows: question forms, relations, classes and synonyms.
std::string QueryHelp(const Vocabulary& vocabulary);

// Lower-case word tokens of `text` ("what's" -> "what is"; punctuation dropped; '#', '-', '_'
// and digits kept).
std::vector<std::string> Tokenize(std::string_view text);

}  // namespace loci::query

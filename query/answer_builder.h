// Turns a parsed question into an AskResult on one indexed snapshot: finds the objects, the
// relations behind them and writes the sentence. Internal to QueryEngine (one per Ask).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "query/map_index.h"
#include "query/parser.h"
#include "query/query_engine.h"
#include "query/relation_search.h"

namespace loci::query {

class AnswerBuilder {
 public:
  AnswerBuilder(const MapIndex& index, const RelationSearch& search, const QueryOptions& options,
                int64_t now_ns)
      : index_(index), search_(search), opt_(options), now_ns_(now_ns) {}

  // Fills everything but status, intent and up_source.
  void Answer(const ParsedQuery& query, AskResult* result) const;

 private:
  void Where(const ParsedQuery& q, AskResult* r) const;
  void WhatRelation(const ParsedQuery& q, AskResult* r) const;
  void Exists(const ParsedQuery& q, AskResult* r) const;
  void Count(const ParsedQuery& q, AskResult* r) const;
  void List(const ParsedQuery& q, AskResult* r) const;
  void WhichRobot(const ParsedQuery& q, AskResult* r) const;
  void Nearest(const ParsedQuery& q, AskResult* r) const;
  // answer_changes.cc: what appeared, moved or went since a time; where an object was before.
  void Changes(const ParsedQuery& q, AskResult* r) const;
  void WhereBefore(const ParsedQuery& q, AskResult* r) const;

  // WhatRelation's subjects holding `rel` to an anchor (or an anchor pair for "between"): the
  // most confident relation of each, best first.
  std::vector<RelationResult> SubjectsRelated(const RelationClause& rel,
                                              const std::vector<int>& anchors,
                                              const std::vector<int>& anchors2,
                                              const RelationSearch::Mask* subjects) const;
  // "On the dining table (#3) there are a book (#12) and a cup (#7); ..." for a non-empty
  // `unique`, grouped by anchor; adds the subjects and their relations to r.
  std::string GroupedRelationAnswer(const RelationClause& rel,
                                    const std::vector<RelationResult>& unique, AskResult* r) const;
  // Eligible objects named by `phrase`, sorted by index.
  std::vector<int> Matching(const ObjectPhrase& phrase) const;
  // "book", "object #12", "object" (for sentences about a phrase).
  std::string PhraseNoun(const ObjectPhrase& phrase) const;
  std::string PhrasePlural(const ObjectPhrase& phrase) const;
  // "a book" / "an object" for negative sentences.
  std::string PhraseWithArticle(const ObjectPhrase& phrase) const;
  // Targets holding the relation to an anchor: best relation per target, best first.
  std::vector<RelationResult> Holding(const std::vector<int>& targets,
                                      const RelationClause& relation) const;
  // "on the dining table (#3)", "between the chair (#4) and the couch (#9)".
  std::string RelText(const RelationResult& relation) const;
  // "the book (#12) on the dining table (#3)" or just "the book (#12)" when nothing supports it.
  std::string Describe(int i, const std::optional<RelationResult>& support) const;
  // Why a relation did not hold: where the targets are instead. Appends to r's objects and
  // relations; returns the clause ("I found the book (#12) on the shelf (#5) at ...").
  std::string Instead(const std::vector<int>& targets, const std::vector<int>& anchors,
                      const RelationClause& relation, AskResult* r) const;
  void AddObject(int i, AskResult* r) const;
  // "The book (#12) is on the dining table (#3) at (1.20, 0.40, 0.76) m, last seen 12 s ago by
  // robot-a."
  std::string OneSentence(int i, const std::optional<RelationResult>& relation) const;
  // "the dining table (#3)" when one anchor matches, else "a dining table" (+ " and a chair").
  std::string AnchorText(const RelationClause& relation, const std::vector<int>& anchors) const;
  // Not-found sentence when a phrase matches nothing; true when it wrote one.
  bool NoneOf(const ObjectPhrase& phrase, const std::vector<int>& matches, AskResult* r) const;

  const MapIndex& index_;
  const RelationSearch& search_;
  const QueryOptions& opt_;
  int64_t now_ns_;
};

}  // namespace loci::query

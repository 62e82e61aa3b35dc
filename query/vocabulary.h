// Object vocabulary of the parser: canonical detector classes, synonyms and plurals, matched as
// longest token phrases ("dining tables" -> {dining table}, plural).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "query/query_options.h"

namespace loci::query {

struct ClassMatch {
  std::vector<std::string> classes;  // canonical classes, sorted, non-empty
  bool plural = false;               // the phrase was a plural form
  size_t token_count = 0;            // tokens consumed
  std::string phrase;                // the matched words
};

class Vocabulary {
 public:
  explicit Vocabulary(const QueryOptions& options);

  // Adds a canonical class (e.g. a class met in a map snapshot); no-op when known.
  void AddClass(const std::string& class_name);

  // Longest class phrase starting at tokens[begin] (tokens are lower case words).
  std::optional<ClassMatch> Match(const std::vector<std::string>& tokens, size_t begin) const;

  bool IsClass(const std::string& class_name) const;
  // Canonical classes, sorted.
  const std::vector<std::string>& classes() const { return classes_; }
  // Synonym phrases (singular), sorted.
  std::vector<std::string> SynonymPhrases() const;

  // English plural of the last word of `phrase` ("dining table" -> "dining tables").
  std::string Plural(const std::string& phrase) const;

 private:
  struct Entry {
    std::vector<std::string> classes;
    bool plural = false;
  };
  void AddPhrase(const std::string& phrase, const std::vector<std::string>& classes);
  void AddForm(const std::string& phrase, const std::vector<std::string>& classes, bool plural);

  std::vector<std::string> classes_;
  std::unordered_map<std::string, Entry> phrases_;
  std::unordered_map<std::string, std::string> plural_of_;  // singular word -> irregular plural
  std::vector<std::string> synonym_phrases_;
  size_t max_tokens_ = 1;
};

}  // namespace loci::query

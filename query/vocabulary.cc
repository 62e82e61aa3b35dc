#include "query/vocabulary.h"

#include <algorithm>

namespace loci::query {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool IsVowel(char c) { return c == 'a' || c == 'e' || c == 'i' || c == 'o' || c == 'u'; }

}  // namespace

Vocabulary::Vocabulary(const QueryOptions& options) {
  for (const auto& [plural, singular] : options.irregular_plurals) plural_of_[singular] = plural;
  for (const std::string& c : options.classes) AddClass(c);
  for (const auto& [phrase, classes] : options.synonyms) {
    AddPhrase(phrase, classes);
    synonym_phrases_.push_back(phrase);
  }
}

void Vocabulary::AddClass(const std::string& class_name) {
  if (class_name.empty() || IsClass(class_name)) return;
  classes_.insert(std::upper_bound(classes_.begin(), classes_.end(), class_name), class_name);
  AddPhrase(class_name, {class_name});
}

bool Vocabulary::IsClass(const std::string& class_name) const {
  return std::binary_search(classes_.begin(), classes_.end(), class_name);
}

std::vector<std::string> Vocabulary::SynonymPhrases() const {
  std::vector<std::string> out = synonym_phrases_;
  std::sort(out.begin(), out.end());
  return out;
}

std::string Vocabulary::Plural(const std::string& phrase) const {
  const size_t space = phrase.rfind(' ');
  const std::string head = space == std::string::npos ? "" : phrase.substr(0, space + 1);
  const std::string word = space == std::string::npos ? phrase : phrase.substr(space + 1);
  if (auto it = plural_of_.find(word); it != plural_of_.end()) return head + it->second;
  // Words already plural as detector classes name them ("skis", "scissors") stay as they are.
  if (EndsWith(word, "s") && !EndsWith(word, "ss") && !EndsWith(word, "us")) return phrase;
  if (EndsWith(word, "s") || EndsWith(word, "x") || EndsWith(word, "z") || EndsWith(word, "ch") ||
      EndsWith(word, "sh")) {
    return head + word + "es";
  }
  if (word.size() >= 2 && word.back() == 'y' && !IsVowel(word[word.size() - 2])) {
    return head + word.substr(0, word.size() - 1) + "ies";
  }
  return head + word + "s";
}

void Vocabulary::AddPhrase(const std::string& phrase, const std::vector<std::string>& classes) {
  AddForm(phrase, classes, false);
  const std::string plural = Plural(phrase);
  if (plural != phrase) AddForm(plural, classes, true);
}

void Vocabulary::AddForm(const std::string& phrase, const std::vector<std::string>& classes,
                         bool plural) {
  Entry& e = phrases_[phrase];
  for (const std::string& c : classes) {
    if (std::find(e.classes.begin(), e.classes.end(), c) == e.classes.end()) e.classes.push_back(c);
  }
  std::sort(e.classes.begin(), e.classes.end());
  // A form that is also a singular phrase ("skis") counts as singular.
  e.plural = e.classes.size() == classes.size() ? plural : (e.plural && plural);
  const size_t n = std::count(phrase.begin(), phrase.end(), ' ') + 1;
  max_tokens_ = std::max(max_tokens_, n);
}

std::optional<ClassMatch> Vocabulary::Match(const std::vector<std::string>& tokens,
                                            size_t begin) const {
  if (begin >= tokens.size()) return std::nullopt;
  const size_t longest = std::min(max_tokens_, tokens.size() - begin);
  for (size_t n = longest; n >= 1; --n) {
    std::string phrase = tokens[begin];
    for (size_t k = 1; k < n; ++k) phrase += " " + tokens[begin + k];
    auto it = phrases_.find(phrase);
    if (it == phrases_.end()) continue;
    return ClassMatch{it->second.classes, it->second.plural, n, phrase};
  }
  return std::nullopt;
}

}  // namespace loci::query

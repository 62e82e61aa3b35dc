#include "query/change_parser.h"

#include <algorithm>
#include <cstdio>
#include <ctime>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace loci::query {
namespace {

using Filter = ParsedQuery::ChangeFilter;

// The kind of change a word asks about; nullopt for a word that is not about change.
std::optional<Filter> ChangeWord(const std::string& w) {
  if (w == "changed" || w == "change" || w == "changes" || w == "different") return Filter::kAll;
  if (w == "new" || w == "appeared" || w == "added") return Filter::kNew;
  if (w == "moved" || w == "move" || w == "moves") return Filter::kMoved;
  if (w == "gone" || w == "removed" || w == "missing" || w == "disappeared" || w == "taken") {
    return Filter::kGone;
  }
  return std::nullopt;
}

// Seconds per unit word ("hours" -> 3600); 0 for a word that is no unit.
double UnitSeconds(const std::string& w) {
  static const std::vector<std::pair<std::vector<std::string>, double>> units = {
      {{"s", "sec", "secs", "second", "seconds"}, 1.0},
      {{"min", "mins", "minute", "minutes"}, 60.0},
      {{"h", "hr", "hrs", "hour", "hours"}, 3600.0},
      {{"day", "days"}, 86400.0},
      {{"week", "weeks"}, 7 * 86400.0}};
  for (const auto& [words, seconds] : units) {
    if (std::find(words.begin(), words.end(), w) != words.end()) return seconds;
  }
  return 0;
}

// Where the question's change words are: "what [is|has|have|was|were|got] WORD" or
// "[has|did|is] anything WORD"; the index past WORD, 0 when the question is not of that form.
size_t ChangeFormEnd(const std::vector<std::string>& w, Filter* filter) {
  auto at = [&](size_t i) -> std::string { return i < w.size() ? w[i] : ""; };
  size_t i = 0;
  if (at(0) == "what" || at(0) == "which" || at(0) == "list") {
    i = 1;
    if (at(i) == "objects" || at(i) == "things") ++i;
  } else if ((at(0) == "has" || at(0) == "did" || at(0) == "is") &&
             (at(1) == "anything" || at(1) == "something")) {
    i = 2;
  } else {
    return 0;
  }
  if (at(i) == "is" || at(i) == "has" || at(i) == "have" || at(i) == "was" || at(i) == "were" ||
      at(i) == "got" || at(i) == "are") {
    ++i;
  }
  if (at(i) == "been") ++i;
  const std::optional<Filter> f = ChangeWord(at(i));
  if (!f) return 0;
  *filter = *f;
  return i + 1;
}

Status BadTime(std::string_view text, const Vocabulary& vocabulary) {
  return absl::InvalidArgumentError(absl::StrCat(
      "Since when? \"", std::string(text),
      "\": say \"since 2 hours ago\", \"in the last 3 days\", \"since yesterday\", \"today\" or "
      "\"since 2026-12-05\". ",
      QueryHelp(vocabulary)));
}

// Reads the time words after the change word into q; false when something is left unread.
bool ReadTime(const std::vector<std::string>& w, size_t i, ParsedQuery* q) {
  auto at = [&](size_t k) -> std::string { return k < w.size() ? w[k] : ""; };
  while (i < w.size()) {
    const std::string& word = w[i];
    if (word == "since" || word == "the" || word == "last" || word == "past" || word == "for" ||
        word == "during" || word == "over" || word == "within" || word == "ago" ||
        word == "this") {
      ++i;
      continue;
    }
    double number = 0;
    const std::string& after = at(i + 2);
    if (word == "in" && at(i + 1) == "the" && !after.empty() && after != "last" &&
        after != "past" && UnitSeconds(after) == 0 && !absl::SimpleAtod(after, &number)) {
      i += 3;  // "in the kitchen": a room name; the map has no rooms, so the whole map
      continue;
    }
    if (word == "in") {
      ++i;
      continue;
    }
    if (word == "yesterday" || word == "today") {
      q->since_s = 86400.0;
      ++i;
      continue;
    }
    if (std::optional<int64_t> t_ns = ParseDateNs(word)) {
      q->since_t_ns = *t_ns;
      ++i;
      continue;
    }
    double n = 0;
    if ((word == "a" || word == "an" || word == "one") && UnitSeconds(at(i + 1)) > 0) n = 1;
    if (n > 0 || absl::SimpleAtod(word, &n)) {
      const double unit = UnitSeconds(at(i + 1));
      if (unit <= 0 || !(n >= 0) || n > 1e6) return false;
      q->since_s = n * unit;
      i += 2;
      continue;
    }
    if (UnitSeconds(word) > 0) {  // "in the last hour"
      q->since_s = UnitSeconds(word);
      ++i;
      continue;
    }
    return false;
  }
  return true;
}

}  // namespace

std::optional<int64_t> ParseDateNs(const std::string& word) {
  int y = 0, mo = 0, d = 0;
  char tail = 0;
  if (word.size() != 10 || std::sscanf(word.c_str(), "%4d-%2d-%2d%c", &y, &mo, &d, &tail) != 3) {
    return std::nullopt;
  }
  if (y < 1970 || y > 9999 || mo < 1 || mo > 12 || d < 1 || d > 31) return std::nullopt;
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  return static_cast<int64_t>(timegm(&tm)) * 1'000'000'000;
}

std::optional<StatusOr<ParsedQuery>> ParseChangeQuestion(const std::vector<std::string>& words,
                                                         std::string_view text,
                                                         const Vocabulary& vocabulary) {
  ParsedQuery q;
  q.intent = Intent::kChanges;
  const size_t end = ChangeFormEnd(words, &q.changes);
  if (end == 0) return std::nullopt;
  if (!ReadTime(words, end, &q)) return StatusOr<ParsedQuery>(BadTime(text, vocabulary));
  return StatusOr<ParsedQuery>(std::move(q));
}

}  // namespace loci::query

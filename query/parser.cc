#include "query/parser.h"

#include <algorithm>
#include <cctype>
#include <set>

#include "absl/strings/numbers.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "query/change_parser.h"

namespace loci::query {
namespace {

struct RelPhrase {
  std::vector<std::string> words;
  RelationKind kind;
};

// Relation phrases after filler removal ("to the left of" -> "to left of"), longest first.
const std::vector<RelPhrase>& RelPhrases() {
  static const std::vector<RelPhrase> phrases = [] {
    const std::vector<std::pair<const char*, RelationKind>> table = {
        {"on top of", RelationKind::kOn},
        {"on", RelationKind::kOn},
        {"onto", RelationKind::kOn},
        {"upon", RelationKind::kOn},
        {"atop", RelationKind::kOn},
        {"under", RelationKind::kUnder},
        {"underneath", RelationKind::kUnder},
        {"beneath", RelationKind::kUnder},
        {"above", RelationKind::kAbove},
        {"over", RelationKind::kAbove},
        {"below", RelationKind::kBelow},
        {"near", RelationKind::kNear},
        {"near to", RelationKind::kNear},
        {"close to", RelationKind::kNear},
        {"nearby", RelationKind::kNear},
        {"by", RelationKind::kNear},
        {"around", RelationKind::kNear},
        {"next to", RelationKind::kNextTo},
        {"beside", RelationKind::kNextTo},
        {"besides", RelationKind::kNextTo},
        {"alongside", RelationKind::kNextTo},
        {"adjacent to", RelationKind::kNextTo},
        {"inside", RelationKind::kInside},
        {"inside of", RelationKind::kInside},
        {"in", RelationKind::kInside},
        {"within", RelationKind::kInside},
        {"into", RelationKind::kInside},
        {"between", RelationKind::kBetween},
        {"nearest to", RelationKind::kNearest},
        {"closest to", RelationKind::kNearest},
        {"nearest", RelationKind::kNearest},
        {"closest", RelationKind::kNearest},
        {"left of", RelationKind::kLeftOf},
        {"to left of", RelationKind::kLeftOf},
        {"on left of", RelationKind::kLeftOf},
        {"on left side of", RelationKind::kLeftOf},
        {"to left side of", RelationKind::kLeftOf},
        {"left side of", RelationKind::kLeftOf},
        {"right of", RelationKind::kRightOf},
        {"to right of", RelationKind::kRightOf},
        {"on right of", RelationKind::kRightOf},
        {"on right side of", RelationKind::kRightOf},
        {"to right side of", RelationKind::kRightOf},
        {"right side of", RelationKind::kRightOf},
        {"in front of", RelationKind::kInFrontOf},
        {"behind", RelationKind::kBehind},
        {"in back of", RelationKind::kBehind},
        {"at back of", RelationKind::kBehind},
    };
    std::vector<RelPhrase> out;
    for (const auto& [text, kind] : table) {
      out.push_back({absl::StrSplit(text, ' '), kind});
    }
    std::stable_sort(out.begin(), out.end(), [](const RelPhrase& a, const RelPhrase& b) {
      return a.words.size() > b.words.size();
    });
    return out;
  }();
  return phrases;
}

const std::set<std::string>& Fillers() {
  static const std::set<std::string> words = {
      "the",    "a",       "an",       "any",      "some",     "all",       "every",   "each",
      "please", "is",      "are",      "was",      "were",     "be",        "there",   "does",
      "do",     "did",     "you",      "i",        "we",       "can",       "could",   "see",
      "seen",   "have",    "has",      "had",      "exist",    "exists",    "located", "placed",
      "lying",  "sitting", "standing", "kept",     "stored",   "currently", "now",     "me",
      "tell",   "know",    "saw",      "observed", "spotted",  "detected",  "found",   "noticed",
      "last",   "first",   "latest",   "most",     "recently", "lately",    "many"};
  return words;
}

const std::set<std::string>& AnyWords() {
  static const std::set<std::string> words = {"object",     "objects",  "thing",     "things",
                                              "everything", "anything", "something", "item",
                                              "items",      "stuff"};
  return words;
}

bool IsBeforeWord(const std::string& w) {
  return w == "before" || w == "earlier" || w == "previously" || w == "originally" ||
         w == "formerly" || w == "yesterday";
}

bool IsPlaceWord(const std::string& w) {
  return w == "map" || w == "room" || w == "scene" || w == "house" || w == "world" ||
         w == "environment" || w == "here";
}

std::optional<std::pair<RelationKind, size_t>> MatchRelation(const std::vector<std::string>& t,
                                                             size_t i) {
  for (const RelPhrase& p : RelPhrases()) {
    if (i + p.words.size() > t.size()) continue;
    if (std::equal(p.words.begin(), p.words.end(), t.begin() + i)) {
      return std::make_pair(p.kind, p.words.size());
    }
  }
  return std::nullopt;
}

// "#12" / "object 12": the id and the tokens used.
std::optional<std::pair<int64_t, size_t>> MatchId(const std::vector<std::string>& t, size_t i) {
  int64_t id = 0;
  if (t[i].size() > 1 && t[i][0] == '#' && absl::SimpleAtoi(t[i].substr(1), &id)) {
    return std::make_pair(id, size_t{1});
  }
  if ((t[i] == "object" || t[i] == "id" || t[i] == "number") && i + 1 < t.size()) {
    const std::string& n = t[i + 1];
    const std::string digits = !n.empty() && n[0] == '#' ? n.substr(1) : n;
    if (absl::SimpleAtoi(digits, &id)) return std::make_pair(id, size_t{2});
  }
  return std::nullopt;
}

class TailParser {
 public:
  TailParser(const std::vector<std::string>& tokens, const Vocabulary& vocab, std::string_view text)
      : t_(tokens), vocab_(vocab), text_(text) {}

  Status UnknownWord(const std::string& word) const {
    return absl::InvalidArgumentError(absl::StrCat("I did not understand \"", word, "\" in \"",
                                                   std::string(text_), "\". ", QueryHelp(vocab_)));
  }

  StatusOr<ObjectPhrase> Object(size_t b, size_t e, const char* role) const {
    if (b >= e) {
      return absl::InvalidArgumentError(absl::StrCat(
          "The question \"", std::string(text_), "\" names no ", role, ". ", QueryHelp(vocab_)));
    }
    ObjectPhrase p;
    std::vector<std::string> words(t_.begin() + b, t_.begin() + e);
    p.words = absl::StrJoin(words, " ");
    if (auto id = MatchId(t_, b); id && b + id->second == e) {
      p.id = id->first;
      return p;
    }
    if (e - b == 1 && AnyWords().count(t_[b])) {
      p.plural = t_[b].back() == 's' || t_[b] == "everything" || t_[b] == "stuff";
      return p;
    }
    auto m = vocab_.Match(t_, b);
    if (!m) return UnknownWord(t_[b]);
    size_t used = m->token_count;
    // "book objects", "cups items": a trailing any-word is allowed.
    if (b + used < e && AnyWords().count(t_[b + used])) ++used;
    if (b + used != e) return UnknownWord(t_[b + used]);
    p.classes = m->classes;
    p.plural = m->plural;
    return p;
  }

  struct Tail {
    std::optional<ObjectPhrase> target;
    std::optional<RelationClause> relation;
  };

  StatusOr<Tail> Parse(size_t b, size_t e) const {
    Tail tail;
    bool nearest = false;
    if (b < e && (t_[b] == "nearest" || t_[b] == "closest")) {
      nearest = true;
      ++b;
    }
    // Find the relation phrase, skipping over class phrases ("hot dog" is not "dog").
    size_t p = e;
    std::optional<std::pair<RelationKind, size_t>> rel;
    for (size_t i = b; i < e;) {
      if (auto id = MatchId(t_, i)) {
        i += id->second;
        continue;
      }
      if (auto m = vocab_.Match(t_, i); m && i + m->token_count <= e) {
        i += m->token_count;
        continue;
      }
      if (nearest && (t_[i] == "to" || t_[i] == "from")) {
        rel = std::make_pair(RelationKind::kNearest, size_t{1});
      } else {
        rel = MatchRelation(t_, i);
      }
      if (rel) {
        p = i;
        break;
      }
      ++i;
    }
    if (p > b) {
      LOCI_ASSIGN_OR_RETURN(tail.target, Object(b, p, "object"));
    }
    if (!rel && nearest) tail.relation = RelationClause{RelationKind::kNearest, {}, {}};
    if (!rel) return tail;
    RelationClause clause;
    clause.kind = nearest ? RelationKind::kNearest : rel->first;
    const size_t a = p + rel->second;
    if (clause.kind == RelationKind::kBetween) {
      const auto and_it = std::find(t_.begin() + a, t_.begin() + e, "and");
      const size_t k = and_it - t_.begin();
      if (k >= e) {
        return absl::InvalidArgumentError(
            absl::StrCat("\"between\" needs two objects (\"between the X and the Y\") in \"",
                         std::string(text_), "\"."));
      }
      LOCI_ASSIGN_OR_RETURN(clause.anchor, Object(a, k, "first object after \"between\""));
      LOCI_ASSIGN_OR_RETURN(clause.anchor2, Object(k + 1, e, "second object after \"between\""));
    } else if (a < e || clause.kind != RelationKind::kNearest) {
      LOCI_ASSIGN_OR_RETURN(clause.anchor, Object(a, e, "reference object"));
    }
    tail.relation = clause;
    return tail;
  }

 private:
  const std::vector<std::string>& t_;
  const Vocabulary& vocab_;
  std::string_view text_;
};

}  // namespace

std::vector<std::string> Tokenize(std::string_view text) {
  std::string s;
  s.reserve(text.size() + 8);
  for (size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    // Contractions: 's -> is, 're -> are (the apostrophe may be ASCII or U+2019).
    const bool ascii_apos = c == '\'';
    const bool utf8_apos = c == 0xE2 && i + 2 < text.size() &&
                           static_cast<unsigned char>(text[i + 1]) == 0x80 &&
                           static_cast<unsigned char>(text[i + 2]) == 0x99;
    if (ascii_apos || utf8_apos) {
      const size_t next = i + (utf8_apos ? 3 : 1);
      const char n = next < text.size() ? std::tolower(text[next]) : ' ';
      const bool word_end = next + 1 >= text.size() || !std::isalnum(text[next + 1]);
      if (n == 's' && word_end) {
        s += " is";
        i = next;
      } else if (n == 'r' && next + 1 < text.size() && std::tolower(text[next + 1]) == 'e') {
        s += " are";
        i = next + 1;
      } else {
        i = next - 1;
      }
      continue;
    }
    if (std::isalnum(c) || c == '#' || c == '-' || c == '_') {
      s += static_cast<char>(std::tolower(c));
    } else {
      s += ' ';
    }
  }
  return absl::StrSplit(s, ' ', absl::SkipEmpty());
}

std::string IntentName(const ParsedQuery& q) {
  switch (q.intent) {
    case Intent::kWhere:
      return "where";
    case Intent::kWhatRelation:
      return absl::StrCat(
          "what_", std::string(RelationName(q.relation ? q.relation->kind : RelationKind::kOn)));
    case Intent::kExists:
      return "exists";
    case Intent::kCheckRelation:
      return absl::StrCat(
          "check_", std::string(RelationName(q.relation ? q.relation->kind : RelationKind::kOn)));
    case Intent::kCount:
      return "count";
    case Intent::kList:
      return "list";
    case Intent::kWhichRobot:
      return "which_robot";
    case Intent::kNearest:
      return "nearest";
    case Intent::kChanges:
      return "changes";
    case Intent::kWhereBefore:
      return "where_before";
  }
  return "unknown";
}

std::string QueryHelp(const Vocabulary& vocabulary) {
  return absl::StrCat(
      "Questions I understand: \"where is the X [on the Y]\", \"what is on the Y\", \"is there "
      "an X near the Y\", \"is the X on the Y\", \"how many Xs are there [on the Y]\", \"list all "
      "objects\", \"which robot saw the X last\", \"what is the nearest X to the Y\", \"what "
      "changed since 2 hours ago\", \"what is new\", \"where was the X before\". Relations: "
      "on, under, above, below, near, next to, inside, between ... and ..., nearest, left of, "
      "right of, in front of, behind. Objects: ",
      absl::StrJoin(vocabulary.classes(), ", "), "; also ",
      absl::StrJoin(vocabulary.SynonymPhrases(), ", "),
      ", plurals, \"objects\" for any, \"#12\" for object 12.");
}

namespace {

// The question's form, from its first words.
enum class Form { kCount, kList, kWhichRobot, kWhere, kExists, kCheck, kWhat };

// The form the first words give, and how many of them it takes (*skip).
Form LeadingForm(const std::vector<std::string>& raw, size_t* skip) {
  auto at = [&](size_t i) -> const std::string& {
    static const std::string kEmpty;
    return i < raw.size() ? raw[i] : kEmpty;
  };
  *skip = 0;
  if (at(0) == "how" && at(1) == "many") return *skip = 2, Form::kCount;
  if (at(0) == "list" || at(0) == "enumerate" || at(0) == "name" ||
      (at(0) == "show" && at(1) != "me")) {
    return *skip = 1, Form::kList;
  }
  if ((at(0) == "which" || at(0) == "what") && (at(1) == "robot" || at(1) == "robots")) {
    return *skip = 2, Form::kWhichRobot;
  }
  if (at(0) == "who") return *skip = 1, Form::kWhichRobot;
  if (at(0) == "where" || at(0) == "find" || at(0) == "locate" || at(0) == "show") {
    return *skip = 1, Form::kWhere;
  }
  if ((at(0) == "is" || at(0) == "are") && at(1) == "there") return *skip = 2, Form::kExists;
  if (at(0) == "do" || at(0) == "does" || at(0) == "can" || at(0) == "have" || at(0) == "did") {
    return *skip = 1, Form::kExists;
  }
  if (at(0) == "is" || at(0) == "are") return *skip = 1, Form::kCheck;
  if (at(0) == "what" || at(0) == "which") return *skip = 1, Form::kWhat;
  return Form::kWhere;
}

// The words after the first `skip` without fillers and "in the map"-like place phrases: what
// remains is "[X] [REL Y [and Z]]".
std::vector<std::string> ContentWords(const std::vector<std::string>& raw, size_t skip) {
  std::vector<std::string> t;
  for (size_t i = skip; i < raw.size(); ++i) {
    if (Fillers().count(raw[i])) continue;
    if (IsPlaceWord(raw[i])) {
      if (!t.empty() && (t.back() == "in" || t.back() == "on")) t.pop_back();
      continue;
    }
    t.push_back(raw[i]);
  }
  return t;
}

// q's intent from the form and what the tail named; an error when the form needs a target and
// none was named.
Status SetIntent(Form form, std::string_view text, const Vocabulary& vocabulary, ParsedQuery* q) {
  const bool nearest = q->relation && q->relation->kind == RelationKind::kNearest;
  const bool list = form == Form::kList || form == Form::kWhat;
  if (!q->target && !(list && !nearest)) {
    return absl::InvalidArgumentError(absl::StrCat("Which object? \"", std::string(text),
                                                   "\" names none. ", QueryHelp(vocabulary)));
  }
  switch (form) {
    case Form::kCount:
      q->intent = nearest ? Intent::kNearest : Intent::kCount;
      break;
    case Form::kList:
    case Form::kWhat:
      q->intent = nearest ? Intent::kNearest : q->relation ? Intent::kWhatRelation : Intent::kList;
      break;
    case Form::kWhichRobot:
      q->intent = Intent::kWhichRobot;
      break;
    case Form::kWhere:
      q->intent = nearest ? Intent::kNearest : Intent::kWhere;
      break;
    case Form::kExists:
      q->intent = nearest ? Intent::kNearest : Intent::kExists;
      break;
    case Form::kCheck:
      q->intent = nearest       ? Intent::kNearest
                  : q->relation ? Intent::kCheckRelation
                                : Intent::kExists;
      break;
  }
  return absl::OkStatus();
}

}  // namespace

StatusOr<ParsedQuery> ParseQuestion(std::string_view text, const Vocabulary& vocabulary) {
  const std::vector<std::string> raw = Tokenize(text);
  if (raw.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("The question is empty. ", QueryHelp(vocabulary)));
  }
  if (std::optional<StatusOr<ParsedQuery>> changes = ParseChangeQuestion(raw, text, vocabulary)) {
    return *changes;
  }
  ParsedQuery q;
  size_t skip = 0;
  // "where was the X [before]": where it was before it moved.
  const bool before = raw.size() > 1 && raw[0] == "where" && (raw[1] == "was" || raw[1] == "were") &&
                      std::any_of(raw.begin(), raw.end(), IsBeforeWord);
  if (before) {
    std::vector<std::string> tail;
    for (const std::string& w : raw) {
      if (!IsBeforeWord(w)) tail.push_back(w);
    }
    const std::vector<std::string> t = ContentWords(tail, 1);
    LOCI_ASSIGN_OR_RETURN(TailParser::Tail parsed,
                          TailParser(t, vocabulary, text).Parse(0, t.size()));
    if (!parsed.target || parsed.relation) {
      return absl::InvalidArgumentError(absl::StrCat(
          "Ask \"where was the X before\" with one object. ", QueryHelp(vocabulary)));
    }
    q.intent = Intent::kWhereBefore;
    q.target = parsed.target;
    return q;
  }
  const Form form = LeadingForm(raw, &skip);
  q.first_seen = form == Form::kWhichRobot && std::count(raw.begin(), raw.end(), "first") > 0;
  const std::vector<std::string> t = ContentWords(raw, skip);
  TailParser parser(t, vocabulary, text);
  LOCI_ASSIGN_OR_RETURN(TailParser::Tail tail, parser.Parse(0, t.size()));
  q.target = tail.target;
  q.relation = tail.relation;
  LOCI_RETURN_IF_ERROR(SetIntent(form, text, vocabulary, &q));
  return q;
}

}  // namespace loci::query

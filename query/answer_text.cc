#include "query/answer_text.h"

#include <cctype>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace loci::query {

std::string ObjectRef(const MapObject& o) {
  return absl::StrFormat("the %s (#%d)", o.class_name, o.id);
}

std::string Position(const MapObject& o) {
  return absl::StrFormat("(%.2f, %.2f, %.2f) m", o.centroid_m.x(), o.centroid_m.y(),
                         o.centroid_m.z());
}

std::string Duration(int64_t dt_ns) {
  const double s = dt_ns > 0 ? dt_ns * 1e-9 : 0.0;
  if (s < 120) return absl::StrFormat("%.0f s", s);
  if (s < 7200) return absl::StrFormat("%.0f min", s / 60);
  if (s < 172800) return absl::StrFormat("%.1f h", s / 3600);
  return absl::StrFormat("%.1f days", s / 86400);
}

std::string SeenPhrase(const MapObject& o, int64_t now_ns) {
  std::string out;
  if (o.last_seen_ns > 0) {
    out = now_ns > 0 ? absl::StrCat("last seen ", Duration(now_ns - o.last_seen_ns), " ago")
                     : "last seen";
  }
  const std::string& robot = !o.last_robot.empty() ? o.last_robot
                             : o.robots.empty()    ? std::string()
                                                   : o.robots.back();
  if (!robot.empty()) out = absl::StrCat(out.empty() ? "seen" : out, " by ", robot);
  return out;
}

std::string CountedClass(const Vocabulary& vocabulary, const std::string& class_name, int64_t n) {
  if (n == 1) {
    const char c = class_name.empty() ? 'x' : class_name[0];
    const bool vowel = c == 'a' || c == 'e' || c == 'i' || c == 'o' || c == 'u';
    return absl::StrCat(vowel ? "an " : "a ", class_name);
  }
  return absl::StrCat(n == 0 ? std::string("no") : absl::StrCat(n), " ",
                      vocabulary.Plural(class_name));
}

std::string JoinItems(const std::vector<std::string>& items, size_t max_items) {
  if (items.empty()) return "";
  std::vector<std::string> shown(items.begin(), items.begin() + std::min(items.size(), max_items));
  if (items.size() > shown.size()) {
    shown.push_back(absl::StrCat(items.size() - (shown.size()), " more"));
  }
  if (shown.size() == 1) return shown[0];
  const std::string last = shown.back();
  shown.pop_back();
  return absl::StrCat(absl::StrJoin(shown, ", "), " and ", last);
}

std::string Capitalize(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  return s;
}

std::string Uncapitalize(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(s[0])));
  return s;
}

}  // namespace loci::query

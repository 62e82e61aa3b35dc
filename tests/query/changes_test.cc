// Questions about the map over time: what changed since T, what is new, where an object was
// before it moved; answered from the objects' place histories, the gone ones included.
#include <gtest/gtest.h>

#include "query/change_parser.h"
#include "query/query_engine.h"
#include "test_scene.h"

namespace loci::query {
namespace {

using testing::Box;
using testing::kT0;
using Kind = ObjectPlaceChange::Kind;

constexpr int64_t kHourNs = 3'600'000'000'000;

ObjectPlaceChange Change(Kind kind, int64_t t_ns, const Vec3d& at_m, const Vec3d& from_m) {
  ObjectPlaceChange c;
  c.kind = kind;
  c.t_ns = t_ns;
  c.centroid_m = at_m;
  c.from_m = from_m;
  if (kind != Kind::kAppeared) c.evidence_keyframe_ids = {40, 41, 42};
  return c;
}

// Two days ago a table, a cup and a book appeared; three hours ago the cup moved to the
// shelf's end of the table; an hour ago a chair appeared; 30 min ago the book was found gone.
class ChangesTest : public ::testing::Test {
 protected:
  ChangesTest() {
    const int64_t day1 = kT0 - 48 * kHourNs;
    MapObject table = Box(1, "dining table", {0, 0, 0}, {1.2, 0.8, 0.75});
    table.history = {Change(Kind::kAppeared, day1, table.centroid_m, Vec3d::Zero())};
    MapObject cup = Box(2, "cup", {1.0, 0.5, 0.75}, {1.08, 0.58, 0.85});
    cup.history = {Change(Kind::kAppeared, day1, {0.2, 0.2, 0.8}, Vec3d::Zero()),
                   Change(Kind::kMoved, kT0 - 3 * kHourNs, cup.centroid_m, {0.2, 0.2, 0.8})};
    MapObject chair = Box(3, "chair", {1.5, 0, 0}, {2.0, 0.5, 0.9});
    chair.history = {Change(Kind::kAppeared, kT0 - kHourNs, chair.centroid_m, Vec3d::Zero())};
    MapObject book = Box(4, "book", {0.5, 0.1, 0.75}, {0.7, 0.3, 0.8});
    book.history = {Change(Kind::kAppeared, day1, book.centroid_m, Vec3d::Zero()),
                    Change(Kind::kRemoved, kT0 - kHourNs / 2, book.centroid_m, book.centroid_m)};
    book.removed_t_ns = kT0 - kHourNs / 2;
    index_ = engine_.Index({table, cup, chair}, std::nullopt, {}, {book});
  }
  AskResult Ask(const std::string& text) {
    AskResult r = engine_.Ask(text, *index_, AskContext{kT0, ""});
    EXPECT_TRUE(r.status.ok()) << text << ": " << r.answer;
    return r;
  }
  QueryEngine engine_;
  std::shared_ptr<const MapIndex> index_;
};

std::vector<int64_t> Ids(const AskResult& r) {
  std::vector<int64_t> ids;
  for (const MapObject& o : r.objects) ids.push_back(o.id);
  return ids;
}

TEST_F(ChangesTest, WhatChangedSinceATimeListsEachChangeOnceNewestFirst) {
  const AskResult r = Ask("What changed since 4 hours ago?");
  EXPECT_EQ(r.intent, "changes");
  EXPECT_EQ(r.count, 3);
  EXPECT_EQ(Ids(r), (std::vector<int64_t>{4, 3, 2}));
  EXPECT_NE(r.answer.find("the book (#4) went from (0.60, 0.20, 0.78) m (30 min ago"),
            std::string::npos)
      << r.answer;
  EXPECT_NE(r.answer.find("the cup (#2) moved"), std::string::npos) << r.answer;
  EXPECT_EQ(r.answer.find("table"), std::string::npos) << "it appeared two days ago";
  EXPECT_EQ(Ask("what has changed in the last 2 hours").count, 2);
  EXPECT_EQ(Ask("what changed since 2 days ago").count, 3) << "the day-1 appearances are older";
  EXPECT_EQ(Ask("what changed in the last 3 days").count, 6);
  EXPECT_EQ(Ask("has anything changed in the last 10 minutes").yes, std::optional<bool>(false));
  EXPECT_EQ(Ask("has anything changed in the last 10 minutes").answer,
            "Nothing changed in the last 10 min.");
}

TEST_F(ChangesTest, WhatIsNewMovedOrGoneFiltersTheKind) {
  const AskResult fresh = Ask("what is new in the kitchen?");
  EXPECT_EQ(Ids(fresh), std::vector<int64_t>{3});  // the last day by default
  EXPECT_EQ(Ids(Ask("what moved today")), std::vector<int64_t>{2});
  EXPECT_EQ(Ids(Ask("what is gone")), std::vector<int64_t>{4});
  EXPECT_EQ(Ids(Ask("what is missing since yesterday")), std::vector<int64_t>{4});
}

TEST_F(ChangesTest, WhereWasItBefore) {
  const AskResult cup = Ask("where was the cup before?");
  EXPECT_EQ(cup.intent, "where_before");
  EXPECT_EQ(cup.answer,
            "The cup (#2) was at (0.20, 0.20, 0.80) m until 3.0 h ago; it is now at (1.04, 0.54, "
            "0.80) m.");
  const AskResult book = Ask("where was the book earlier");
  EXPECT_NE(book.answer.find("was at (0.60, 0.20, 0.78) m until 30 min ago; its place was then "
                             "seen empty"),
            std::string::npos)
      << book.answer;
  const AskResult chair = Ask("where was the chair before");
  EXPECT_EQ(chair.yes, std::optional<bool>(false));
  EXPECT_NE(chair.answer.find("The chair (#3) has not moved since it appeared; it is at"), std::string::npos) << chair.answer;
  EXPECT_EQ(Ask("where was the laptop before").yes, std::optional<bool>(false));
  EXPECT_EQ(Ask("where was the cup last seen").intent, "where") << "no 'before': where it is";
}

TEST_F(ChangesTest, TimesThatCannotBeReadAreErrors) {
  for (const char* bad : {"what changed since banana", "what changed since 3 bananas ago",
                          "what changed since -2 hours ago", "what changed since 2026-13-40"}) {
    const AskResult r = engine_.Ask(bad, *index_, AskContext{kT0, ""});
    EXPECT_EQ(r.status.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(r.answer.find("Since when?"), std::string::npos) << bad << ": " << r.answer;
  }
}

TEST(ChangeParser, DatesAreUtcMidnight) {
  EXPECT_EQ(ParseDateNs("1970-01-02"), std::optional<int64_t>(86'400'000'000'000));
  EXPECT_EQ(ParseDateNs("2026-12-05"), std::optional<int64_t>(1'796'428'800'000'000'000));
  EXPECT_FALSE(ParseDateNs("2026-12-5x").has_value());
  EXPECT_FALSE(ParseDateNs("12").has_value());
}

}  // namespace
}  // namespace loci::query

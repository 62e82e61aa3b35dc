// QueryEngine::Ask on the hand-built office: answers, sentences, negatives, structured APIs.
#include "query/query_engine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <thread>

#include "test_scene.h"

namespace loci::query {
namespace {

using testing::kT0;

std::vector<int64_t> Ids(const AskResult& r) {
  std::vector<int64_t> ids;
  for (const MapObject& o : r.objects) ids.push_back(o.id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

class QueryEngineTest : public ::testing::Test {
 protected:
  QueryEngineTest() : objects_(testing::Office()) {
    view_.objects = objects_;
    view_.viewpoints = {{"robot-a", testing::OfficeViewpoint(), kT0}};
    view_.now_ns = kT0;
    index_ = engine_.Index(view_);
  }
  AskResult Ask(const std::string& text) {
    AskResult r = engine_.Ask(text, *index_, AskContext{kT0, ""});
    EXPECT_TRUE(r.status.ok()) << text << ": " << r.answer;
    return r;
  }
  QueryEngine engine_;
  std::vector<MapObject> objects_;
  MapView view_;
  std::shared_ptr<const MapIndex> index_;
};

TEST_F(QueryEngineTest, WhereIsTheBookOnTheTable) {
  const AskResult r = Ask("Where is the book on the table?");
  EXPECT_EQ(r.intent, "where");
  EXPECT_EQ(Ids(r), std::vector<int64_t>{2});
  EXPECT_EQ(r.count, 1);
  ASSERT_EQ(r.relations.size(), 1u);
  EXPECT_EQ(RelationName(r.relations[0].kind), "on");
  EXPECT_EQ(r.relations[0].anchor_id, 1);
  EXPECT_FALSE(r.relations[0].evidence.empty());
  EXPECT_EQ(r.answer,
            "The book (#2) is on the dining table (#1) at (0.31, 0.28, 0.77) m, last seen 5 s "
            "ago by robot-a.");
  EXPECT_EQ(r.up_source, "config");
}

TEST_F(QueryEngineTest, WhereIsTheBookSaysWhereEachIs) {
  const AskResult r = Ask("where is the book");
  EXPECT_EQ(Ids(r), (std::vector<int64_t>{2, 8}));
  EXPECT_EQ(r.count, 2);
  EXPECT_NE(r.answer.find("#2 on the dining table (#1)"), std::string::npos) << r.answer;
  EXPECT_NE(r.answer.find("#8 on the shelf (#7)"), std::string::npos) << r.answer;
  const AskResult one = Ask("where is the laptop");
  EXPECT_EQ(one.answer,
            "The laptop (#14) is on the dining table (#1) at (1.37, 0.22, 0.76) m, last seen 12 s "
            "ago by robot-b.");
}

TEST_F(QueryEngineTest, NotFoundSaysWhatWasFoundInstead) {
  const AskResult r = Ask("where is the cup on the shelf");
  EXPECT_EQ(r.count, 0);
  EXPECT_EQ(r.yes, false);
  EXPECT_NE(r.answer.find("No cup is on the shelf (#7)"), std::string::npos) << r.answer;
  EXPECT_NE(r.answer.find("the cup (#3) on the dining table (#1)"), std::string::npos) << r.answer;
  EXPECT_EQ(Ids(r), std::vector<int64_t>{3});
  const AskResult couch = Ask("where is the book on the sofa");
  EXPECT_NE(couch.answer.find("I have not seen any couches"), std::string::npos) << couch.answer;
  const AskResult missing = Ask("where is the bottle");
  EXPECT_EQ(missing.answer, "I have not seen any bottles.");
  EXPECT_TRUE(missing.objects.empty());
}

TEST_F(QueryEngineTest, WhatIsOnTheDeskListsExactlyWhatIsOnIt) {
  const AskResult r = Ask("what is on the desk");
  EXPECT_EQ(r.intent, "what_on");
  // "desk" is the detector class "dining table": both tables' objects.
  EXPECT_EQ(Ids(r), (std::vector<int64_t>{2, 3, 4, 9, 11, 12, 13, 14}));
  EXPECT_EQ(r.count, 8);
  const AskResult shelf = Ask("what is on the shelf");
  EXPECT_EQ(Ids(shelf), std::vector<int64_t>{8});
  EXPECT_EQ(shelf.answer, "On the shelf (#7) there is a book (#8).");
  const AskResult one = Ask("what is on #10");
  EXPECT_EQ(Ids(one), (std::vector<int64_t>{9, 11, 12, 13}));
  const AskResult none = Ask("what is on the chair");
  EXPECT_EQ(none.count, 0);
  EXPECT_NE(none.answer.find("Nothing is on any of the 2 chairs"), std::string::npos)
      << none.answer;
  EXPECT_EQ(r.answer.rfind("On the dining table (#1) there are a book (#2), a cup (#3), a keyboard "
                           "(#4) and a laptop (#14); on the dining table (#10) there are ",
                           0),
            0u)
      << r.answer;
  const AskResult books = Ask("which books are on the table");
  EXPECT_EQ(Ids(books), std::vector<int64_t>{2});
}

TEST_F(QueryEngineTest, IsThereACupNearTheKeyboard) {
  const AskResult r = Ask("is there a cup near the keyboard");
  EXPECT_EQ(r.intent, "exists");
  EXPECT_EQ(r.yes, true);
  EXPECT_EQ(Ids(r), std::vector<int64_t>{3});
  EXPECT_EQ(r.relations[0].anchor_id, 4);
  EXPECT_EQ(r.answer.rfind("Yes, the cup (#3) is near the keyboard (#4): boxes 0.26 m apart", 0),
            0u)
      << r.answer;
  const AskResult no = Ask("is there a cup near the monitor");
  EXPECT_EQ(no.yes, false);
  EXPECT_NE(no.answer.find("No, no cup is near the tv (#9); the nearest is the cup (#3), 2.87 m "
                           "from the tv (#9)"),
            std::string::npos)
      << no.answer;
  EXPECT_EQ(Ask("is there a bottle").yes, false);
  EXPECT_EQ(Ask("is there a bottle on the table").answer, "No, I have not seen any bottles.");
  EXPECT_EQ(Ask("is there a laptop").yes, true);
}

TEST_F(QueryEngineTest, YesNoRelationChecks) {
  EXPECT_EQ(Ask("is the book on the shelf").yes, true);
  EXPECT_EQ(Ask("is the cup on the shelf").yes, false);
  EXPECT_EQ(Ask("is the chair under the table").yes, true);
  EXPECT_EQ(Ask("is the mouse under the table").yes, false);
  EXPECT_EQ(Ask("is the keyboard between the book and the cup").yes, true);
  EXPECT_EQ(Ask("is the shelf between the book and the cup").yes, false);
}

TEST_F(QueryEngineTest, BetweenExcludesWhatHoldsTheAnchors) {
  const AskResult r = Ask("what is between the book and the cup");
  const std::vector<int64_t> ids = Ids(r);
  EXPECT_TRUE(std::count(ids.begin(), ids.end(), 4)) << r.answer;   // the keyboard
  EXPECT_FALSE(std::count(ids.begin(), ids.end(), 1)) << r.answer;  // the table under both
  EXPECT_FALSE(std::count(ids.begin(), ids.end(), 6)) << r.answer;  // a chair on the floor
}

TEST_F(QueryEngineTest, Counts) {
  const AskResult r = Ask("how many chairs are there");
  EXPECT_EQ(r.intent, "count");
  EXPECT_EQ(r.count, 2);
  EXPECT_EQ(r.answer, "There are 2 chairs.");
  EXPECT_EQ(Ask("how many chairs are under the table").count, 1);
  EXPECT_EQ(Ask("how many chairs are under the table").answer,
            "There is 1 chair under a dining table.");
  EXPECT_EQ(Ask("how many books are on the tables").count, 1);
  EXPECT_EQ(Ask("how many bottles").answer, "There are no bottles.");
  EXPECT_EQ(Ask("how many objects are in the map").count, 14);
}

TEST_F(QueryEngineTest, ListAllObjects) {
  const AskResult r = Ask("list all objects");
  EXPECT_EQ(r.intent, "list");
  EXPECT_EQ(r.count, 14);
  EXPECT_EQ(r.objects.size(), 14u);
  EXPECT_EQ(r.answer.rfind("The map has 14 objects: 2 books, 2 chairs, 2 dining tables, 2 "
                           "keyboards, a cup",
                           0),
            0u)
      << r.answer;
}

TEST_F(QueryEngineTest, WhichRobotSawTheLaptopLast) {
  const AskResult r = Ask("which robot saw the laptop last");
  EXPECT_EQ(r.intent, "which_robot");
  EXPECT_EQ(r.answer,
            "The last robot to see the laptop (#14) was robot-b, 12 s ago (seen by robot-a and "
            "robot-b).");
  EXPECT_NE(Ask("who saw the book first").answer.find("was robot-b, 40 s ago"), std::string::npos);
}

TEST_F(QueryEngineTest, LeftRightOfTheMonitor) {
  const AskResult left = Ask("what is left of the monitor");
  EXPECT_EQ(left.intent, "what_left_of");
  EXPECT_EQ(Ids(left), std::vector<int64_t>{12});
  EXPECT_NE(left.relations[0].evidence.find("seen from robot-a"), std::string::npos);
  EXPECT_EQ(Ids(Ask("what is to the right of the screen")), std::vector<int64_t>{11});
  const AskResult front = Ask("what is in front of the monitor");
  EXPECT_NE(std::find_if(front.objects.begin(), front.objects.end(),
                         [](const MapObject& o) { return o.id == 13; }),
            front.objects.end());
  // Without any viewpoint the engine says so instead of guessing.
  MapView blind = view_;
  blind.viewpoints.clear();
  const AskResult r = engine_.Ask("what is left of the monitor", blind);
  EXPECT_EQ(r.status.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(r.answer.find("no robot pose"), std::string::npos);
}

TEST_F(QueryEngineTest, Nearest) {
  const AskResult r = Ask("what is the nearest chair to the shelf");
  EXPECT_EQ(r.intent, "nearest");
  EXPECT_EQ(Ids(r), std::vector<int64_t>{6});
  EXPECT_NE(r.answer.find("The nearest chair to the shelf (#7) is #6, 0.05 m away"),
            std::string::npos)
      << r.answer;
  const AskResult me = Ask("where is the nearest keyboard");
  EXPECT_EQ(Ids(me), std::vector<int64_t>{13});
  EXPECT_NE(me.answer.find("to robot-a"), std::string::npos) << me.answer;
}

TEST_F(QueryEngineTest, UnknownWordsGiveInvalidArgumentWithKnownWords) {
  const AskResult r = engine_.Ask("where is the unicorn", *index_, {});
  EXPECT_EQ(r.status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(r.intent, "unknown");
  EXPECT_NE(r.answer.find("unicorn"), std::string::npos);
  EXPECT_NE(r.answer.find("potted plant"), std::string::npos);
}

TEST_F(QueryEngineTest, RelationsApi) {
  auto rels = engine_.Relations(*index_, 2, 1);
  ASSERT_TRUE(rels.ok());
  ASSERT_FALSE(rels->empty());
  EXPECT_EQ(RelationName(rels->front().kind), "on");
  for (const RelationResult& r : *rels) EXPECT_TRUE(r.holds);
  auto all = engine_.Relations(*index_, 2, 1, "", true);
  EXPECT_EQ(all->size(), 11u);
  EXPECT_EQ(engine_.Relations(*index_, 2, 99).status().code(), absl::StatusCode::kNotFound);
  auto between = engine_.Relation(*index_, RelationKind::kBetween, 4, 2, 3);
  ASSERT_TRUE(between.ok());
  EXPECT_TRUE(between->holds);
  auto left = engine_.Relation(*index_, RelationKind::kLeftOf, 12, 9, 0, "robot-a");
  EXPECT_TRUE(left->holds);
}

TEST_F(QueryEngineTest, FindObjects) {
  ObjectFilter f;
  f.classes = {"book", "cup"};
  auto r = engine_.FindObjects(*index_, f);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 3u);
  EXPECT_EQ((*r)[0].id, 2);
  f.near_center_m = Vec3d(3.2, 0.1, 1.2);
  f.radius_m = 0.5;
  r = engine_.FindObjects(*index_, f);
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ((*r)[0].id, 8);
  ObjectFilter box;
  box.box_min_m = Vec3d(0, 0, 0.7);
  box.box_max_m = Vec3d(1.6, 0.9, 2);
  box.limit = 2;
  EXPECT_EQ(engine_.FindObjects(*index_, box)->size(), 2u);
  ObjectFilter bad;
  bad.radius_m = 1;
  EXPECT_EQ(engine_.FindObjects(*index_, bad).status().code(), absl::StatusCode::kInvalidArgument);
  bad = ObjectFilter{};
  bad.box_min_m = Vec3d(1, 1, 1);
  EXPECT_FALSE(engine_.FindObjects(*index_, bad).ok());
}

TEST_F(QueryEngineTest, GravityFromCallerRotatedMap) {
  const Mat3d R = Eigen::AngleAxisd(M_PI / 2, Vec3d::UnitX()).toRotationMatrix();
  const std::vector<MapObject> rotated = testing::Rotated(objects_, R);
  MapView v;
  v.objects = rotated;
  v.up_map = R * Vec3d::UnitZ();
  const AskResult r = engine_.Ask("what is on the shelf", v);
  EXPECT_EQ(Ids(r), std::vector<int64_t>{8});
  EXPECT_EQ(r.up_source, "given");
  v.up_map.reset();  // wrong up (config +z): the book is no longer on the shelf
  EXPECT_EQ(engine_.Ask("what is on the shelf", v).count, 0);
}

TEST_F(QueryEngineTest, ConcurrentAsksOnOneIndexAgree) {
  const std::vector<std::string> questions = {"what is on the desk", "where is the book",
                                              "is there a cup near the keyboard",
                                              "what is left of the monitor"};
  std::vector<std::string> expected;
  for (const std::string& q : questions) expected.push_back(Ask(q).answer);
  std::vector<std::thread> threads;
  std::atomic<int> mismatches{0};
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int k = 0; k < 200; ++k) {
        const size_t i = k % questions.size();
        const AskResult r = engine_.Ask(questions[i], *index_, AskContext{kT0, ""});
        if (r.answer != expected[i]) ++mismatches;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(mismatches.load(), 0);
}

TEST_F(QueryEngineTest, BadObjectsAreIgnoredNotFatal) {
  std::vector<MapObject> objects = objects_;
  objects[0].centroid_m.x() = std::nan("");
  MapView v;
  v.objects = objects;
  const AskResult r = engine_.Ask("how many dining tables are there", v);
  EXPECT_TRUE(r.status.ok());
  EXPECT_EQ(r.count, 1);
  MapView empty;
  EXPECT_EQ(engine_.Ask("list all objects", empty).answer, "The map has no objects yet.");
}

}  // namespace
}  // namespace loci::query

namespace loci::query {
namespace {

// The largest map keyframe validation lets in (server.map_extent_m, +-10 km): two objects at
// opposite corners stretch the index's grid over 20 km, and the office still answers right (the
// grid's cell count is capped, so it cannot take the gigabytes a 1e12 m extent once took).
TEST(QueryEngineExtent, AMapSpanningTheWholeExtentStillAnswers) {
  std::vector<MapObject> objects = testing::Office();
  objects.push_back(testing::Box(90, "chair", {-1e4, -1e4, 0}, {-1e4 + 0.5, -1e4 + 0.5, 0.9}));
  objects.push_back(testing::Box(91, "chair", {1e4 - 0.5, 1e4 - 0.5, 0}, {1e4, 1e4, 0.9}));
  QueryEngine engine;
  MapView view;
  view.objects = objects;
  view.now_ns = testing::kT0;
  const auto index = engine.Index(view);
  const AskResult on = engine.Ask("what is on #10", *index, AskContext{testing::kT0, ""});
  ASSERT_TRUE(on.status.ok()) << on.answer;
  std::vector<int64_t> ids;
  for (const MapObject& o : on.objects) ids.push_back(o.id);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<int64_t>{9, 11, 12, 13}));
  const AskResult count =
      engine.Ask("how many chairs are there", *index, AskContext{testing::kT0, ""});
  EXPECT_EQ(count.count, 4);
}

}  // namespace
}  // namespace loci::query

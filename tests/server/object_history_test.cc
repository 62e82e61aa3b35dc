// Objects' places over time (ObjectMap): a confirmed object whose place is seen empty is gone
// (kept with its history); seen again elsewhere it is the same object moved, under its old id;
// seen again where it was, it is back. The history survives a checkpoint.
#include <gtest/gtest.h>

#include "loci/store/v1/map_state.pb.h"
#include "server/map/object_map.h"
#include "server/map/visibility.h"
#include "tests/server/object_observations.h"

namespace loci::server {
namespace {

using testing::Rect;
using testing::WithSizes;
using Kind = ObjectPlaceChange::Kind;

constexpr int64_t kViewNs = 600'000'000;  // views 0.6 s apart: one evidence window each

// A camera at the map origin (optical frame = map frame) looking at a flat surface 1 m ahead,
// on which a 10 cm mouse is detected at x_m; views stamped kf x 0.6 s.
class MouseRoom {
 public:
  MouseRoom() : map_(WithSizes(1.5), 0.01), depth_m_(480, 640, CV_32FC1, cv::Scalar(1.0f)) {}

  int64_t SeeMouseAt(double x_m, int views) {
    int64_t id = 0;
    for (int i = 0; i < views; ++i) {
      MapObservation o = Rect("mouse", 0.6, 0, ++kf_, x_m - 0.05, x_m + 0.05, -0.05, 0.05, 1.0);
      o.t_ns = kf_ * kViewNs;
      id = map_.Integrate({o}, &changes_)[0];
    }
    return id;
  }
  // Views of the whole surface without any box.
  void SeeNothing(int views) {
    for (int i = 0; i < views; ++i) {
      ++kf_;
      map_.ObserveView(kf_, kf_ * kViewNs, {&camera_, &depth_m_, 1, SE3d::Identity(), &no_boxes_},
                       {}, &changes_);
    }
  }
  std::vector<ObjectChange> Changes(ObjectChange::Kind kind) const {
    std::vector<ObjectChange> out;
    for (const ObjectChange& c : changes_) {
      if (c.kind == kind) out.push_back(c);
    }
    return out;
  }
  ObjectMap& map() { return map_; }

 private:
  ObjectMap map_;
  PinholeCamera camera_ = PinholeCamera::TumFr1();
  cv::Mat depth_m_;
  std::vector<Detection2D> no_boxes_;
  std::vector<ObjectChange> changes_;
  int64_t kf_ = 0;
};

TEST(ObjectHistory, AGoneObjectSeenElsewhereMovedUnderItsOldId) {
  MouseRoom room;
  const int64_t id = room.SeeMouseAt(-0.2, 5);
  ASSERT_TRUE(room.map().Find(id)->confirmed());
  room.SeeNothing(20);  // its place empty: below the removal belief
  ASSERT_EQ(room.map().Find(id), nullptr);
  ASSERT_EQ(room.map().Removed().size(), 1u);
  EXPECT_EQ(room.map().Removed()[0].history.back().kind, Kind::kRemoved);
  EXPECT_GT(room.map().Removed()[0].removed_t_ns, 0);
  const int64_t fresh = room.SeeMouseAt(0.25, 6);
  EXPECT_EQ(fresh, id) << "the mouse seen elsewhere is the one gone";
  ASSERT_NE(room.map().Find(id), nullptr);
  EXPECT_TRUE(room.map().Removed().empty());
  const std::optional<MapObject> now = room.map().SnapshotOf(id);
  ASSERT_TRUE(now.has_value());
  ASSERT_EQ(now->history.size(), 2u);
  EXPECT_EQ(now->history[0].kind, Kind::kAppeared);
  EXPECT_EQ(now->history[1].kind, Kind::kMoved);
  EXPECT_NEAR(now->history[1].from_m.x(), -0.2, 0.02);
  EXPECT_NEAR(now->history[1].centroid_m.x(), 0.25, 0.02);
  EXPECT_FALSE(now->history[1].evidence_keyframe_ids.empty());
  const auto moved = room.Changes(ObjectChange::Kind::kMoved);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].object_id, id);
  EXPECT_NEAR(moved[0].from_m.x(), -0.2, 0.02);
  EXPECT_EQ(room.map().confirmed_count(), 1u) << "one mouse, never two";
}

TEST(ObjectHistory, SeenAgainWhereItWasItIsBackNotMoved) {
  MouseRoom room;
  const int64_t id = room.SeeMouseAt(-0.2, 5);
  room.SeeNothing(20);
  ASSERT_EQ(room.map().Find(id), nullptr);
  EXPECT_EQ(room.SeeMouseAt(-0.2, 6), id);
  const std::optional<MapObject> now = room.map().SnapshotOf(id);
  ASSERT_TRUE(now.has_value());
  ASSERT_EQ(now->history.size(), 2u);
  EXPECT_EQ(now->history[1].kind, Kind::kAppeared);
  EXPECT_TRUE(room.Changes(ObjectChange::Kind::kMoved).empty());
}

TEST(ObjectHistory, AnotherClassElsewhereIsNotTheGoneOne) {
  MouseRoom room;
  const int64_t id = room.SeeMouseAt(-0.2, 5);
  room.SeeNothing(20);
  int64_t book = 0;
  for (int64_t i = 0; i < 6; ++i) {
    MapObservation o = Rect("book", 0.6, 0, 100 + i, 0.2, 0.4, -0.1, 0.05, 1.0);
    o.t_ns = (100 + i) * kViewNs;
    std::vector<ObjectChange> changes;
    book = room.map().Integrate({o}, &changes)[0];
  }
  EXPECT_NE(book, id);
  EXPECT_EQ(room.map().Removed().size(), 1u) << "the mouse stays gone";
}

TEST(ObjectHistory, HistoryAndGoneObjectsSurviveACheckpoint) {
  MouseRoom room;
  const int64_t id = room.SeeMouseAt(-0.2, 5);
  room.SeeNothing(20);
  loci::store::v1::ObjectMapState state;
  room.map().SaveState(&state);
  ObjectMap loaded(WithSizes(1.5), 0.01);
  ASSERT_TRUE(loaded.LoadState(state).ok());
  const std::vector<MapObject> before = room.map().Removed(), after = loaded.Removed();
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].id, id);
  ASSERT_EQ(after[0].history.size(), before[0].history.size());
  EXPECT_EQ(after[0].history.back().kind, Kind::kRemoved);
  EXPECT_EQ(after[0].history.back().evidence_keyframe_ids,
            before[0].history.back().evidence_keyframe_ids);
  EXPECT_EQ(after[0].removed_t_ns, before[0].removed_t_ns);
  // Corrupt state is an error, not a crash.
  (*state.mutable_history())[id].mutable_changes(0)->set_kind(7);
  EXPECT_FALSE(ObjectMap(WithSizes(1.5), 0.01).LoadState(state).ok());
}

}  // namespace
}  // namespace loci::server

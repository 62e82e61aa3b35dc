// The changes a read-only query server streams between two publications of the writer's map.
#include "server/runtime/replica_changes.h"

#include <gtest/gtest.h>

namespace loci::server {
namespace {

using Kind = ObjectChange::Kind;

MapObject Object(int64_t id, const std::string& cls, const Eigen::Vector3d& centroid_m) {
  MapObject o;
  o.id = id;
  o.class_name = cls;
  o.confidence = 0.8;
  o.centroid_m = centroid_m;
  o.aabb_min_m = centroid_m - Eigen::Vector3d::Constant(0.1);
  o.aabb_max_m = centroid_m + Eigen::Vector3d::Constant(0.1);
  o.observation_count = 3;
  o.confirmed = true;
  return o;
}

ReplicaSnapshot Snapshot(std::vector<MapObject> objects, std::vector<MapObject> removed = {}) {
  ReplicaSnapshot s;
  s.objects = std::move(objects);
  s.removed = std::move(removed);
  return s;
}

TEST(ReplicaChanges, AnUnchangedPublicationHasNoEvents) {
  const ReplicaSnapshot s = Snapshot({Object(1, "cup", {1, 0, 0.8}), Object(2, "chair", {2, 1, 0})});
  EXPECT_TRUE(ChangesBetween(s, s).empty());
}

TEST(ReplicaChanges, NewObjectsAreCreatedAndChangedOnesUpdated) {
  const ReplicaSnapshot before = Snapshot({Object(1, "cup", {1, 0, 0.8})});
  MapObject seen_again = Object(1, "cup", {1.01, 0, 0.8});
  seen_again.observation_count = 4;
  const ReplicaSnapshot after = Snapshot({seen_again, Object(5, "book", {0, 1, 0.7})});
  const std::vector<ObjectEventOut> events = ChangesBetween(before, after);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, Kind::kUpdated);
  EXPECT_EQ(events[0].object.id, 1);
  EXPECT_EQ(events[0].object.observation_count, 4u);
  EXPECT_EQ(events[1].kind, Kind::kCreated);
  EXPECT_EQ(events[1].object.id, 5);
}

TEST(ReplicaChanges, AMoveInTheHistoryIsAMoveWithItsEvidence) {
  const ReplicaSnapshot before = Snapshot({Object(3, "cup", {1, 0, 0.8})});
  MapObject moved = Object(3, "cup", {2, 1, 0.8});
  ObjectPlaceChange change;
  change.kind = ObjectPlaceChange::Kind::kMoved;
  change.t_ns = 77;
  change.centroid_m = moved.centroid_m;
  change.from_m = {1, 0, 0.8};
  change.evidence_keyframe_ids = {10, 11};
  moved.history = {change};
  const std::vector<ObjectEventOut> events = ChangesBetween(before, Snapshot({moved}));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::kMoved);
  EXPECT_EQ(events[0].from_m, Eigen::Vector3d(1, 0, 0.8));
  EXPECT_EQ(events[0].evidence_keyframe_ids, (std::vector<int64_t>{10, 11}));
  EXPECT_EQ(events[0].evidence_t_ns, 77);
}

TEST(ReplicaChanges, FoundGoneAndMergedAwayObjectsAreRemovedOnce) {
  const ReplicaSnapshot before = Snapshot(
      {Object(1, "cup", {1, 0, 0.8}), Object(2, "book", {0, 1, 0.7}), Object(4, "book", {0, 1.05, 0.7})});
  MapObject gone = before.objects[0];
  gone.removed_t_ns = 900;
  ObjectPlaceChange change;
  change.kind = ObjectPlaceChange::Kind::kRemoved;
  change.t_ns = 880;
  change.evidence_keyframe_ids = {20, 21, 22};
  gone.history = {change};
  MapObject survivor = before.objects[1];  // absorbed object 4
  survivor.observation_count = 6;
  const ReplicaSnapshot after = Snapshot({survivor}, {gone});
  const std::vector<ObjectEventOut> events = ChangesBetween(before, after);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].kind, Kind::kUpdated);
  EXPECT_EQ(events[0].object.id, 2);
  EXPECT_EQ(events[1].kind, Kind::kRemoved);
  EXPECT_EQ(events[1].object.id, 1);
  EXPECT_EQ(events[1].evidence_keyframe_ids, (std::vector<int64_t>{20, 21, 22}));
  EXPECT_EQ(events[1].evidence_t_ns, 880);
  EXPECT_EQ(events[2].kind, Kind::kRemoved);
  EXPECT_EQ(events[2].object.id, 4);
  EXPECT_TRUE(events[2].evidence_keyframe_ids.empty());
  // Already gone before: not removed again.
  EXPECT_TRUE(ChangesBetween(after, after).empty());
}

}  // namespace
}  // namespace loci::server

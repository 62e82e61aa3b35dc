// A room mapped, then visited again two days later by the same robot: what was taken away in
// between leaves the map (REMOVED, with the keyframes that saw its place empty), what was put
// elsewhere is one object that MOVED, with its history, and nothing else changes. The belief forgets at its class's rate (config/classes.yaml `stays_days`), so the
// later views of the empty place outweigh the earlier sightings.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/objects_json.h"
#include "server/map/map_options.h"
#include "synth/sequence_writer.h"
#include "tests/server/island_robots.h"
#include "tests/server/scene_stream.h"

namespace loci::server {
namespace {

namespace fs = std::filesystem;
using testing::Rebased;
using testing::Running;
using testing::Start;
using testing::Stream;

constexpr uint64_t kSeed = 2;
constexpr int64_t kDaysLaterNs = 2 * 86400 * 1'000'000'000LL;

std::map<int64_t, loci::v1::Object> Confirmed(loci::v1::Query::Stub* stub) {
  grpc::ClientContext ctx;
  loci::v1::FindObjectsRequest req;
  req.set_confirmed_only(true);
  loci::v1::FindObjectsResponse resp;
  EXPECT_TRUE(stub->FindObjects(&ctx, req, &resp).ok());
  std::map<int64_t, loci::v1::Object> out;
  for (const auto& o : resp.objects()) out[o.id()] = o;
  return out;
}

class ObjectChanges : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(
        (fs::temp_directory_path() / ("loci_changes_" + std::to_string(getpid()))).string());
    fs::remove_all(*dir_);
    ASSERT_TRUE(synth::WriteSequence(testing::Room(kSeed), *dir_ + "/day1").ok());
    auto gt = ReadObjectsJson(*dir_ + "/day1/objects.json");
    ASSERT_TRUE(gt.ok()) << gt.status();
    // The thing taken away: of those resting on furniture and holding nothing, the one its
    // class says is moved soonest (the shipped classes' stays_days).
    ServerOptions options = testing::Options();
    const auto& stays = options.map.stays_days;
    std::set<int64_t> supports;
    for (const auto& o : gt->objects) supports.insert(o.on_id);
    double soonest_days = 1e9;
    for (const auto& o : gt->objects) {
      const auto it = stays.find(o.class_name);
      if (o.dynamic || o.on_id == 0 || supports.count(o.id) || it == stays.end()) continue;
      if (it->second < soonest_days) {
        soonest_days = it->second;
        *taken_ = o;
      }
    }
    ASSERT_GT(taken_->id, 0) << "no movable object in the room";
    for (const std::string name : {"same", "taken", "moved"}) {
      synth::SceneOptions later = testing::Room(kSeed);
      later.start_t_ns += kDaysLaterNs;
      if (name == "taken") later.absent_ids = {taken_->id};
      if (name == "moved") later.moved_ids = {taken_->id};
      ASSERT_TRUE(synth::WriteSequence(later, *dir_ + "/" + name).ok());
    }
    auto moved_gt = ReadObjectsJson(*dir_ + "/moved/objects.json");
    ASSERT_TRUE(moved_gt.ok()) << moved_gt.status();
    for (const auto& o : moved_gt->objects) {
      if (o.id == taken_->id) *moved_to_ = o;
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }

  struct Visit {
    std::map<int64_t, loci::v1::Object> before, after;
    std::vector<ObjectEventOut> removed;  // of objects confirmed before the second visit
    std::vector<ObjectEventOut> moved;
    std::string what_moved;  // Ask "what moved in the last 3 days" after the second visit
  };

  // Day 1, then the second visit from folder `later`, as robot A both times.
  static Visit Revisit(const std::string& later) {
    Visit v;
    Running r = Start(*dir_ + "/" + later + ".db", testing::Options());
    EXPECT_TRUE(r.server);
    if (!r.server) return v;
    auto day1 = testing::LoadSceneKeyframes(*dir_ + "/day1");
    auto day3 = testing::LoadSceneKeyframes(*dir_ + "/" + later);
    EXPECT_TRUE(day1.ok() && day3.ok());
    if (!day1.ok() || !day3.ok()) return v;
    Stream(r.mapping.get(), "A", Rebased(*day1, 0, false));
    r.server->Flush();
    v.before = Confirmed(r.query.get());
    auto events = std::make_shared<ObjectEventQueue>(100000);
    EXPECT_TRUE(r.server->events().Subscribe(events).ok());
    Stream(r.mapping.get(), "A", Rebased(*day3, 0, false));
    r.server->Flush();
    r.server->events().Unsubscribe(events);
    events->Close();
    while (std::optional<ObjectEventOut> e = events->Pop()) {
      if (e->kind == ObjectChange::Kind::kRemoved && v.before.count(e->object.id)) {
        v.removed.push_back(std::move(*e));
      } else if (e->kind == ObjectChange::Kind::kMoved) {
        v.moved.push_back(std::move(*e));
      }
    }
    v.after = Confirmed(r.query.get());
    grpc::ClientContext ctx;
    loci::v1::AskRequest ask;
    ask.set_text("what moved in the last 3 days?");
    loci::v1::AskResponse answer;
    EXPECT_TRUE(r.query->Ask(&ctx, ask, &answer).ok());
    v.what_moved = answer.answer();
    return v;
  }

  static std::string* dir_;
  static GroundTruthObject* taken_;     // taken away, or moved
  static GroundTruthObject* moved_to_;  // the moved one at its new place
};

std::string* ObjectChanges::dir_ = nullptr;
GroundTruthObject* ObjectChanges::taken_ = new GroundTruthObject;
GroundTruthObject* ObjectChanges::moved_to_ = new GroundTruthObject;

TEST_F(ObjectChanges, TheThingTakenAwayIsRemovedOnceAndNothingElse) {
  const Visit v = Revisit("taken");
  ASSERT_GE(v.before.size(), 5u);
  // The one removal is the taken thing: its class, and its height.
  ASSERT_EQ(v.removed.size(), 1u) << "confirmed objects removed on the second visit";
  const ObjectEventOut& e = v.removed.front();
  EXPECT_EQ(e.object.class_name, taken_->class_name);
  EXPECT_NEAR(e.object.aabb_max_m.z() - e.object.aabb_min_m.z(), taken_->extent_m.z(), 0.05);
  EXPECT_FALSE(e.evidence_keyframe_ids.empty());
  EXPECT_GE(e.evidence_t_ns, testing::Room(kSeed).start_t_ns + kDaysLaterNs)
      << "the evidence is the second visit's views";
  EXPECT_EQ(v.after.count(e.object.id), 0u);
  for (const auto& [id, o] : v.before) {
    if (id == e.object.id) continue;
    EXPECT_EQ(v.after.count(id), 1u) << o.class_name() << " #" << id << " left the map";
  }
}

TEST_F(ObjectChanges, TheThingPutElsewhereMovedAndIsOneObject) {
  const Visit v = Revisit("moved");
  ASSERT_GE(v.before.size(), 5u);
  ASSERT_EQ(v.moved.size(), 1u) << "objects moved on the second visit";
  const ObjectEventOut& e = v.moved.front();
  ASSERT_EQ(v.before.count(e.object.id), 1u) << "it keeps the id it had";
  const loci::v1::Object& was = v.before.at(e.object.id);
  EXPECT_EQ(e.object.class_name, taken_->class_name);
  const Eigen::Vector3d was_m(was.centroid_m().x(), was.centroid_m().y(), was.centroid_m().z());
  EXPECT_LT((e.from_m - was_m).norm(), 0.02) << "its previous place is where it was";
  // Its new place (the map frame is not the scene's: the distance moved is the same in both).
  EXPECT_NEAR((e.object.centroid_m - e.from_m).norm(),
              (moved_to_->centroid_m - taken_->centroid_m).norm(), 0.05);
  EXPECT_FALSE(e.evidence_keyframe_ids.empty());
  // One object with its history, never two; every other object stays.
  ASSERT_EQ(v.after.count(e.object.id), 1u);
  const loci::v1::Object& now = v.after.at(e.object.id);
  ASSERT_EQ(now.history_size(), 2) << "appeared, moved";
  EXPECT_EQ(now.history(0).kind(), loci::v1::PlaceChange::APPEARED);
  EXPECT_EQ(now.history(1).kind(), loci::v1::PlaceChange::MOVED);
  EXPECT_EQ(v.after.size(), v.before.size());
  for (const auto& [id, o] : v.before) {
    EXPECT_EQ(v.after.count(id), 1u) << o.class_name() << " #" << id << " left the map";
  }
  // A removal of the moved object before its new place was seen is corrected by the move.
  for (const ObjectEventOut& r : v.removed) EXPECT_EQ(r.object.id, e.object.id);
  EXPECT_NE(v.what_moved.find(absl::StrCat("(#", e.object.id, ") moved")), std::string::npos)
      << v.what_moved;
}

TEST_F(ObjectChanges, ARoomAsItWasLosesNothing) {
  const Visit v = Revisit("same");
  ASSERT_GE(v.before.size(), 5u);
  EXPECT_TRUE(v.moved.empty()) << v.moved.front().object.class_name << " moved";
  EXPECT_NE(v.what_moved.find("Nothing moved"), std::string::npos) << v.what_moved;
  EXPECT_TRUE(v.removed.empty()) << v.removed.front().object.class_name << " removed";
  for (const auto& [id, o] : v.before) {
    EXPECT_EQ(v.after.count(id), 1u) << o.class_name() << " #" << id << " left the map";
  }
}

}  // namespace
}  // namespace loci::server

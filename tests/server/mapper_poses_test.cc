// Keyframes whose poses change move what they contributed: a moved block of keyframes leaves
// the map exactly as if it had had the new poses from the start, objects only the other block
// saw stay put, the OctoMap follows (without holding up the keyframes mapped meanwhile), and a
// block moved onto objects the map already holds merges into them.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <map>

#include "server/map/mapper.h"
#include "tests/server/mapper_views.h"

namespace loci::server {
namespace {

using testing::BoxWorldOptions;
using testing::DefaultBoxes;
using testing::Views;
using testing::WorldBox;

const Eigen::Vector3d kOffset(8.0, 0.0, 0.0);  // room B, beyond the 4 m depth range of room A
const Eigen::Vector3d kTargetA(0.1, 0.05, 0.05);

// Room A's boxes and a copy 8 m away (room B, other ids).
std::vector<WorldBox> TwoRooms() {
  std::vector<WorldBox> boxes = DefaultBoxes(/*with_person=*/false);
  for (WorldBox b : DefaultBoxes(false)) {
    b.id += 10;
    b.min_m += kOffset;
    b.max_m += kOffset;
    boxes.push_back(b);
  }
  return boxes;
}

// Integrates keyframes, keeping their products for later moves.
struct MappedRun {
  // Before the mapper: an OctoMap rebuild reads products on the mapper's thread until the mapper
  // is destroyed.
  std::map<int64_t, KeyframeProducts> products;
  std::vector<ObjectEventOut> events;
  Mapper mapper{BoxWorldOptions()};
  MappedRun() {
    mapper.SetEventListener([this](const auto& e) { events.insert(events.end(), e.begin(), e.end()); });
  }
  void Add(const std::vector<MapperKeyframe>& keyframes) {
    for (const MapperKeyframe& kf : keyframes) {
      products[kf.keyframe_id] = mapper.BuildProducts(kf);
      mapper.Integrate(kf, products[kf.keyframe_id]);
    }
  }
  Mapper::ProductSource Source() {
    return [this](int64_t id) -> StatusOr<KeyframeProducts> { return products.at(id); };
  }
};

std::map<int64_t, MapObject> ById(const Mapper& m) {
  std::map<int64_t, MapObject> out;
  for (const MapObject& o : m.Snapshot(false)) out[o.id] = o;
  return out;
}

SE3d YawAbout(const Eigen::Vector3d& pivot, double yaw_deg, const Eigen::Vector3d& t) {
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = pivot + t - T.linear() * pivot;
  return T;
}

TEST(MapperPoses, AMovedBlockEndsAsIfItHadItsNewPosesFromTheStart) {
  const auto boxes = TwoRooms();
  const auto room_a = Views(boxes, 12, true, kTargetA, 1);
  const auto room_b = Views(boxes, 12, true, kTargetA + kOffset, 13);
  const SE3d T_move = YawAbout(kTargetA + kOffset, 10.0, {0.30, -0.20, 0.0});

  MappedRun moved;
  moved.Add(room_a);
  moved.Add(room_b);
  const auto before = ById(moved.mapper);
  std::vector<Mapper::KeyframePoseUpdate> updates;
  for (const MapperKeyframe& kf : room_b) updates.push_back({kf.keyframe_id, T_move * kf.T_base_kf});
  const size_t events_before = moved.events.size();
  auto n = moved.mapper.UpdateKeyframePoses(updates, moved.Source());
  ASSERT_TRUE(n.ok()) << n.status();
  EXPECT_EQ(*n, room_b.size());

  MappedRun fresh;  // the same images, room B at the new poses from the start
  fresh.Add(room_a);
  std::vector<MapperKeyframe> room_b_moved = room_b;
  for (MapperKeyframe& kf : room_b_moved) kf.T_base_kf = T_move * kf.T_base_kf;
  fresh.Add(room_b_moved);

  const auto after = ById(moved.mapper), expected = ById(fresh.mapper);
  ASSERT_EQ(after.size(), expected.size());
  ASSERT_EQ(after.size(), 6u);
  const SE3d T_map_base = moved.mapper.MapFromBaseFrame();
  const SE3d T_move_map = T_map_base * T_move * T_map_base.inverse();
  int moved_objects = 0;
  for (const auto& [id, o] : after) {
    ASSERT_TRUE(expected.count(id)) << id;
    EXPECT_EQ(o.class_name, expected.at(id).class_name);
    EXPECT_LT((o.centroid_m - expected.at(id).centroid_m).norm(), 1e-3) << o.class_name << id;
    const Eigen::Vector3d c0 = before.at(id).centroid_m;
    const bool in_b = (T_map_base.inverse() * c0).x() > 4.0;
    if (in_b) {
      ++moved_objects;  // moved by the transform, up to the 1 cm object voxels
      EXPECT_LT((o.centroid_m - T_move_map * c0).norm(), 0.01) << o.class_name;
    } else {
      EXPECT_LT((o.centroid_m - c0).norm(), 1e-9) << o.class_name << " in room A moved";
    }
  }
  EXPECT_EQ(moved_objects, 3);
  EXPECT_EQ(moved.mapper.Cloud(0, {}).size(), fresh.mapper.Cloud(0, {}).size());
  // The OctoMap is rebuilt at the new poses: the same tree as the fresh run's, and not the one
  // from before the move.
  moved.mapper.FlushOctomap();
  fresh.mapper.FlushOctomap();
  EXPECT_EQ(moved.mapper.OctomapBt(), fresh.mapper.OctomapBt());
  MappedRun unmoved;
  unmoved.Add(room_a);
  unmoved.Add(room_b);
  unmoved.mapper.FlushOctomap();
  EXPECT_NE(moved.mapper.OctomapBt(), unmoved.mapper.OctomapBt());
  int updated = 0;
  for (size_t i = events_before; i < moved.events.size(); ++i) {
    updated += moved.events[i].kind == ObjectChange::Kind::kUpdated;
  }
  EXPECT_GE(updated, 3);
}

// The OctoMap rebuild after a move reads every keyframe's products (seconds per 1000 keyframes).
// Keyframes mapped meanwhile do not wait for it on the OctoMap's bounded queue: their scans go
// into the new tree after it, which ends as if they had been mapped after the move. Meanwhile
// OctomapRebuilding() says so (a checkpoint then waits for a later keyframe), and a reader that
// does not wait for the rebuild gets the live tree at once.
TEST(MapperPoses, KeyframesMappedDuringAnOctomapRebuildDoNotWaitForIt) {
  const auto boxes = TwoRooms();
  const auto room_a = Views(boxes, 12, true, kTargetA, 1);
  const auto room_b = Views(boxes, 12, true, kTargetA + kOffset, 13);
  const auto again_a = Views(boxes, 12, true, kTargetA, 25);  // more than the 8 queued scans
  const SE3d T_move = YawAbout(kTargetA + kOffset, 10.0, {0.30, -0.20, 0.0});
  MappedRun run;
  run.Add(room_a);
  run.Add(room_b);
  const std::map<int64_t, KeyframeProducts> products = run.products;
  std::vector<Mapper::KeyframePoseUpdate> updates;
  for (const MapperKeyframe& kf : room_b) updates.push_back({kf.keyframe_id, T_move * kf.T_base_kf});
  // The move reads its keyframes' products; the rebuild after it stops at its first read until
  // the gate opens.
  std::promise<void> gate;
  const std::shared_future<void> open = gate.get_future().share();
  std::atomic<size_t> reads{0};
  auto gated = [&](int64_t id) -> StatusOr<KeyframeProducts> {
    if (++reads > updates.size()) open.wait();
    return products.at(id);
  };
  ASSERT_TRUE(run.mapper.UpdateKeyframePoses(updates, gated).ok());
  auto mapping = std::async(std::launch::async, [&] { run.Add(again_a); });
  const bool mapped = mapping.wait_for(std::chrono::seconds(60)) == std::future_status::ready;
  // What a checkpoint asks before it waits for the OctoMap (MapServer::MaybeCheckpoint defers).
  const bool rebuilding = run.mapper.OctomapRebuilding();
  // A reader that does not wait for the rebuild (GetOctomap by default) gets the live tree.
  auto live = std::async(std::launch::async, [&] { return run.mapper.OctomapBt(false); });
  const bool answered = live.wait_for(std::chrono::seconds(60)) == std::future_status::ready;
  gate.set_value();
  mapping.get();
  EXPECT_TRUE(mapped) << "mapping the next keyframes waited for the OctoMap rebuild";
  EXPECT_TRUE(answered) << "OctomapBt(false) waited for the OctoMap rebuild";
  MappedRun unmoved;  // the live tree: room B where it was, then the next keyframes
  unmoved.Add(room_a);
  unmoved.Add(room_b);
  unmoved.Add(again_a);
  EXPECT_TRUE(live.get() == unmoved.mapper.OctomapBt()) << "the live tree is not the unmoved one";
  EXPECT_GT(reads.load(), updates.size()) << "the rebuild had started";

  MappedRun fresh;  // room B at the new poses from the start, then the same next keyframes
  fresh.Add(room_a);
  std::vector<MapperKeyframe> room_b_moved = room_b;
  for (MapperKeyframe& kf : room_b_moved) kf.T_base_kf = T_move * kf.T_base_kf;
  fresh.Add(room_b_moved);
  fresh.Add(again_a);
  run.mapper.FlushOctomap();
  fresh.mapper.FlushOctomap();
  EXPECT_TRUE(rebuilding) << "OctomapRebuilding() was false while the rebuild was held";
  EXPECT_FALSE(run.mapper.OctomapRebuilding()) << "still rebuilding after FlushOctomap";
  EXPECT_TRUE(run.mapper.OctomapBt() == fresh.mapper.OctomapBt())
      << "the rebuilt OctoMap differs from the one mapped at the new poses";
}

// A pose update rebuilds the OctoMap only when some keyframe's scan would move more than
// map.octomap.rebuild_tolerance_m (1.25 cm) from where it is in the tree. Two moves of 8 mm: the
// first leaves the tree as it was; the second, 16 mm from where the scans are (not 8 mm from the
// last poses), rebuilds it, also in a mapper restarted from a checkpoint taken between the two.
TEST(MapperPoses, SmallMovesAddUpUntilTheyRebuildTheOctomap) {
  const auto boxes = TwoRooms();
  const auto room_a = Views(boxes, 12, true, kTargetA, 1);
  const auto room_b = Views(boxes, 12, true, kTargetA + kOffset, 13);
  auto shift = [](double dx_m) {
    SE3d T = SE3d::Identity();
    T.translation() = Eigen::Vector3d(dx_m, 0.0, 0.0);
    return T;
  };
  auto moved_by = [&](double dx_m) {
    std::vector<Mapper::KeyframePoseUpdate> updates;
    for (const MapperKeyframe& kf : room_b) {
      updates.push_back({kf.keyframe_id, shift(dx_m) * kf.T_base_kf});
    }
    return updates;
  };
  MappedRun run;
  run.Add(room_a);
  run.Add(room_b);
  const std::string unmoved = run.mapper.OctomapBt();
  ASSERT_EQ(run.mapper.options().octomap.rebuild_tolerance_m, 0.0125);
  ASSERT_TRUE(run.mapper.UpdateKeyframePoses(moved_by(0.008), run.Source()).ok());
  EXPECT_TRUE(run.mapper.OctomapBt() == unmoved) << "an 8 mm move rebuilt the OctoMap";
  EXPECT_EQ(run.mapper.Stats().octomap_rebuilds, 0u);
  EXPECT_EQ(run.mapper.Stats().octomap_rebuilds_skipped, 1u);

  const std::string checkpoint = run.mapper.SaveCheckpoint();
  ASSERT_TRUE(run.mapper.UpdateKeyframePoses(moved_by(0.016), run.Source()).ok());
  EXPECT_EQ(run.mapper.Stats().octomap_rebuilds, 1u) << "16 mm from where the scans are";
  MappedRun fresh;  // room B 16 mm over from the start
  fresh.Add(room_a);
  std::vector<MapperKeyframe> room_b_moved = room_b;
  for (MapperKeyframe& kf : room_b_moved) kf.T_base_kf = shift(0.016) * kf.T_base_kf;
  fresh.Add(room_b_moved);
  EXPECT_TRUE(fresh.mapper.OctomapBt() != unmoved);
  EXPECT_TRUE(run.mapper.OctomapBt() == fresh.mapper.OctomapBt())
      << "the rebuilt OctoMap differs from the one mapped at the new poses";

  // The checkpoint keeps where the scans are (the poses 8 mm back from its keyframes' own).
  MappedRun restarted;
  restarted.products = run.products;
  ASSERT_TRUE(restarted.mapper.LoadCheckpoint(checkpoint).ok());
  EXPECT_TRUE(restarted.mapper.OctomapBt() == unmoved);
  ASSERT_TRUE(restarted.mapper.UpdateKeyframePoses(moved_by(0.016), restarted.Source()).ok());
  EXPECT_EQ(restarted.mapper.Stats().octomap_rebuilds, 1u) << "16 mm from where the scans are";
  EXPECT_TRUE(restarted.mapper.OctomapBt() != unmoved);
}

TEST(MapperPoses, ABlockMovedOntoKnownObjectsMergesIntoThem) {
  const auto boxes = TwoRooms();
  MappedRun run;
  run.Add(Views(boxes, 12, true, kTargetA, 1));
  const auto room_b = Views(boxes, 12, true, kTargetA + kOffset, 13);
  run.Add(room_b);
  ASSERT_EQ(run.mapper.Snapshot(false).size(), 6u);
  SE3d back = SE3d::Identity();
  back.translation() = -kOffset;  // room B was room A all along (a robot that started elsewhere)
  std::vector<Mapper::KeyframePoseUpdate> updates;
  for (const MapperKeyframe& kf : room_b) updates.push_back({kf.keyframe_id, back * kf.T_base_kf});
  const size_t events_before = run.events.size();
  ASSERT_TRUE(run.mapper.UpdateKeyframePoses(updates, run.Source()).ok());
  const auto objects = run.mapper.Snapshot(false);
  ASSERT_EQ(objects.size(), 3u);
  for (const MapObject& o : objects) EXPECT_GE(o.observation_count, 13u) << o.class_name;
  int merged = 0, removed = 0;
  for (size_t i = events_before; i < run.events.size(); ++i) {
    merged += run.events[i].kind == ObjectChange::Kind::kMerged;
    removed += run.events[i].kind == ObjectChange::Kind::kRemoved;
  }
  EXPECT_EQ(merged, 3);
  EXPECT_EQ(removed, 3);
}

TEST(MapperPoses, UnknownKeyframeOrBadPoseMovesNothing) {
  MappedRun run;
  run.Add(Views(DefaultBoxes(false), 11, true));
  const auto before = ById(run.mapper);
  SE3d nan_pose = SE3d::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_EQ(run.mapper.UpdateKeyframePoses({{99, SE3d::Identity()}}, run.Source()).status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(run.mapper.UpdateKeyframePoses({{3, nan_pose}}, run.Source()).status().code(),
            absl::StatusCode::kInvalidArgument);
  for (const auto& [id, o] : ById(run.mapper)) {
    EXPECT_EQ(o.centroid_m, before.at(id).centroid_m);
  }
}

}  // namespace
}  // namespace loci::server

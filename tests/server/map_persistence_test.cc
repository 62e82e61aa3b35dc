// What the database keeps of the map: per-keyframe products (product_codec.h) map exactly as
// fresh ones, a map resumed from a checkpoint equals the map of an uninterrupted run, and the
// views' object centroids (the pose graph's landmarks) survive a checkpoint.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <map>

#include "server/map/mapper.h"
#include "server/map/product_codec.h"
#include "tests/server/mapper_views.h"

namespace loci::server {
namespace {

using testing::BoxWorldOptions;
using testing::DefaultBoxes;
using testing::Views;

MapperKeyframe WithoutImages(MapperKeyframe kf) {
  kf.bgr.release();
  kf.depth_m.release();
  kf.detections.clear();
  return kf;
}

// Same objects (ids, classes, evidence) with centroids within tol_m, same cloud and OctoMap.
void ExpectSameMap(const Mapper& a, const Mapper& b, double tol_m) {
  std::map<int64_t, MapObject> by_id;
  for (const MapObject& o : b.Snapshot(false)) by_id[o.id] = o;
  const auto objects = a.Snapshot(false);
  ASSERT_EQ(objects.size(), by_id.size());
  for (const MapObject& o : objects) {
    ASSERT_TRUE(by_id.count(o.id)) << "object " << o.id;
    const MapObject& p = by_id.at(o.id);
    EXPECT_EQ(o.class_name, p.class_name);
    EXPECT_EQ(o.observation_count, p.observation_count);
    EXPECT_EQ(o.confirmed, p.confirmed);
    EXPECT_NEAR(o.confidence, p.confidence, 1e-9);
    EXPECT_LT((o.centroid_m - p.centroid_m).norm(), tol_m) << o.class_name << " #" << o.id;
  }
  EXPECT_EQ(a.Cloud(0, {}).size(), b.Cloud(0, {}).size());
  EXPECT_EQ(a.OctomapBt(), b.OctomapBt());
  EXPECT_EQ(a.Stats().keyframes, b.Stats().keyframes);
  const auto ta = a.Trajectories(), tb = b.Trajectories();
  ASSERT_EQ(ta.size(), tb.size());
  for (const auto& [robot, traj] : ta) {
    ASSERT_EQ(traj.size(), tb.at(robot).size());
    for (size_t i = 0; i < traj.size(); ++i) {
      EXPECT_LT((traj[i].T_world_cam.translation() - tb.at(robot)[i].T_world_cam.translation()).norm(), 1e-9);
    }
  }
}

TEST(ProductCodec, StoredProductsMapExactlyAsFreshOnes) {
  const auto views = Views(DefaultBoxes(/*with_person=*/true), 14, /*masks=*/true);
  Mapper fresh(BoxWorldOptions()), stored(BoxWorldOptions());
  const std::string fingerprint = fresh.options().ProductsFingerprint();
  size_t observations = 0;
  for (const MapperKeyframe& kf : views) {
    const KeyframeProducts p = fresh.BuildProducts(kf);
    auto d = DecodeProducts(EncodeProducts(p, fingerprint), fingerprint);
    ASSERT_TRUE(d.ok()) << d.status();
    ASSERT_EQ(d->static_cloud_kf.size(), p.static_cloud_kf.size());
    for (size_t i = 0; i < p.static_cloud_kf.size(); ++i) {
      EXPECT_EQ(d->static_cloud_kf[i].getVector3fMap(), p.static_cloud_kf[i].getVector3fMap());
      EXPECT_EQ(d->static_cloud_kf[i].label, p.static_cloud_kf[i].label);
      EXPECT_EQ(d->static_cloud_kf[i].r, p.static_cloud_kf[i].r);
      EXPECT_EQ(d->static_cloud_kf[i].g, p.static_cloud_kf[i].g);
      EXPECT_EQ(d->static_cloud_kf[i].b, p.static_cloud_kf[i].b);
    }
    ASSERT_EQ(d->observations.size(), p.observations.size());
    observations += p.observations.size();
    for (size_t i = 0; i < p.observations.size(); ++i) {
      EXPECT_EQ(d->observations[i].class_name, p.observations[i].class_name);
      EXPECT_EQ(d->observations[i].track_id, p.observations[i].track_id);
      EXPECT_EQ(d->observations[i].cloud_kf.size(), p.observations[i].cloud_kf.size());
    }
    EXPECT_EQ(cv::norm(d->visibility_depth_m, p.visibility_depth_m, cv::NORM_INF), 0.0);
    EXPECT_EQ(d->depth_stride, 4);
    EXPECT_EQ(d->detection_boxes.size(), kf.detections.size());
    fresh.Integrate(kf, p);
    stored.Integrate(WithoutImages(kf), *d);  // no images: the products are all it needs
  }
  EXPECT_GT(observations, 20u);
  ExpectSameMap(fresh, stored, 1e-9);
}

TEST(ProductCodec, RefusesOtherOptionsAndBrokenBytes) {
  const auto views = Views(DefaultBoxes(false), 1, true);
  Mapper mapper(BoxWorldOptions());
  const std::string bytes = EncodeProducts(mapper.BuildProducts(views[0]), "aaaa");
  EXPECT_EQ(DecodeProducts(bytes, "bbbb").status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(DecodeProducts("\xff\xff\xff garbage", "aaaa").status().code(),
            absl::StatusCode::kDataLoss);
  EXPECT_EQ(DecodeProducts(bytes.substr(0, bytes.size() / 2), "aaaa").status().code(),
            absl::StatusCode::kDataLoss);
}

TEST(MapCheckpoint, ResumingFromACheckpointGivesTheUninterruptedMap) {
  const auto views = Views(DefaultBoxes(/*with_person=*/true), 16, /*masks=*/true);
  Mapper uninterrupted(BoxWorldOptions()), first(BoxWorldOptions()), resumed(BoxWorldOptions());
  std::vector<ObjectEventOut> events_a, events_c;
  uninterrupted.SetEventListener(
      [&](const auto& e) { events_a.insert(events_a.end(), e.begin(), e.end()); });
  for (const auto& kf : views) uninterrupted.Integrate(kf);

  for (int i = 0; i < 11; ++i) {
    first.Integrate(views[i]);
    if (i == 4) {
      EXPECT_TRUE(first.SaveCheckpoint().empty()) << "the frame is not settled yet";
    }
  }
  const std::string checkpoint = first.SaveCheckpoint();
  ASSERT_FALSE(checkpoint.empty());
  ASSERT_TRUE(resumed.LoadCheckpoint(checkpoint).ok());
  EXPECT_EQ(resumed.last_keyframe_id(), 11);
  ExpectSameMap(first, resumed, 1e-9);
  const size_t events_before_resume = events_a.size();
  resumed.SetEventListener(
      [&](const auto& e) { events_c.insert(events_c.end(), e.begin(), e.end()); });
  for (size_t i = 11; i < views.size(); ++i) resumed.Integrate(views[i]);
  ExpectSameMap(uninterrupted, resumed, 1e-3);
  EXPECT_FALSE(events_c.empty());
  EXPECT_LT(events_c.size(), events_before_resume);
}

// The pose graph's object landmarks (Mapper::SeenCentroids): each view of a small confirmed
// object gives its centre in the keyframe frame, which the keyframe's pose puts near the fused
// centroid; a size limit leaves the laptop (0.35 m) out; a checkpoint keeps them.
TEST(MapCheckpoint, EachViewsObjectCentroidIsKeptForTheLandmarks) {
  const auto views = Views(DefaultBoxes(/*with_person=*/false), 16, /*masks=*/true);
  Mapper mapper(BoxWorldOptions());
  for (const auto& kf : views) mapper.Integrate(kf);
  std::map<int64_t, MapObject> objects;
  for (const MapObject& o : mapper.Snapshot(true)) objects[o.id] = o;
  std::map<int64_t, SE3d> T_map_kf;
  for (const auto& k : mapper.KeyframePoses()) {
    T_map_kf[k.keyframe_id] = mapper.MapFromBaseFrame() * k.T_base_kf;
  }
  const auto seen = mapper.SeenCentroids(0.6);
  std::map<std::string, int> views_of;
  for (const Mapper::SeenCentroid& c : seen) {
    ASSERT_TRUE(objects.count(c.object_id)) << "not a confirmed object: " << c.object_id;
    const MapObject& o = objects.at(c.object_id);
    ++views_of[o.class_name];
    EXPECT_LT((T_map_kf.at(c.keyframe_id) * c.c_kf_m - o.centroid_m).norm(), 0.05)
        << o.class_name << " from keyframe " << c.keyframe_id;
  }
  EXPECT_GE(views_of["book"], 8);
  EXPECT_GE(views_of["cup"], 8);
  EXPECT_GE(views_of["laptop"], 8);
  for (const Mapper::SeenCentroid& c : mapper.SeenCentroids(0.3)) {
    EXPECT_NE(objects.at(c.object_id).class_name, "laptop");
  }
  Mapper resumed(BoxWorldOptions());
  ASSERT_TRUE(resumed.LoadCheckpoint(mapper.SaveCheckpoint()).ok());
  const auto again = resumed.SeenCentroids(0.6);
  ASSERT_EQ(again.size(), seen.size());
  for (size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(again[i].keyframe_id, seen[i].keyframe_id);
    EXPECT_EQ(again[i].object_id, seen[i].object_id);
    EXPECT_LT((again[i].c_kf_m - seen[i].c_kf_m).norm(), 1e-6);
  }
}

TEST(MapCheckpoint, RefusesACheckpointOfOtherOptionsOrBrokenBytes) {
  const auto views = Views(DefaultBoxes(false), 11, true);
  Mapper mapper(BoxWorldOptions());
  for (const auto& kf : views) mapper.Integrate(kf);
  const std::string checkpoint = mapper.SaveCheckpoint();
  MapOptions other = BoxWorldOptions();
  ASSERT_TRUE(other.FromYaml(YAML::Load("fusion: {containment: 0.7}")).ok());
  EXPECT_NE(other.MapFingerprint(), mapper.options().MapFingerprint());
  EXPECT_EQ(other.ProductsFingerprint(), mapper.options().ProductsFingerprint());
  Mapper with_other(other);
  EXPECT_EQ(with_other.LoadCheckpoint(checkpoint).code(), absl::StatusCode::kFailedPrecondition);
  Mapper broken(BoxWorldOptions());
  EXPECT_EQ(broken.LoadCheckpoint(checkpoint.substr(0, checkpoint.size() / 3)).code(),
            absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace loci::server

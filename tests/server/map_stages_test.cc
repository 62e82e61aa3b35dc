// Unit tests of the map stages: back-projection, pixel labels, filters, overlap,
// label fusion, association and merging.
#include <gtest/gtest.h>
#include <pcl/filters/voxel_grid.h>

#include <numeric>
#include <opencv2/imgproc.hpp>
#include <random>
#include <unordered_map>

#include "server/map/fused_object.h"
#include "server/map/grid_outlier_filter.h"
#include "server/map/keyframe_products.h"
#include "server/map/label_distribution.h"
#include "server/map/object_eval.h"
#include "server/map/object_map.h"
#include "server/map/voxel_filter.h"

namespace loci::server {
namespace {

TEST(BackProject, PlaneAtKnownDepthLandsOnThePlane) {
  const PinholeCamera cam = PinholeCamera::TumFr1();
  cv::Mat depth(cam.height_px, cam.width_px, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 10, 10)).setTo(0.0f);   // no reading
  depth(cv::Rect(20, 0, 10, 10)).setTo(5.0f);  // beyond max range
  cv::Mat bgr(depth.size(), CV_8UC3, cv::Scalar(10, 20, 30));
  cv::Mat labels(depth.size(), CV_16SC1, cv::Scalar(0));
  labels(cv::Rect(100, 100, 20, 20)).setTo(3);
  labels(cv::Rect(300, 300, 10, 10)).setTo(kExcludedLabel);
  const auto cloud = BackProject(bgr, depth, labels, cam, 1, 0.1, 4.0);
  EXPECT_EQ(cloud.size(), 640u * 480u - 200u - 100u);
  int labelled = 0;
  for (const auto& p : cloud) {
    ASSERT_FLOAT_EQ(p.z, 2.0f);
    labelled += p.label == 3;
  }
  EXPECT_EQ(labelled, 400);
  // Pixel (u, v) = (cx + fx, cy) at depth 2 is 2 m to the right.
  const Eigen::Vector3d p = cam.BackProject(cam.cx + cam.fx, cam.cy, 2.0);
  EXPECT_NEAR(p.x(), 2.0, 1e-12);
  EXPECT_EQ(cloud[0].r, 30);  // BGR in, RGB out
  EXPECT_EQ(BackProject(bgr, depth, labels, cam, 2, 0.1, 4.0).size(), 320u * 240u - 50u - 25u);
}

Detection2D Det(const std::string& class_name, cv::Rect2f box) {
  Detection2D d;
  d.class_name = class_name;
  d.score = 0.9f;
  d.box_px = box;
  return d;
}

TEST(LabelPixels, SegmentsBoxesWithoutMaskAndExcludesDynamicBoxes) {
  const PinholeCamera cam = PinholeCamera::TumFr1();
  cv::Mat depth(cam.height_px, cam.width_px, CV_32FC1, cv::Scalar(3.0f));  // wall
  depth(cv::Rect(100, 100, 80, 60)).setTo(1.5f);                           // a monitor
  const std::vector<Detection2D> dets = {Det("tv", {90, 90, 100, 80}),
                                         Det("person", {400, 100, 50, 200})};
  MapOptions options;
  const cv::Mat labels = LabelPixels(depth, dets, options, cam, std::nullopt);
  EXPECT_EQ(cv::countNonZero(labels == 1), 80 * 60);  // the monitor, not the wall around it
  EXPECT_EQ(labels.at<int16_t>(130, 140), 1);
  EXPECT_EQ(labels.at<int16_t>(95, 95), kBackgroundLabel);
  EXPECT_EQ(cv::countNonZero(labels == kExcludedLabel), 50 * 200);  // dynamic: whole box
}

TEST(LabelPixels, LeavesOutTheSupportUnderAnObjectWithGravity) {
  // Camera 0.6 m above a table, looking down 40 deg; a 3 cm slab (a keyboard) on the table.
  const PinholeCamera cam = PinholeCamera::TumFr1();
  const double tilt = 40.0 * M_PI / 180.0;
  const Vec3d up(0, -std::cos(tilt), -std::sin(tilt));  // cam frame: y down, z forward
  cv::Mat depth(cam.height_px, cam.width_px, CV_32FC1, cv::Scalar(0.0f));
  cv::Mat truth = cv::Mat::zeros(depth.size(), CV_8UC1);
  for (int v = 0; v < cam.height_px; ++v) {
    for (int u = 0; u < cam.width_px; ++u) {
      const Vec3d ray = cam.BackProject(u, v, 1.0);
      const double table_z = -0.6 / up.dot(ray);
      if (!(table_z > 0)) continue;
      depth.at<float>(v, u) = static_cast<float>(table_z);
      const Vec3d p = table_z * ray;  // on the table; the slab spans 40 x 20 cm around (0, 0.5)
      const Vec3d right(1, 0, 0), fwd = up.cross(right);  // horizontal, away from the camera
      const Vec3d d = p - (-0.6 * up + 0.8 * fwd);        // from the slab centre
      if (std::abs(d.dot(right)) < 0.2 && std::abs(d.dot(fwd)) < 0.1) {
        depth.at<float>(v, u) = static_cast<float>(-0.57 / up.dot(ray));  // slab top, 3 cm up
        truth.at<uint8_t>(v, u) = 255;
      }
    }
  }
  const cv::Rect object = cv::boundingRect(truth);
  ASSERT_GT(object.area(), 2000);
  const cv::Rect2f box(object.x - 12, object.y - 12, object.width + 24, object.height + 24);
  MapOptions options;
  const cv::Mat with = LabelPixels(depth, {Det("keyboard", box)}, options, cam, -up);
  const cv::Mat without = LabelPixels(depth, {Det("keyboard", box)}, options, cam, std::nullopt);
  options.observation.mask.remove_support_plane = false;
  const cv::Mat no_planes = LabelPixels(depth, {Det("keyboard", box)}, options, cam, -up);
  const auto iou = [&](const cv::Mat& labels) {
    return static_cast<double>(cv::countNonZero((labels == 1) & truth)) /
           cv::countNonZero((labels == 1) | truth);
  };
  std::printf("keyboard on a table: IoU %.3f with gravity, %.3f without, %.3f no plane removal\n",
              iou(with), iou(without), iou(no_planes));
  EXPECT_GT(iou(with), 0.9);  // the table plane continues past the box: left out
  EXPECT_GT(iou(without), 0.9);
  EXPECT_LT(iou(no_planes), iou(with));
}

// An upright panel w x h m, 2 m in front of a wall 3 m away, seen by a level camera (y down).
cv::Mat PanelBeforeWall(const PinholeCamera& cam, double w_m, double h_m, cv::Rect* panel_px) {
  const int w = static_cast<int>(w_m * cam.fx / 2.0), h = static_cast<int>(h_m * cam.fy / 2.0);
  *panel_px = cv::Rect(320 - w / 2, 240 - h / 2, w, h);
  cv::Mat depth(cam.height_px, cam.width_px, CV_32FC1, cv::Scalar(3.0f));
  depth(*panel_px).setTo(2.0f);
  return depth;
}

TEST(ClassSizePriors, AViewTallerThanItsClassIsNotFusedWhenGravityIsKnown) {
  const PinholeCamera cam = PinholeCamera::TumFr1();
  const cv::Mat bgr(cam.height_px, cam.width_px, CV_8UC3, cv::Scalar(90, 90, 90));
  const Vec3d gravity_cam(0, 9.81, 0);  // level camera: down is +y
  MapOptions options;
  options.max_height_m = {{"laptop", 0.45}};
  const auto observations = [&](double h_m, const std::string& class_name,
                                const std::optional<Vec3d>& gravity) {
    cv::Rect panel;
    const cv::Mat depth = PanelBeforeWall(cam, 0.5, h_m, &panel);
    const cv::Rect2f box(panel.x - 8, panel.y - 8, panel.width + 16, panel.height + 16);
    return BuildKeyframeProducts(bgr, depth, cam, {Det(class_name, box)}, options, gravity)
        .observations.size();
  };
  EXPECT_EQ(observations(0.6, "laptop", gravity_cam), 0u);  // a 0.6 m tall "laptop"
  EXPECT_EQ(observations(0.6, "laptop", std::nullopt), 1u);  // no gravity: no height known
  EXPECT_EQ(observations(0.6, "tv", gravity_cam), 1u);       // no limit for the class
  EXPECT_EQ(observations(0.3, "laptop", gravity_cam), 1u);   // an open laptop's height
}

TEST(Filters, VoxelFilterKeepsMajorityLabelAndOutlierRemovalDropsStrayPoints) {
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.f, 0.2f);
  for (int i = 0; i < 4000; ++i) {
    pcl::PointXYZRGBL p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = 1.0f;
    p.label = 2;
    cloud.push_back(p);
  }
  const auto voxelised = VoxelFilterLabelled(cloud, 0.02);
  EXPECT_NEAR(static_cast<double>(voxelised.size()), 100.0, 5.0);  // 10 x 10 voxels
  for (const auto& p : voxelised) EXPECT_EQ(p.label, 2u);

  auto with_outliers = voxelised;
  pcl::PointXYZRGBL far;
  far.x = 1.0f;
  far.y = 1.0f;
  far.z = 2.0f;
  with_outliers.push_back(far);
  far.x = -1.0f;
  with_outliers.push_back(far);
  const auto filtered = RemoveOutliers(with_outliers, 8, 1.0);
  for (const auto& p : filtered) EXPECT_LT(p.x, 0.5f);
  EXPECT_GE(filtered.size(), voxelised.size() * 8 / 10);  // the plane itself survives
}

// A voxelised noisy surface (a wall and a box corner) with stray points around it.
pcl::PointCloud<pcl::PointXYZRGBL> SurfaceWithStrays(double voxel_m) {
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.003f);
  for (int i = 0; i < 30000; ++i) {
    pcl::PointXYZRGBL p;
    p.x = u(rng) * 1.5f;
    p.y = u(rng) * 1.0f;
    p.z = (p.x > 1.0f ? 2.0f - 0.5f * (p.x - 1.0f) : 2.0f) + noise(rng);
    cloud.push_back(p);
  }
  for (int i = 0; i < 60; ++i) {  // strays up to 0.6 m off the surface
    pcl::PointXYZRGBL p;
    p.x = u(rng) * 1.5f;
    p.y = u(rng) * 1.0f;
    p.z = 2.0f - 0.6f * u(rng);
    cloud.push_back(p);
  }
  return VoxelFilterLabelled(cloud, voxel_m);
}

TEST(Filters, GridOutlierRemovalEqualsPclStatisticalOutlierRemoval) {
  for (double voxel_m : {0.01, 0.04}) {
    const auto cloud = SurfaceWithStrays(voxel_m);
    ASSERT_GT(cloud.size(), 500u);
    // Exact K nearest neighbours whatever the grid cell (a tenth or ten times the voxel).
    const std::vector<float> d = MeanNeighbourDistances(cloud, 8, voxel_m);
    for (double cell_m : {voxel_m * 0.1, voxel_m * 10}) {
      const std::vector<float> other = MeanNeighbourDistances(cloud, 8, cell_m);
      for (size_t i = 0; i < cloud.size(); i += 37) ASSERT_NEAR(other[i], d[i], 1e-6);
    }
    for (size_t i = 0; i < cloud.size(); i += 53) {  // brute force
      std::vector<float> all;
      for (size_t j = 0; j < cloud.size(); ++j) {
        if (j != i) all.push_back((cloud[j].getVector3fMap() - cloud[i].getVector3fMap()).norm());
      }
      std::partial_sort(all.begin(), all.begin() + 8, all.end());
      ASSERT_NEAR(d[i], std::accumulate(all.begin(), all.begin() + 8, 0.0) / 8, 1e-6);
    }
    const auto pcl_kept = RemoveOutliers(cloud, 8, 1.0);
    const auto grid_kept = RemoveOutliersOnGrid(cloud, 8, 1.0, voxel_m);
    ASSERT_LT(pcl_kept.size(), cloud.size());  // strays go
    ASSERT_EQ(grid_kept.size(), pcl_kept.size());
    for (size_t i = 0; i < grid_kept.size(); ++i) {
      ASSERT_EQ(grid_kept[i].getVector3fMap(), pcl_kept[i].getVector3fMap()) << i;
    }
  }
}

TEST(Filters, OutlierFloorKeepsTheRimOfACleanSurfaceAndDropsStrays) {
  // A 20 x 20 cm square at 1 cm voxels plus two strays 10 cm off it.
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) {
      pcl::PointXYZRGB p;
      p.x = 0.005f + 0.01f * i;
      p.y = 0.005f + 0.01f * j;
      p.z = 1.0f;
      cloud.push_back(p);
    }
  }
  for (float x : {-0.1f, 0.3f}) {
    pcl::PointXYZRGB p;
    p.x = x;
    p.y = 0.1f;
    p.z = 1.1f;
    cloud.push_back(p);
  }
  // Eq. 18 alone trims the rim of the clean square (its points have fewer close neighbours)...
  pcl::PointCloud<pcl::PointXYZRGB> square;
  for (int i = 0; i < 400; ++i) square.push_back(cloud[i]);
  const auto plain = RemoveOutliersOnGrid(square, 10, 1.0, 0.01);
  float plain_max_x = 0;
  for (const auto& p : plain) plain_max_x = std::max(plain_max_x, p.x);
  EXPECT_LT(plain_max_x, 0.19f);
  EXPECT_EQ(RemoveOutliersOnGrid(square, 10, 1.0, 0.01, 0.03).size(), 400u);
  // ... with the floor of 3 voxels the whole square stays and only the strays go.
  const auto kept = RemoveOutliersOnGrid(cloud, 10, 1.0, 0.01, 0.03);
  EXPECT_EQ(kept.size(), 400u);
  for (const auto& p : kept) EXPECT_FLOAT_EQ(p.z, 1.0f);
}

TEST(Filters, VoxelAverageEqualsPclVoxelGrid) {
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-0.3f, 0.5f);
  std::uniform_int_distribution<int> c(0, 255);
  for (int i = 0; i < 20000; ++i) {
    pcl::PointXYZRGB p(static_cast<uint8_t>(c(rng)), static_cast<uint8_t>(c(rng)),
                       static_cast<uint8_t>(c(rng)));
    p.x = u(rng);
    p.y = u(rng);
    p.z = 1.0f + 0.1f * u(rng);
    cloud.push_back(p);
  }
  pcl::PointCloud<pcl::PointXYZRGB> expected;
  pcl::VoxelGrid<pcl::PointXYZRGB> grid;
  grid.setInputCloud(cloud.makeShared());
  grid.setLeafSize(0.03f, 0.03f, 0.03f);
  grid.filter(expected);
  const auto got = VoxelAverage(cloud, 0.03);
  ASSERT_EQ(got.size(), expected.size());
  auto key = [](const pcl::PointXYZRGB& p) {
    return KeyOf(p.getVector3fMap().cast<double>(), 0.03);
  };
  VoxelMap<pcl::PointXYZRGB> by_voxel;
  for (const auto& p : expected) by_voxel[key(p)] = p;
  for (const auto& p : got) {
    ASSERT_EQ(by_voxel.count(key(p)), 1u);
    const auto& e = by_voxel[key(p)];
    EXPECT_LT((p.getVector3fMap() - e.getVector3fMap()).norm(), 1e-5);
    EXPECT_NEAR(p.r, e.r, 1);  // PCL averages colour in float and rounds down too
    EXPECT_NEAR(p.g, e.g, 1);
    EXPECT_NEAR(p.b, e.b, 1);
  }
}

VoxelSet CubeKeys(double x0, int n) {
  VoxelSet keys;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      keys.insert(KeyOf(Eigen::Vector3d(x0 + 0.01 * i + 0.005, 0.01 * j + 0.005, 0), 0.01));
  return keys;
}

TEST(Overlap, IntersectionOverUnionAndContainment) {
  const auto a = CubeKeys(0.0, 10);   // 100 voxels
  const auto b = CubeKeys(0.05, 10);  // shifted by half: 50 shared
  EXPECT_NEAR(VoxelOverlap(a, a), 1.0, 1e-12);
  EXPECT_NEAR(VoxelOverlap(a, b), 50.0 / 150.0, 1e-12);
  EXPECT_NEAR(VoxelContainment(a, CubeKeys(0.0, 5)), 1.0, 1e-12);
  EXPECT_EQ(VoxelOverlap(a, CubeKeys(1.0, 10)), 0.0);
  EXPECT_EQ(VoxelOverlap({}, {}), 0.0);
}

TEST(LabelDistribution, BayesUpdateFavoursRepeatedEvidence) {
  LabelDistribution d(13, 0.05);
  d.Update("teddy bear", 0.8);
  EXPECT_EQ(d.Argmax(), "teddy bear");
  EXPECT_NEAR(d.Probability("teddy bear"), 0.8, 1e-9);  // uniform prior, one measurement
  d.Update("person", 0.6);                              // the misdetection of paper 000
  d.Update("teddy bear", 0.7);
  EXPECT_EQ(d.Argmax(), "teddy bear");
  const double p_teddy = d.Probability("teddy bear"), p_person = d.Probability("person");
  EXPECT_GT(p_teddy, 0.8);
  EXPECT_GT(p_person, d.Probability("cup"));  // seen once beats never seen
  const auto observed = d.Observed();
  ASSERT_EQ(observed.size(), 2u);
  EXPECT_EQ(observed[0].first, "teddy bear");
  EXPECT_NEAR(observed[0].second + observed[1].second, 1.0, 1e-12);
  // Independent evidence of a duplicate sharpens the posterior.
  LabelDistribution e(13, 0.05);
  e.Update("teddy bear", 0.7);
  d.Merge(e);
  EXPECT_GT(d.Probability("teddy bear"), p_teddy);
}

MapObservation Obs(int64_t track, const Eigen::Vector3d& center, double half, int64_t kf,
                   const std::string& cls = "cup") {
  MapObservation o;
  o.session_row = 1;
  o.robot = "r";
  o.keyframe_id = kf;
  o.t_ns = kf * 300'000'000;  // keyframes 0.3 s apart
  o.track_id = track;
  o.class_name = cls;
  o.score = 0.9;
  for (double x = -half; x <= half + 1e-9; x += 0.01)
    for (double y = -half; y <= half + 1e-9; y += 0.01)
      o.points_m.push_back({(center + Eigen::Vector3d(x, y, 0)).cast<float>(), 0});
  o.centroid_m = center;
  o.half_size_m = half;
  return o;
}

TEST(ObjectMap, AssociatesByTrackOrCentroidElseCreatesAndConfirmsAfterThreeIndependentViews) {
  FusionOptions opt;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const auto a = map.Integrate({Obs(1, {0, 0, 1}, 0.05, 1)}, &changes);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, ObjectChange::Kind::kCreated);
  EXPECT_FALSE(map.Find(a[0])->confirmed());
  // Same track, 0.2 m away (beyond the centroid criterion, inside the track gate).
  const auto b = map.Integrate({Obs(1, {0.2, 0, 1}, 0.05, 2)}, &changes);
  EXPECT_EQ(b[0], a[0]);
  EXPECT_FALSE(map.Find(a[0])->confirmed());  // 0.3 s after the first: the same evidence
  // No track, 2 cm from the fused centroid, a compatible size: the centroid criterion, 0.6 s
  // after the first.
  const auto c = map.Integrate({Obs(0, {0.12, 0, 1}, 0.10, 3)}, &changes);
  EXPECT_EQ(c[0], a[0]);
  EXPECT_FALSE(map.Find(a[0])->confirmed());  // two independent views
  const auto c2 = map.Integrate({Obs(0, {0.11, 0, 1}, 0.10, 5)}, &changes);
  EXPECT_EQ(c2[0], a[0]);
  EXPECT_TRUE(map.Find(a[0])->confirmed());
  EXPECT_EQ(map.Find(a[0])->observation_count(), 4u);
  // Far away, other track: a new candidate.
  const auto d = map.Integrate({Obs(2, {2, 0, 1}, 0.05, 6)}, &changes);
  EXPECT_NE(d[0], a[0]);
  EXPECT_EQ(map.size(), 2u);
  EXPECT_EQ(map.confirmed_count(), 1u);
  // Track match beyond the gate does not associate.
  const auto e = map.Integrate({Obs(1, {5, 0, 1}, 0.05, 7)}, &changes);
  EXPECT_NE(e[0], a[0]);
}

TEST(ObjectMap, MergesDuplicatesThatEndUpOverlapping) {
  FusionOptions opt;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const auto a = map.Integrate({Obs(1, {0, 0, 1}, 0.10, 1)}, &changes);
  const MapObservation far = Obs(2, {1.0, 0, 1}, 0.10, 2);
  const auto b = map.Integrate({far}, &changes);
  ASSERT_NE(b[0], a[0]);
  // A pose correction moves the second view to 4 cm from the first: the box centres are closer
  // than centroid_gate_m, so the newer object is absorbed into the older one.
  MapObservation moved = Obs(2, {0.04, 0, 1}, 0.10, 2);
  ASSERT_TRUE(map.MoveObservation(b[0], far.points_m, moved.points_m, "cup"));
  map.MergeMoved({b[0]}, &changes);
  EXPECT_EQ(map.Resolve(b[0]), a[0]);
  EXPECT_EQ(map.size(), 1u);
  // A MERGED change for the survivor, then a REMOVED one with the absorbed object's last state.
  ASSERT_GE(changes.size(), 2u);
  const ObjectChange& merged = changes[changes.size() - 2];
  const ObjectChange& removed = changes.back();
  EXPECT_EQ(merged.kind, ObjectChange::Kind::kMerged);
  EXPECT_EQ(merged.object_id, a[0]);
  EXPECT_EQ(map.Resolve(merged.merged_from_id), a[0]);
  EXPECT_EQ(removed.kind, ObjectChange::Kind::kRemoved);
  EXPECT_EQ(removed.object_id, merged.merged_from_id);
  EXPECT_EQ(removed.removed_state.id, merged.merged_from_id);
  EXPECT_NEAR(removed.removed_state.centroid_m.x(), 0.04, 0.006);
  EXPECT_EQ(map.Find(removed.object_id), nullptr);
  // A small object of another class lying on it is neither associated nor merged (sizes 5x
  // apart)...
  const auto m = map.Integrate({Obs(3, {0.0, 0, 1}, 0.02, 3, "mouse")}, &changes);
  EXPECT_NE(m[0], a[0]);
  EXPECT_EQ(map.size(), 2u);
  // ... while a same-sized object of another class at the same place is the same object under a
  // confusable label: it merges, and the label distribution keeps the majority class.
  const auto l = map.Integrate({Obs(4, {0.01, 0, 1}, 0.10, 4, "book")}, &changes);
  EXPECT_EQ(l[0], a[0]);
  EXPECT_EQ(map.size(), 2u);
  EXPECT_EQ(map.Find(a[0])->labels().Argmax(), "cup");
}

TEST(ObjectEval, CountErrorMatchingFalsePositivesAndMisses) {
  GroundTruthScene gt;
  auto add_gt = [&](int64_t id, const std::string& cls, Eigen::Vector3d c, bool dynamic = false) {
    GroundTruthObject o;
    o.id = id;
    o.class_name = cls;
    o.centroid_m = c;
    o.dynamic = dynamic;
    gt.objects.push_back(o);
  };
  add_gt(1, "cup", {0, 0, 0});
  add_gt(2, "cup", {1, 0, 0});
  add_gt(3, "book", {0, 1, 0});
  add_gt(4, "person", {5, 5, 0}, /*dynamic=*/true);  // never evaluated
  auto obj = [](int64_t id, const std::string& cls, Eigen::Vector3d c) {
    MapObject o;
    o.id = id;
    o.class_name = cls;
    o.centroid_m = c;
    return o;
  };
  const std::vector<MapObject> found = {obj(10, "cup", {0.01, 0, 0}),  // -> gt 1
                                        obj(11, "cup", {0.98, 0, 0}),  // -> gt 2
                                        obj(12, "book", {2, 2, 0}),    // too far: FP
                                        obj(13, "chair", {0, 1, 0})};  // wrong class: FP
  const ObjectEvalResult r = EvaluateObjects(found, gt, ObjectEvalOptions{});
  EXPECT_EQ(r.gt_count, 3);
  EXPECT_EQ(r.detected_count, 4);
  EXPECT_NEAR(r.count_error, 1.0 / 3.0, 1e-12);  // |4 - 3| / 3, eq. 24
  ASSERT_EQ(r.matches.size(), 2u);
  EXPECT_NEAR(r.max_centroid_error_m, 0.02, 1e-9);
  EXPECT_NEAR(r.mean_centroid_error_m, 0.015, 1e-9);
  EXPECT_EQ(r.missed_gt_ids, std::vector<int64_t>{3});
  EXPECT_EQ(r.false_positive_ids.size(), 2u);
  ObjectEvalOptions only_cups;
  only_cups.classes = {"cup"};
  const ObjectEvalResult c = EvaluateObjects(found, gt, only_cups);
  EXPECT_EQ(c.count_error, 0.0);
  EXPECT_TRUE(c.missed_gt_ids.empty() && c.false_positive_ids.empty());
}

// Hand-made ground truth: Hungarian matching (not greedy), `low` objects neutral, the nearer of
// centroid and visible-part centre, precision / recall / F1.
TEST(ObjectEval, HungarianLowConfidenceAndVisiblePart) {
  GroundTruthScene gt;
  auto add = [&](int64_t id, const std::string& name, const std::string& cls, Eigen::Vector3d c,
                 const std::string& confidence) {
    GroundTruthObject o;
    o.id = id;
    o.name = name;
    o.class_name = cls;
    o.centroid_m = c;
    o.confidence = confidence;
    gt.objects.push_back(o);
    return &gt.objects.back();
  };
  add(1, "cup_a", "cup", {0, 0, 0}, "high");
  add(2, "cup_b", "cup", {0.25, 0, 0}, "medium");
  add(3, "cup_far", "cup", {3, 0, 0}, "low");
  add(4, "desk", "dining table", {0, 0, 0.4}, "high")->visible_part_centroid_m =
      Eigen::Vector3d(0, 0, 0.75);
  add(5, "book_low", "book", {5, 5, 0}, "low");  // missed but not counted
  auto obj = [](int64_t id, const std::string& cls, Eigen::Vector3d c) {
    MapObject o;
    o.id = id;
    o.class_name = cls;
    o.centroid_m = c;
    return o;
  };
  // Greedy would give #10 (0.12 from cup_a, 0.13 from cup_b) to cup_a and leave #11 (0.2 from
  // cup_a, 0.45 from cup_b) unmatched; the optimal assignment matches both.
  const std::vector<MapObject> found = {obj(10, "cup", {0.12, 0, 0}), obj(11, "cup", {-0.2, 0, 0}),
                                        obj(12, "cup", {3.05, 0, 0}),  // -> low: neutral
                                        obj(13, "dining table", {0, 0, 0.72}),  // visible part
                                        obj(14, "laptop", {1, 1, 1})};          // FP
  const ObjectEvalResult r = EvaluateObjects(found, gt, ObjectEvalOptions{});
  EXPECT_EQ(r.gt_count, 3);
  EXPECT_EQ(r.true_positives, 3);
  EXPECT_EQ(r.detected_count, 4);  // 3 TP + 1 FP; the neutral match is not counted
  EXPECT_NEAR(r.precision, 0.75, 1e-12);
  EXPECT_NEAR(r.recall, 1.0, 1e-12);
  EXPECT_NEAR(r.f1, 2 * 0.75 / 1.75, 1e-12);
  EXPECT_NEAR(r.count_error, 1.0 / 3.0, 1e-12);
  EXPECT_EQ(r.false_positive_ids, std::vector<int64_t>{14});
  EXPECT_TRUE(r.missed_gt_names.empty());
  int neutral = 0;
  for (const ObjectMatch& m : r.matches) neutral += m.neutral;
  EXPECT_EQ(neutral, 1);
  // Errors 0.2 (cup_a <- #11), 0.13 (cup_b <- #10), 0.03 (desk top).
  EXPECT_NEAR(r.mean_centroid_error_m, (0.2 + 0.13 + 0.03) / 3, 1e-9);
  EXPECT_NEAR(r.median_centroid_error_m, 0.13, 1e-9);
  // Each match's offset is taken from the point it was compared with (the desk: its top).
  int checked = 0;
  for (const ObjectMatch& m : r.matches) {
    if (m.object_id == 13) {
      EXPECT_TRUE(m.offset_m.isApprox(Eigen::Vector3d(0, 0, -0.03)));
      ++checked;
    }
    if (m.object_id == 10) {
      EXPECT_TRUE(m.offset_m.isApprox(Eigen::Vector3d(-0.13, 0, 0)));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 2);
}

// A `low` object is placed only to +-0.2 m: a map object within the radius plus that tolerance
// is neutral; one beyond it, or a high object's neighbour at the same distance, is not.
TEST(ObjectEval, LowObjectsMatchWithinTheirTolerance) {
  GroundTruthScene gt;
  GroundTruthObject chair;
  chair.id = 1;
  chair.name = "chair_far";
  chair.class_name = "chair";
  chair.centroid_m = Eigen::Vector3d(3, 0, 0);
  chair.confidence = "low";
  gt.objects.push_back(chair);
  chair.id = 2;
  chair.name = "chair_near";
  chair.centroid_m = Eigen::Vector3d(0, 0, 0);
  chair.confidence = "high";
  gt.objects.push_back(chair);
  auto chair_at = [](int64_t id, double x_m, double y_m) {
    MapObject o;
    o.id = id;
    o.class_name = "chair";
    o.centroid_m = Eigen::Vector3d(x_m, y_m, 0);
    return o;
  };
  const std::vector<MapObject> found = {chair_at(10, 3.45, 0), chair_at(11, 0, 0.45)};
  const ObjectEvalResult r = EvaluateObjects(found, gt, ObjectEvalOptions{});
  EXPECT_EQ(r.false_positive_ids, std::vector<int64_t>{11});
  ASSERT_EQ(r.matches.size(), 1u);
  EXPECT_TRUE(r.matches[0].neutral);
  EXPECT_EQ(r.matches[0].object_id, 10);
  ObjectEvalOptions strict;
  strict.low_tolerance_m = 0;
  const ObjectEvalResult s = EvaluateObjects(found, gt, strict);
  EXPECT_EQ(s.false_positive_ids.size(), 2u);
  EXPECT_TRUE(s.matches.empty());
}

}  // namespace
}  // namespace loci::server

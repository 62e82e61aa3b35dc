// One detector box over two books side by side (observation.object_tops): a view gives one
// observation per book top when the tops differ in height by a step; tops 1.2 cm apart and a lone
// book with a small thing on it stay one observation.
#include <gtest/gtest.h>

#include <algorithm>

#include "server/map/keyframe_products.h"
#include "tests/server/box_world.h"

namespace loci::server {
namespace {

using testing::LookAt;
using testing::Render;
using testing::RenderedView;
using testing::WorldBox;

// A desk (top at 0.75 m) with things on it, seen from 1.1 m away, 40 deg down.
struct DeskView {
  RenderedView view;
  SE3d T_world_cam;
  Vec3d gravity_cam;
};

DeskView SeeDesk(std::vector<WorldBox> on_desk) {
  on_desk.push_back({9, "dining table", {-0.6, -0.4, 0.0}, {0.6, 0.5, 0.75}, {120, 120, 120}});
  DeskView d;
  d.T_world_cam = LookAt({0.0, -0.85, 1.45}, {0.0, 0.05, 0.75});
  d.view = Render(on_desk, PinholeCamera::TumFr1(), d.T_world_cam, /*with_masks=*/false);
  d.gravity_cam = d.T_world_cam.rotation().transpose() * Vec3d(0, 0, -9.81);
  return d;
}

// One "book" box over the boxes of the detections of these track ids, 10 px looser.
Detection2D BoxOver(const std::vector<Detection2D>& detections, const std::vector<int64_t>& ids) {
  Detection2D out;
  out.class_name = "book";
  out.score = 0.6f;
  out.track_id = 77;
  for (const Detection2D& d : detections) {
    if (std::find(ids.begin(), ids.end(), d.track_id) == ids.end()) continue;
    out.box_px = out.box_px.area() > 0 ? (out.box_px | d.box_px) : d.box_px;
  }
  out.box_px = cv::Rect2f(out.box_px.x - 10, out.box_px.y - 10, out.box_px.width + 20,
                          out.box_px.height + 20);
  return out;
}

// The book observations' centroids in the world frame.
std::vector<Vec3d> BookCentroidsWorld(const DeskView& d, const Detection2D& box,
                                      const MapOptions& options) {
  const KeyframeProducts products = BuildKeyframeProducts(
      d.view.bgr, d.view.depth_m, PinholeCamera::TumFr1(), {box}, options, d.gravity_cam);
  std::vector<Vec3d> out;
  for (const ObjectObservation& o : products.observations) {
    Vec3d sum = Vec3d::Zero();
    for (const auto& p : o.cloud_kf) sum += p.getVector3fMap().cast<double>();
    out.push_back(d.T_world_cam * (sum / static_cast<double>(o.cloud_kf.size())));
  }
  return out;
}

// Two books lying against each other, 7 and 4 cm thick (fr1_rpy's blue book and white book).
const std::vector<WorldBox> kTwoBooks = {
    {1, "book", {-0.26, -0.05, 0.75}, {0.0, 0.20, 0.82}, {200, 60, 40}},
    {2, "book", {0.0, -0.03, 0.75}, {0.25, 0.13, 0.79}, {230, 230, 230}}};

TEST(ObjectTops, OneBoxOverTwoBooksGivesOneObservationPerBook) {
  const DeskView d = SeeDesk(kTwoBooks);
  const Detection2D box = BoxOver(d.view.detections, {1, 2});
  MapOptions options;
  const std::vector<Vec3d> books = BookCentroidsWorld(d, box, options);
  ASSERT_EQ(books.size(), 2u);
  for (const WorldBox& b : kTwoBooks) {
    const Vec3d centre = 0.5 * (b.min_m + b.max_m);
    double nearest_m = 1e9;
    for (const Vec3d& c : books) nearest_m = std::min(nearest_m, (c - centre).head<2>().norm());
    EXPECT_LT(nearest_m, 0.04) << "book " << b.id;
  }
  // Off: one observation over both, its centroid between them.
  options.observation.object_tops.classes.clear();
  EXPECT_EQ(BookCentroidsWorld(d, box, options).size(), 1u);
  // Without gravity no top is known: whole.
  const KeyframeProducts no_gravity = BuildKeyframeProducts(
      d.view.bgr, d.view.depth_m, PinholeCamera::TumFr1(), {box}, MapOptions{}, std::nullopt);
  EXPECT_EQ(no_gravity.observations.size(), 1u);
}

TEST(ObjectTops, TwoTopsWithoutAStepBetweenThemStayOneObservation) {
  // Two level surfaces side by side 1.2 cm apart in height (the pages of an open book, a cover
  // and the label on it): two tops, but no step between two objects, so one observation.
  const std::vector<WorldBox> halves = {
      {1, "book", {-0.16, -0.05, 0.75}, {0.0, 0.17, 0.785}, {230, 230, 230}},
      {2, "book", {0.0, -0.05, 0.75}, {0.16, 0.17, 0.797}, {230, 230, 230}}};
  const DeskView d = SeeDesk(halves);
  const Detection2D box = BoxOver(d.view.detections, {1, 2});
  EXPECT_EQ(BookCentroidsWorld(d, box, {}).size(), 1u);
  MapOptions no_step;  // they are two tops: only the step keeps them one observation
  no_step.observation.object_tops.min_step_m = 0;
  EXPECT_EQ(BookCentroidsWorld(d, box, no_step).size(), 2u);
}

TEST(ObjectTops, ALoneBookWithAnEraserOnItStaysOneObservation) {
  const std::vector<WorldBox> book = {
      {1, "book", {-0.12, -0.05, 0.75}, {0.13, 0.15, 0.79}, {200, 60, 40}},
      {3, "eraser", {0.0, 0.02, 0.79}, {0.06, 0.08, 0.81}, {40, 40, 200}}};
  const DeskView d = SeeDesk(book);
  const std::vector<Vec3d> books = BookCentroidsWorld(d, BoxOver(d.view.detections, {1}), {});
  ASSERT_EQ(books.size(), 1u);
  EXPECT_LT((books[0] - Vec3d(0.005, 0.05, 0.77)).head<2>().norm(), 0.04);
}

}  // namespace
}  // namespace loci::server

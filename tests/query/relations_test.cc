// Relations in the gravity frame on hand-built scenes, positive and negative.
#include "query/relations.h"

#include <gtest/gtest.h>

#include "query/geometry.h"
#include "test_scene.h"

namespace loci::query {
namespace {

using testing::Box;
using testing::Office;

class RelationsTest : public ::testing::Test {
 protected:
  RelationsTest() : frame_(Vec3d::UnitZ()), eval_(RelationOptions{}) {
    for (const MapObject& o : Office()) geoms_[o.id] = frame_.Geom(o);
    view_ = *frame_.View(Viewpoint{"robot-a", testing::OfficeViewpoint(), 0});
  }
  RelationResult Eval(RelationKind kind, int64_t s, int64_t a) {
    return eval_.Evaluate(kind, geoms_.at(s), geoms_.at(a), &view_);
  }
  GravityFrame frame_;
  RelationEvaluator eval_;
  std::map<int64_t, ObjectGeom> geoms_;
  ViewpointG view_;
};

TEST_F(RelationsTest, BookOnTable) {
  const RelationResult r = Eval(RelationKind::kOn, 2, 1);
  EXPECT_TRUE(r.holds);
  EXPECT_GT(r.confidence, 0.9);
  EXPECT_NE(r.evidence.find("footprint overlap 1.00"), std::string::npos) << r.evidence;
  EXPECT_EQ(RelationName(r.kind), "on");
  // Not the other way round, not on the shelf, not on the chair it is above.
  EXPECT_FALSE(Eval(RelationKind::kOn, 1, 2).holds);
  EXPECT_FALSE(Eval(RelationKind::kOn, 2, 7).holds);
  EXPECT_TRUE(Eval(RelationKind::kOn, 8, 7).holds);
  EXPECT_FALSE(Eval(RelationKind::kOn, 5, 1).holds);
}

// A monitor's points end at its panel: 17 cm of stand lie between it and the desk. It is on the
// desk; a book 17 cm above the desk is not, and neither is a monitor a stand's height too high.
TEST_F(RelationsTest, MonitorOnItsStandIsOnTheTable) {
  ObjectGeom tv = geoms_.at(2);
  tv.class_name = "tv";
  tv.box.min.z() = geoms_.at(1).top_z + 0.17;
  tv.bottom_z = tv.box.min.z();
  tv.box.max.z() = tv.box.min.z() + 0.35;
  tv.centroid_g.z() = tv.box.min.z() + 0.175;
  const RelationResult on = eval_.Evaluate(RelationKind::kOn, tv, geoms_.at(1), nullptr, true);
  EXPECT_TRUE(on.holds) << on.evidence;
  EXPECT_NE(on.evidence.find("stands up to 0.25 m"), std::string::npos) << on.evidence;
  ObjectGeom book = tv;
  book.class_name = "book";
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, book, geoms_.at(1)).holds);
  tv.box.min.z() += 0.25;
  tv.bottom_z += 0.25;
  tv.box.max.z() += 0.25;
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, tv, geoms_.at(1)).holds);
  RelationOptions none;
  none.on_stand_m.clear();
  tv.box.min.z() -= 0.25;
  tv.bottom_z -= 0.25;
  tv.box.max.z() -= 0.25;
  EXPECT_FALSE(RelationEvaluator(none).Evaluate(RelationKind::kOn, tv, geoms_.at(1)).holds);
}

TEST_F(RelationsTest, OnToleratesSmallGapsButNotHovering) {
  ObjectGeom book = geoms_.at(2);
  book.box.min.z() += 0.02;
  book.bottom_z += 0.02;
  book.box.max.z() += 0.02;
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kOn, book, geoms_.at(1)).holds);
  book.box.min.z() += 0.2;  // 22 cm above the table top: above, not on
  book.bottom_z += 0.2;
  book.box.max.z() += 0.2;
  book.centroid_g.z() += 0.22;
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, book, geoms_.at(1)).holds);
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kAbove, book, geoms_.at(1)).holds);
  // Half off the edge: footprint overlap below on_min_overlap.
  ObjectGeom edge = geoms_.at(2);
  const double shift_m = 1.7 - edge.centroid_g.x();
  edge.box.min.x() = 1.5;
  edge.box.max.x() = 1.9;
  edge.centroid_g.x() = 1.7;
  for (Eigen::Vector2d& corner : edge.footprint_g) corner.x() += shift_m;
  const RelationResult r = eval_.Evaluate(RelationKind::kOn, edge, geoms_.at(1));
  EXPECT_FALSE(r.holds) << r.evidence;
}

// fr1_rpy, start 30: the fused box of the book on the main desk reaches 7.2 cm under the desk's
// top (its mask caught the desk's edge), while only 5 % of its points lie more than 2 cm under
// it. By its box the book hovers in the desk; by its robust bottom it lies on it.
TEST_F(RelationsTest, ABookWhoseBoxCaughtTheDesksEdgeIsOnTheDesk) {
  MapObject book = Box(30, "book", {0.2, 0.2, 0.75 - 0.072}, {0.68, 0.51, 0.75 + 0.088});
  const ObjectGeom& desk = geoms_.at(1);
  ASSERT_DOUBLE_EQ(desk.top_z, 0.75);
  const RelationResult by_box = eval_.Evaluate(RelationKind::kOn, frame_.Geom(book), desk);
  EXPECT_FALSE(by_box.holds) << by_box.confidence;
  book.bottom_z_m = 0.75 - 0.020;
  const RelationResult robust = eval_.Evaluate(RelationKind::kOn, frame_.Geom(book), desk);
  EXPECT_TRUE(robust.holds) << robust.confidence;
  EXPECT_GT(robust.confidence, 0.9);
  // A bottom outside the box is not the map's and is not used.
  book.bottom_z_m = 0.5;
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, frame_.Geom(book), desk).holds);
}

// fr1_rpy, start 0: the keyboard lies in front of the main monitor, and the map's axes run at
// about 40 deg to the desk, so their axis-aligned boxes overlap by 43 % of the keyboard's
// footprint: "is the keyboard under the tv" answered yes. Their oriented boxes do not overlap.
TEST_F(RelationsTest, AKeyboardInFrontOfAMonitorTurnedToTheMapAxesIsNotBelowIt) {
  const std::vector<MapObject> desk = testing::Rotated(
      {Box(40, "tv", {0.0, 0.0, 0.95}, {0.05, 0.55, 1.30}),
       Box(41, "keyboard", {0.15, 0.05, 0.75}, {0.30, 0.50, 0.78})},
      Eigen::AngleAxisd(0.7, Vec3d::UnitZ()).toRotationMatrix());
  ObjectGeom tv = frame_.Geom(desk[0]), keyboard = frame_.Geom(desk[1]);
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kBelow, keyboard, tv).holds);
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kAbove, tv, keyboard).holds);
  // By their boxes alone they would be.
  tv.footprint_g.clear();
  keyboard.footprint_g.clear();
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kBelow, keyboard, tv).holds);
  // A keyboard under the panel (on a shelf below it) still is below it.
  const std::vector<MapObject> under = testing::Rotated(
      {Box(42, "keyboard", {0.0, 0.05, 0.75}, {0.05, 0.50, 0.78})},
      Eigen::AngleAxisd(0.7, Vec3d::UnitZ()).toRotationMatrix());
  const RelationResult below =
      eval_.Evaluate(RelationKind::kBelow, frame_.Geom(under[0]), frame_.Geom(desk[0]));
  EXPECT_TRUE(below.holds) << below.evidence;
}

// fr1_rpy, live run 3: a piece of one desk, turned 40 deg to the map's axes, has an axis-aligned
// box that holds the book lying on the desk beside it, 3 cm higher (the book's box caught a
// centimetre of its desk's edge). By the oriented footprints the book is not on that piece; on
// a piece of its own desk it is.
TEST_F(RelationsTest, ABookBesideADeskTurnedToTheMapAxesIsNotOnIt) {
  MapObject lower = Box(50, "dining table", {-0.9, 0.0, 0.70}, {0.0, 1.5, 0.74});
  MapObject own = Box(51, "dining table", {0.0, 0.0, 0.73}, {0.8, 1.5, 0.77});
  lower.top_surface_z_m = 0.74;
  own.top_surface_z_m = 0.77;
  const std::vector<MapObject> turned = testing::Rotated(
      {lower, own, Box(52, "book", {0.08, 1.2, 0.76}, {0.32, 1.45, 0.81})},
      Eigen::AngleAxisd(40.0 * M_PI / 180, Vec3d::UnitZ()).toRotationMatrix());
  ObjectGeom lower_g = frame_.Geom(turned[0]), book = frame_.Geom(turned[2]);
  const RelationResult on_lower = eval_.Evaluate(RelationKind::kOn, book, lower_g, nullptr, true);
  EXPECT_FALSE(on_lower.holds) << on_lower.evidence;
  EXPECT_NE(on_lower.evidence.find("footprint overlap 0.00"), std::string::npos)
      << on_lower.evidence;
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kOn, book, frame_.Geom(turned[1])).holds);
  // By their axis-aligned boxes, the lower piece's box holds half the book's: it was "on" both.
  lower_g.footprint_g.clear();
  book.footprint_g.clear();
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kOn, book, lower_g).holds);
}

// fr1_rpy, start 60: two desks meet with tops about 3 cm apart, and the boxes of the two map
// pieces overlap by a few centimetres. "what is under the desk" named the other piece: its box
// top was 4 cm above the desk's bottom, within the vertical tolerance. Neither piece is under,
// below or above the other; a box on the floor under the desk is.
TEST_F(RelationsTest, ADeskPieceBesideAnotherIsNeitherUnderNorAboveIt) {
  MapObject desk = Box(60, "dining table", {0.0, 0.0, 0.72}, {0.8, 1.5, 0.78});
  desk.top_surface_z_m = 0.77;
  desk.bottom_z_m = 0.76;
  MapObject piece = Box(61, "dining table", {-0.5, 0.6, 0.71}, {0.4, 2.0, 0.80});
  piece.top_surface_z_m = 0.74;
  const ObjectGeom desk_g = frame_.Geom(desk), piece_g = frame_.Geom(piece);
  for (RelationKind kind : {RelationKind::kUnder, RelationKind::kBelow, RelationKind::kAbove}) {
    const RelationResult r = eval_.Evaluate(kind, piece_g, desk_g, nullptr, true);
    EXPECT_FALSE(r.holds) << RelationName(kind) << ": " << r.evidence;
    EXPECT_FALSE(eval_.Evaluate(kind, desk_g, piece_g).holds) << RelationName(kind);
  }
  const ObjectGeom crate = frame_.Geom(Box(62, "suitcase", {0.2, 0.4, 0.0}, {0.6, 0.9, 0.4}));
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kBelow, crate, desk_g).holds);
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kUnder, crate, desk_g).holds);
}

TEST_F(RelationsTest, NotOnATallerBoxBelowTheSurface) {
  // A chair tucked under a desk reaches above the desk top (back at 0.81 m); the keyboard on
  // the desk (0.78-0.81 m) lies over the chair's footprint but rests on the desk.
  const ObjectGeom desk = frame_.Geom(Box(20, "dining table", {0, 0, 0}, {1.2, 0.6, 0.78}));
  const ObjectGeom chair = frame_.Geom(Box(21, "chair", {0.3, -0.2, 0}, {0.75, 0.25, 0.81}));
  const ObjectGeom keyboard =
      frame_.Geom(Box(22, "keyboard", {0.35, 0.05, 0.78}, {0.79, 0.19, 0.805}));
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kOn, keyboard, desk).holds);
  const RelationResult r = eval_.Evaluate(RelationKind::kOn, keyboard, chair);
  EXPECT_FALSE(r.holds) << r.evidence;
}

TEST_F(RelationsTest, ChairUnderTable) {
  EXPECT_TRUE(Eval(RelationKind::kUnder, 5, 1).holds);
  EXPECT_FALSE(Eval(RelationKind::kUnder, 6, 1).holds);  // standing away
  EXPECT_FALSE(Eval(RelationKind::kUnder, 2, 1).holds);  // the book is on it
  EXPECT_FALSE(Eval(RelationKind::kUnder, 1, 5).holds);
}

TEST_F(RelationsTest, CupNearKeyboardNotNearMonitor) {
  const RelationResult r = Eval(RelationKind::kNear, 3, 4);
  EXPECT_TRUE(r.holds) << r.evidence;
  EXPECT_NEAR(r.distance_m, 0.26, 1e-9);
  EXPECT_FALSE(Eval(RelationKind::kNear, 3, 9).holds);
  EXPECT_FALSE(Eval(RelationKind::kNear, 3, 7).holds);
}

TEST_F(RelationsTest, NextTo) {
  EXPECT_TRUE(Eval(RelationKind::kNextTo, 11, 13).holds);  // mouse beside keyboard
  EXPECT_FALSE(Eval(RelationKind::kNextTo, 2, 1).holds);   // stacked, not side by side
  EXPECT_FALSE(Eval(RelationKind::kNextTo, 3, 7).holds);   // 2 m away
}

TEST_F(RelationsTest, Inside) {
  const MapObject drawer = Box(50, "shelf", {0, 0, 0}, {1, 1, 1});
  const MapObject bottle = Box(51, "bottle", {0.4, 0.4, 0.2}, {0.5, 0.5, 0.5});
  const ObjectGeom d = frame_.Geom(drawer);
  const ObjectGeom b = frame_.Geom(bottle);
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kInside, b, d).holds);
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kInside, d, b).holds);
  EXPECT_FALSE(Eval(RelationKind::kInside, 2, 1).holds);  // on top is not inside
  // A keyboard whose box lies within a tall monitor's box (the monitor's box reaching down over
  // the desk) is not inside it: a monitor holds nothing.
  const ObjectGeom tv = frame_.Geom(Box(52, "tv", {0, 0, 0.75}, {0.9, 0.8, 1.7}));
  const ObjectGeom kb = frame_.Geom(Box(53, "keyboard", {0.2, 0.2, 0.78}, {0.65, 0.35, 0.81}));
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kInside, kb, tv).holds);
  // A pen in a cup is.
  const ObjectGeom cup = frame_.Geom(Box(54, "cup", {0, 0, 0}, {0.1, 0.1, 0.12}));
  const ObjectGeom pen = frame_.Geom(Box(55, "pen", {0.04, 0.04, 0.01}, {0.05, 0.05, 0.09}));
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kInside, pen, cup).holds);
  // Nor is it "under" the monitor: monitors have no room under them.
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kUnder, kb, tv).holds);
}

// A fused desk whose box also caught a monitor (top at 1.2 m) still carries things on its top
// surface, the densest layer of its points.
TEST_F(RelationsTest, OnTheTopSurfaceOfAFlatTopTable) {
  MapObject desk = Box(60, "dining table", {0, 0, 0}, {1.2, 0.8, 1.2});
  const MapObject keyboard = Box(61, "keyboard", {0.3, 0.2, 0.75}, {0.75, 0.35, 0.78});
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, frame_.Geom(keyboard), frame_.Geom(desk)).holds);
  // Before the top surface is known, the box top is the surface: the keyboard looks under it.
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kUnder, frame_.Geom(keyboard), frame_.Geom(desk)).holds);
  desk.top_surface_z_m = 0.75;
  const RelationResult r = eval_.Evaluate(RelationKind::kOn, frame_.Geom(keyboard), frame_.Geom(desk));
  EXPECT_TRUE(r.holds) << r.evidence;
  // Nor is it under the desk (fr1_rpy: "I found the mouse under the dining table");
  // a chair's seat below the top is.
  const RelationResult under =
      eval_.Evaluate(RelationKind::kUnder, frame_.Geom(keyboard), frame_.Geom(desk));
  EXPECT_FALSE(under.holds) << under.evidence;
  const MapObject chair = Box(63, "chair", {0.2, 0.1, 0.0}, {0.7, 0.6, 0.9});
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kUnder, frame_.Geom(chair), frame_.Geom(desk)).holds);
  // Only for flat-top furniture: a monitor's densest layer is not a surface.
  MapObject tv = Box(62, "tv", {0, 0, 0.7}, {1.2, 0.8, 1.2});
  tv.top_surface_z_m = 0.75;
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, frame_.Geom(keyboard), frame_.Geom(tv)).holds);
}

TEST_F(RelationsTest, Between) {
  // The keyboard lies between the book and the cup on the table; the shelf does not.
  EXPECT_TRUE(eval_.Between(geoms_.at(4), geoms_.at(2), geoms_.at(3)).holds);
  EXPECT_FALSE(eval_.Between(geoms_.at(7), geoms_.at(2), geoms_.at(3)).holds);
  EXPECT_FALSE(eval_.Between(geoms_.at(2), geoms_.at(2), geoms_.at(3)).holds);
}

TEST_F(RelationsTest, LeftRightFrontBehindFromTheViewpoint) {
  EXPECT_TRUE(Eval(RelationKind::kLeftOf, 12, 9).holds);  // plant left of the monitor
  EXPECT_FALSE(Eval(RelationKind::kRightOf, 12, 9).holds);
  EXPECT_TRUE(Eval(RelationKind::kRightOf, 11, 9).holds);  // mouse right of it
  EXPECT_FALSE(Eval(RelationKind::kLeftOf, 11, 9).holds);
  EXPECT_TRUE(Eval(RelationKind::kInFrontOf, 13, 9).holds);  // keyboard in front of it
  EXPECT_FALSE(Eval(RelationKind::kBehind, 13, 9).holds);
  EXPECT_TRUE(Eval(RelationKind::kBehind, 9, 13).holds);
  // Seen from the other side of the desk, left and right swap.
  SE3d T = testing::OfficeViewpoint();
  T.linear() = T.linear() * Eigen::AngleAxisd(M_PI, Vec3d::UnitY()).toRotationMatrix();
  T.translation() = Vec3d(0.6, 5.5, 1.2);
  const ViewpointG back = *frame_.View(Viewpoint{"robot-b", T, 0});
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kRightOf, geoms_.at(12), geoms_.at(9), &back).holds);
  const RelationResult none =
      eval_.Evaluate(RelationKind::kLeftOf, geoms_.at(12), geoms_.at(9), nullptr);
  EXPECT_FALSE(none.holds);
  EXPECT_NE(none.evidence.find("viewpoint"), std::string::npos);
}

TEST_F(RelationsTest, GravityAlignedFrameFollowsUp) {
  // Rotate the whole office so the map's up is +x; with up given, relations are unchanged.
  const Mat3d R = Eigen::AngleAxisd(-M_PI / 2, Vec3d::UnitY()).toRotationMatrix();
  ASSERT_TRUE((R * Vec3d::UnitZ() - Vec3d(-1, 0, 0)).norm() < 1e-9);
  const std::vector<MapObject> rotated = testing::Rotated(Office(), R);
  const GravityFrame aligned(R * Vec3d::UnitZ());
  const GravityFrame naive(Vec3d::UnitZ());
  auto geom = [&](const GravityFrame& f, int64_t id) { return f.Geom(rotated[id - 1]); };
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kOn, geom(aligned, 2), geom(aligned, 1)).holds);
  EXPECT_TRUE(eval_.Evaluate(RelationKind::kUnder, geom(aligned, 5), geom(aligned, 1)).holds);
  EXPECT_FALSE(eval_.Evaluate(RelationKind::kOn, geom(naive, 2), geom(naive, 1)).holds);
  // A tilted up (30 deg) still recovers the table top within the box bound.
  const Mat3d tilt = Eigen::AngleAxisd(0.5, Vec3d(1, 1, 0).normalized()).toRotationMatrix();
  const std::vector<MapObject> tilted = testing::Rotated(Office(), tilt);
  const GravityFrame g(tilt * Vec3d::UnitZ());
  const RelationResult r = eval_.Evaluate(RelationKind::kOn, g.Geom(tilted[1]), g.Geom(tilted[0]));
  EXPECT_TRUE(r.holds) << r.evidence;
}

TEST(GeometryTest, UpFromViewpoints) {
  std::vector<Viewpoint> views = {{"a", testing::OfficeViewpoint(), 1}};
  auto up = EstimateUpFromViewpoints(views);
  ASSERT_TRUE(up);
  EXPECT_LT((*up - Vec3d::UnitZ()).norm(), 1e-9);
  EXPECT_FALSE(EstimateUpFromViewpoints({}));
  SE3d upside_down = testing::OfficeViewpoint();
  upside_down.linear() = upside_down.linear() * Eigen::AngleAxisd(M_PI, Vec3d::UnitZ());
  views.push_back({"b", upside_down, 2});
  EXPECT_FALSE(EstimateUpFromViewpoints(views));  // they disagree
}

TEST(GeometryTest, BoxDistances) {
  BoxG a{{0, 0, 0}, {1, 1, 1}};
  BoxG b{{2, 0, 0}, {3, 1, 1}};
  BoxG c{{2, 2, 2}, {3, 3, 3}};
  EXPECT_DOUBLE_EQ(BoxGap(a, b), 1.0);
  EXPECT_DOUBLE_EQ(BoxGap(a, c), std::sqrt(3.0));
  EXPECT_DOUBLE_EQ(HorizontalGap(a, c), std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(FootprintOverlapArea(a, BoxG{{0.5, 0.5, 5}, {2, 2, 6}}), 0.25);
  EXPECT_DOUBLE_EQ(IntersectionVolume(a, BoxG{{0.5, 0.5, 0.5}, {2, 2, 2}}), 0.125);
}

TEST(RelationNamesTest, RoundTrip) {
  for (RelationKind k : {RelationKind::kOn, RelationKind::kNextTo, RelationKind::kLeftOf,
                         RelationKind::kInFrontOf, RelationKind::kBetween}) {
    EXPECT_EQ(RelationFromName(RelationName(k)), k);
  }
  EXPECT_FALSE(RelationFromName("onto"));
}

}  // namespace
}  // namespace loci::query

// The object model (server/map/README.md): one rule set for association and merging, the
// existence belief from detections and misses, and shape checked against class data.
#include <gtest/gtest.h>

#include <cmath>

#include "server/map/object_map.h"
#include "server/map/visibility.h"
#include "tests/server/object_observations.h"

namespace loci::server {
namespace {

using testing::Grid;
using testing::Rect;
using testing::WithSizes;

// Size priors, and "dining table" as furniture with a top.
FusionOptions TableOptions() {
  FusionOptions opt = WithSizes(1.5);
  opt.top_classes = {"dining table"};
  return opt;
}

// A desk seen in part (1.0 x 0.6 m, weak "dining table" boxes), then blurred views that call the
// monitor on it and the desk under it a "laptop" (0.55 m, inside the desk's points): they must
// not turn the desk into a laptop.
std::string DeskClass(double class_size_slack) {
  FusionOptions opt = WithSizes(class_size_slack);
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t desk = 0;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    desk = map.Integrate({Rect("dining table", 0.3, 1, kf, 0.0, 1.0, 0.0, 0.6, 0.75)}, &changes)[0];
  }
  for (int64_t kf = 4; kf <= 7; ++kf) {
    map.Integrate({Rect("laptop", 0.8, 0, kf, 0.2, 0.75, 0.1, 0.5, 0.75)}, &changes);
  }
  return map.Find(map.Resolve(desk))->labels().Argmax();
}

TEST(ObjectModel, ClassSizesKeepADeskFromBecomingALaptop) {
  EXPECT_EQ(DeskClass(0.0), "laptop");  // no class sizes: the laptop views fuse in and win
  EXPECT_EQ(DeskClass(1.5), "dining table");
}

// A book on a desk, then views of the desk top around it that show only a 0.43 x 0.35 m piece:
// the pieces lie over the book's points and fit a book's size, yet furniture with a top is never
// what stands on it. Returns the object count and the book's class.
std::string BookAfterDeskPieces(bool desks_have_tops) {
  FusionOptions opt = WithSizes(1.5);
  if (desks_have_tops) opt.top_classes = {"dining table"};
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t book = 0;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    book = map.Integrate({Rect("book", 0.6, 1, kf, 0.0, 0.25, 0.0, 0.19, 0.80)}, &changes)[0];
  }
  for (int64_t kf = 4; kf <= 8; ++kf) {
    map.Integrate({Rect("dining table", 0.6, 0, kf, -0.09, 0.34, -0.08, 0.27, 0.80)}, &changes);
  }
  return std::to_string(map.size()) + " " + map.Find(map.Resolve(book))->labels().Argmax();
}

TEST(ObjectModel, APieceOfADeskTopNeverJoinsTheBookOnIt) {
  EXPECT_EQ(BookAfterDeskPieces(false), "1 dining table");
  EXPECT_EQ(BookAfterDeskPieces(true), "2 book");
}

TEST(ObjectModel, TwoTablesSideBySideStayTwoAndAPartialViewJoinsItsTable) {
  ObjectMap map(TableOptions(), 0.01);
  std::vector<ObjectChange> changes;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    map.Integrate({Rect("dining table", 0.5, 0, kf, 0.0, 0.8, 0.0, 1.4, 0.75),
                   Rect("dining table", 0.5, 0, kf, 0.85, 1.7, 0.0, 1.4, 0.72)},
                  &changes);
  }
  EXPECT_EQ(map.size(), 2u);
  // A view of the first table's near half: its footprint lies inside that table's.
  const std::vector<int64_t> ids =
      map.Integrate({Rect("dining table", 0.5, 0, 4, 0.0, 0.8, 0.0, 0.6, 0.755)}, &changes);
  EXPECT_EQ(map.size(), 2u);
  EXPECT_EQ(ids[0], 1);
}

TEST(ObjectModel, AssociationAndMergingAreOneSymmetricRule) {
  const FusionOptions opt = TableOptions();
  const ObjectAssociation rules(opt);
  const VoxelSet empty;
  AssociationView cup{"cup", {0, 0, 0.8}, 0.05, 1.0, &empty, nullptr, nullptr};
  AssociationView near_cup = cup;
  near_cup.centroid_m.x() = 0.08;
  AssociationView far_cup = cup;
  far_cup.centroid_m.x() = 0.3;
  AssociationView table{"dining table", {0, 0, 0.75}, 0.06, 1.0, &empty, nullptr, nullptr};
  EXPECT_EQ(rules.Score(cup, near_cup), 1);
  EXPECT_EQ(rules.Score(near_cup, cup), 1);
  EXPECT_EQ(rules.Score(cup, far_cup), 0);
  EXPECT_EQ(rules.Score(cup, table), 0);  // a top and what stands on it: never one object
  EXPECT_EQ(rules.Score(table, cup), 0);
}

// Keyframes at the given times (s), one "cup" view each at the same place.
FusedObject CupSeenAt(const std::vector<double>& t_s) {
  ObjectMap map(WithSizes(1.5), 0.01);
  std::vector<ObjectChange> changes;
  int64_t id = 0, kf = 0;
  for (double t : t_s) {
    MapObservation o = Rect("cup", 0.6, 1, ++kf, 0.0, 0.08, 0.0, 0.08, 0.8);
    o.t_ns = static_cast<int64_t>(t * 1e9);
    id = map.Integrate({o}, &changes)[0];
  }
  return *map.Find(map.Resolve(id));
}

TEST(ObjectModel, ViewsInOneWindowAreOnePieceOfEvidence) {
  const FusedObject::ExistenceModel m;  // prior 0.03, 0.5 / 0.1, 0.5 s windows
  const double hit = std::log(0.5 / 0.1), prior = std::log(0.03 / 0.97);
  const FusedObject burst = CupSeenAt({1.0, 1.1, 1.2, 1.3});
  EXPECT_EQ(burst.EvidenceOver(m.window_ns).hits, 1);
  EXPECT_NEAR(burst.ExistenceLogOdds(m), prior + hit, 1e-9);
  EXPECT_FALSE(burst.confirmed());
  const FusedObject two = CupSeenAt({1.0, 2.0});
  EXPECT_NEAR(two.ExistenceLogOdds(m), prior + 2 * hit, 1e-9);
  EXPECT_FALSE(two.confirmed());  // two windows never confirm
  const FusedObject three = CupSeenAt({1.0, 1.2, 2.0, 3.0});
  EXPECT_EQ(three.EvidenceOver(m.window_ns).hits, 3);
  EXPECT_TRUE(three.confirmed());
  // Misses count per window too, and a window with a hit is a hit.
  FusedObject missed = three;
  for (int64_t kf = 10; kf < 16; ++kf) missed.Miss(kf, 4'000'000'000 + (kf - 10) * 100'000'000);
  missed.Miss(20, 1'100'000'000);
  const FusedObject::Evidence e = missed.EvidenceOver(m.window_ns);
  EXPECT_EQ(e.hits, 3);
  EXPECT_EQ(e.misses, 2);  // 4.0-4.4 s, 4.5 s
  EXPECT_NEAR(missed.ExistenceLogOdds(m), prior + 3 * hit + 2 * std::log(0.5 / 0.9), 1e-9);
}

// Things get moved: sightings days old weigh less than views of the empty place now. A glance
// an hour later that misses a cup leaves it believed; two days later, a few seconds of views
// that miss it take the belief below removal; a class that is never moved keeps it.
TEST(ObjectModel, OldSightingsFadeAtTheClassRate) {
  FusedObject::ExistenceModel m;
  m.stays_s = 0.5 * 86400;  // a cup: moved within half a day
  const double remove = std::log(0.001 / 0.999);
  std::vector<double> seen_s;
  for (int i = 0; i < 40; ++i) seen_s.push_back(0.6 * i);  // 24 s of sightings
  const FusedObject cup = CupSeenAt(seen_s);
  EXPECT_GT(cup.ExistenceLogOdds(m), 5.0);
  auto missed_after = [&](double gap_s, int windows) {
    FusedObject later = cup;
    for (int k = 0; k < windows; ++k) {
      later.Miss(1000 + k, static_cast<int64_t>((24 + gap_s + 0.6 * k) * 1e9));
    }
    return later;
  };
  EXPECT_GT(missed_after(3600, 2).ExistenceLogOdds(m), 0.0) << "an hour later: still there";
  EXPECT_LT(missed_after(2 * 86400, 6).ExistenceLogOdds(m), remove) << "two days later: gone";
  FusedObject::ExistenceModel forever = m;
  forever.stays_s = 0;
  EXPECT_GT(missed_after(2 * 86400, 6).ExistenceLogOdds(forever), 0.0);
}

// A camera at the map origin (optical frame = map frame) sees a flat surface 1 m ahead with a
// 10 cm mouse detected at x = -0.2 m in `hits` views 0.6 s apart; then `misses` views 0.6 s
// apart show the same place without a box. Returns whether the mouse was confirmed after the
// hits, and whether it is still in the map at the end.
std::pair<bool, bool> MouseMissed(int hits, int misses) {
  ObjectMap map(WithSizes(1.5), 0.01);
  const PinholeCamera camera = PinholeCamera::TumFr1();
  const cv::Mat depth_m(480, 640, CV_32FC1, cv::Scalar(1.0f));
  const std::vector<Detection2D> no_boxes;
  std::vector<ObjectChange> changes;
  int64_t id = 0, kf = 0;
  for (int i = 0; i < hits; ++i) {
    MapObservation o = Rect("mouse", 0.6, 0, ++kf, -0.2, -0.1, -0.05, 0.05, 1.0);
    o.t_ns = kf * 600'000'000LL;
    id = map.Integrate({o}, &changes)[0];
  }
  const bool confirmed = map.Find(id)->confirmed();
  for (int i = 0; i < misses; ++i) {
    ++kf;
    map.ObserveView(kf, kf * 600'000'000LL, {&camera, &depth_m, 1, SE3d::Identity(), &no_boxes},
                    {}, &changes);
  }
  return {confirmed, map.Find(id) != nullptr};
}

TEST(ObjectModel, ViewsThatShouldHaveSeenAnObjectLowerItsBelief) {
  // Five windows with a box: log-odds -3.48 + 5 x 1.61 = 4.57, clamped at max_belief's 3.48;
  // each window that missed it adds log(0.5 / 0.9) = -0.59. Ten leave it at -2.4: still
  // there; twenty take it to -8.3, below the removal belief's -3.9.
  EXPECT_EQ(MouseMissed(5, 10), std::make_pair(true, true));
  EXPECT_EQ(MouseMissed(5, 20), std::make_pair(true, false));
  // Thirty windows with a box weigh no more than five: the clamp lets an empty place win.
  EXPECT_EQ(MouseMissed(30, 10), std::make_pair(true, true));
  EXPECT_EQ(MouseMissed(30, 20), std::make_pair(true, false));
}

bool MouseConfirmed(double length_m, double class_size_slack) {
  ObjectMap map(WithSizes(class_size_slack), 0.01);
  std::vector<ObjectChange> changes;
  int64_t id = 0;
  for (int64_t kf = 1; kf <= 6; ++kf) {
    id = map.Integrate({Rect("mouse", 0.6, 1, kf, 0.0, length_m, 0.0, 0.06, 0.78)}, &changes)[0];
  }
  return map.Find(map.Resolve(id))->confirmed();
}

TEST(ObjectModel, AnObjectTooLongForItsClassIsNotConfirmed) {
  EXPECT_TRUE(MouseConfirmed(0.41, 0.0));   // no class sizes
  EXPECT_FALSE(MouseConfirmed(0.41, 1.5));  // longer than 1.5 x 0.25 m
  EXPECT_TRUE(MouseConfirmed(0.12, 1.5));
}

// A flat panel fused from views that took in the wall beside and behind a dark screen is thicker
// than any panel: it stays a candidate while the class data say so.
bool TvConfirmed(double thickness_m, bool prior) {
  FusionOptions opt = WithSizes(1.5);
  if (prior) opt.max_thickness_m["tv"] = 0.3;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t id = 0;
  for (int64_t kf = 1; kf <= 6; ++kf) {
    const MapObservation view =
        Grid("tv", 1, kf, {1.0, 0.0, 0.8}, {1.0 + thickness_m, 0.5, 1.2}, {0.02, 0.02, 0.02});
    id = map.Integrate({view}, &changes)[0];
  }
  const FusedObject* tv = map.Find(map.Resolve(id));
  EXPECT_NEAR(2 * tv->obb_half_m().minCoeff(), thickness_m, 0.03);
  return tv->confirmed();
}

TEST(ObjectModel, ATvThickerThanAPanelIsNotConfirmed) {
  EXPECT_TRUE(TvConfirmed(0.38, false));
  EXPECT_FALSE(TvConfirmed(0.38, true));
  EXPECT_TRUE(TvConfirmed(0.2, true));
}

// Two views of one cup, 0.15 m apart, each seen from range_m (the second from second_range_m).
size_t CupsAt(double range_m, double gate_sigmas, double second_range_m = -1) {
  FusionOptions opt = WithSizes(1.5);
  opt.gate_sigmas = gate_sigmas;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    MapObservation first = Rect("cup", 0.6, 0, 2 * kf, 0.0, 0.08, 0.0, 0.08, 0.8);
    MapObservation second = Rect("cup", 0.6, 0, 2 * kf + 1, 0.15, 0.23, 0.0, 0.08, 0.8);
    first.range_m = range_m;
    second.range_m = second_range_m < 0 ? range_m : second_range_m;
    map.Integrate({first}, &changes);
    map.Integrate({second}, &changes);
  }
  return map.size();
}

TEST(ObjectModel, FarViewsAreOneObjectWithinTheirRangeUncertainty) {
  EXPECT_EQ(CupsAt(3.2, 1.0), 1u);       // gate sqrt(2) s(3.2 m) = 0.19 m
  EXPECT_EQ(CupsAt(0.9, 1.0), 2u);       // gate 0.1 m: s(0.9 m) = 0.024 m
  EXPECT_EQ(CupsAt(3.2, 0.0), 2u);       // off
  EXPECT_EQ(CupsAt(0.0, 1.0), 2u);       // range unknown
  EXPECT_EQ(CupsAt(0.9, 1.0, 3.2), 2u);  // a near view does not take in a far view's blob
}

}  // namespace
}  // namespace loci::server

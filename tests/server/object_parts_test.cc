// Parts of other objects (server/map/object_parts.cc) on fr1_rpy's monitors: a stand boxed as
// "mouse" inside the monitor's points (session 27), a foot under the panel's middle (session
// 39), and a stand that a loop closure's move brings under its monitor.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "server/map/object_map.h"
#include "tests/server/object_observations.h"

namespace loci::server {
namespace {

using testing::Grid;
using testing::WithSizes;

// fr1_rpy's main monitor (objects_gt.json: panel x 0.44-0.52, y 0.65-1.20, z 0.94-1.25, its
// box runs down the stand to the desk at 0.77 m) seen in 11 views with its stand, and a few
// blurred views that box the stand as "mouse" (session 27: 4 such views, 100 % of the "mouse"'s
// voxels in the monitor's). Then what must stay confirmed: a real mouse on the desk in front of
// the monitor, whose views the monitor's masks bleed onto by half; a book lying on a chair's
// seat, inside the chair's points. `part_views_first`: the stand's "mouse" views come after the
// monitor's second view, before its others (the monitor grows to hold it).
struct PartsResult {
  size_t objects = 0;
  bool stand_confirmed = false;  // the "mouse" seen on the monitor's stand
  bool real_mouse_confirmed = false;
  bool book_confirmed = false;
};

PartsResult Parts(double part_containment, bool part_views_first,
                  std::vector<std::string> never_part_of = {"chair"}) {
  FusionOptions opt = WithSizes(1.5);
  opt.max_size_m["mouse"] = 0.25;
  opt.max_size_m["chair"] = 1.6;
  opt.part_containment = part_containment;
  opt.never_part_of = std::move(never_part_of);
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const Eigen::Vector3d step(0.01, 0.01, 0.01);
  auto monitor = [&](int64_t kf) {
    MapObservation tv = Grid("tv", 1, kf, {0.48, 0.65, 0.94}, {0.48, 1.20, 1.25}, step);
    const MapObservation stand = Grid("tv", 1, kf, {0.48, 0.88, 0.77}, {0.48, 0.97, 0.93}, step);
    const MapObservation bleed = Grid("tv", 1, kf, {0.30, 0.90, 0.79}, {0.34, 0.97, 0.79}, step);
    for (const MapObservation* part : {&stand, &bleed}) {
      tv.points_m.insert(tv.points_m.end(), part->points_m.begin(), part->points_m.end());
    }
    tv.centroid_m = {0.48, 0.925, 1.01};
    tv.half_size_m = 0.275;
    return tv;
  };
  auto stand_mouse = [&](int64_t kf) {
    return Grid("mouse", 2, kf, {0.48, 0.88, 0.78}, {0.48, 0.97, 0.90}, step);
  };
  int64_t stand = 0, real = 0, book = 0;
  int64_t kf = 1;
  for (; kf <= 2; ++kf) map.Integrate({monitor(kf)}, &changes);
  if (part_views_first) {
    for (int i = 0; i < 4; ++i, ++kf) stand = map.Integrate({stand_mouse(kf)}, &changes)[0];
  }
  for (; kf <= 16; ++kf) {
    std::vector<MapObservation> views = {
        monitor(kf),
        Grid("mouse", 3, kf, {0.26, 0.90, 0.79}, {0.38, 0.97, 0.79}, step),  // the real mouse
        Grid("chair", 4, kf, {-1.6, -0.3, 0.45}, {-1.1, 0.2, 0.45}, step),   // its seat
    };
    if (kf >= 9) views.push_back(Grid("book", 5, kf, {-1.4, -0.1, 0.45}, {-1.2, 0.05, 0.45}, step));
    if (!part_views_first && kf >= 9 && kf <= 12) views.push_back(stand_mouse(kf));
    const std::vector<int64_t> ids = map.Integrate(views, &changes);
    real = ids[1];
    if (kf >= 9) book = ids[3];
    if (!part_views_first && kf >= 9 && kf <= 12) stand = ids[4];
  }
  PartsResult r;
  r.objects = map.size();
  r.stand_confirmed = map.Find(map.Resolve(stand))->confirmed();
  r.real_mouse_confirmed = map.Find(map.Resolve(real))->confirmed();
  r.book_confirmed = map.Find(map.Resolve(book))->confirmed();
  return r;
}

TEST(ObjectRules, AMonitorsStandCalledMouseIsPartOfTheMonitor) {
  for (bool part_views_first : {false, true}) {
    SCOPED_TRACE(part_views_first ? "stand views early" : "stand views last");
    // Off: the stand's "mouse" is a confirmed object of its own.
    const PartsResult off = Parts(2.0, part_views_first);
    EXPECT_EQ(off.objects, 5u);  // monitor, stand, real mouse, chair, book
    EXPECT_TRUE(off.stand_confirmed);
    // On: it stays a candidate, with its evidence (no object is merged away).
    const PartsResult on = Parts(0.9, part_views_first);
    EXPECT_EQ(on.objects, 5u);
    EXPECT_FALSE(on.stand_confirmed);
    EXPECT_TRUE(on.real_mouse_confirmed);  // half of it inside the monitor's points
    EXPECT_TRUE(on.book_confirmed);
  }
  // The book on the seat lies inside the chair's points: only never_part_of keeps it.
  EXPECT_FALSE(Parts(0.9, false, {}).book_confirmed);
}

// The same monitor seen as its panel only (x 0.47-0.49), its foot on the desk below it called
// "mouse" on a few views: the foot is none of the panel's voxels, so only the stand test finds
// it. A cup beside the monitor, under the panel's end, and a mouse in front stay objects.
struct StandResult {
  bool foot_confirmed = false, cup_confirmed = false, mouse_confirmed = false;
};

StandResult Stand(std::vector<std::string> stand_classes) {
  FusionOptions opt = WithSizes(1.5);
  opt.max_size_m["mouse"] = 0.25;
  opt.max_size_m["cup"] = 0.3;
  opt.stand_classes = std::move(stand_classes);
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const Eigen::Vector3d step(0.01, 0.01, 0.01);
  int64_t foot = 0, cup = 0, mouse = 0;
  for (int64_t kf = 1; kf <= 16; ++kf) {
    std::vector<MapObservation> views = {
        Grid("tv", 1, kf, {0.47, 0.65, 0.94}, {0.49, 1.20, 1.25}, step),
        Grid("cup", 2, kf, {0.50, 0.64, 0.78}, {0.60, 0.72, 0.89}, step),
        Grid("mouse", 3, kf, {0.26, 0.90, 0.79}, {0.38, 0.97, 0.81}, step),
    };
    if (kf >= 5 && kf <= 12) {
      views.push_back(Grid("mouse", 4, kf, {0.44, 0.88, 0.78}, {0.52, 0.97, 0.84}, step));
    }
    const std::vector<int64_t> ids = map.Integrate(views, &changes);
    cup = ids[1];
    mouse = ids[2];
    if (views.size() > 3) foot = ids[3];
  }
  StandResult r;
  r.foot_confirmed = map.Find(map.Resolve(foot))->confirmed();
  r.cup_confirmed = map.Find(map.Resolve(cup))->confirmed();
  r.mouse_confirmed = map.Find(map.Resolve(mouse))->confirmed();
  return r;
}

TEST(ObjectRules, AnObjectUnderTheMiddleOfAMonitorIsItsStand) {
  const StandResult off = Stand({});
  EXPECT_TRUE(off.foot_confirmed);
  const StandResult on = Stand({"tv"});
  EXPECT_FALSE(on.foot_confirmed);
  EXPECT_TRUE(on.cup_confirmed);
  EXPECT_TRUE(on.mouse_confirmed);
}

// A loop closure moves keyframes, and with them what lies under what: the foot's views, mapped
// beside the monitor by a drifted pose, are moved under it. Judged again after the move, it is
// the monitor's stand.
TEST(ObjectRules, AStandFoundAfterAMoveIsJudgedThen) {
  FusionOptions opt = WithSizes(1.5);
  opt.max_size_m["mouse"] = 0.25;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const Eigen::Vector3d step(0.01, 0.01, 0.01);
  const Eigen::Vector3d drift(0.0, 0.45, 0.0);  // the foot's views mapped 45 cm aside
  auto foot = [&](int64_t kf, const Eigen::Vector3d& offset) {
    return Grid("mouse", 4, kf, Eigen::Vector3d(0.44, 0.88, 0.78) + offset,
                Eigen::Vector3d(0.52, 0.97, 0.84) + offset, step);
  };
  int64_t foot_id = 0;
  std::vector<int64_t> foot_kfs;
  for (int64_t kf = 1; kf <= 16; ++kf) {
    std::vector<MapObservation> views = {
        Grid("tv", 1, kf, {0.47, 0.65, 0.94}, {0.49, 1.20, 1.25}, step)};
    if (kf >= 5 && kf <= 12) {
      views.push_back(foot(kf, drift));
      foot_kfs.push_back(kf);
    }
    const std::vector<int64_t> ids = map.Integrate(views, &changes);
    if (views.size() > 1) foot_id = ids[1];
  }
  ASSERT_TRUE(map.Find(map.Resolve(foot_id))->confirmed());  // beside the monitor: an object
  for (int64_t kf : foot_kfs) {
    ASSERT_TRUE(map.MoveObservation(foot_id, foot(kf, drift).points_m,
                                    foot(kf, Eigen::Vector3d::Zero()).points_m, "mouse"));
  }
  changes.clear();
  map.MergeMoved({foot_id}, &changes);
  EXPECT_FALSE(map.Find(map.Resolve(foot_id))->confirmed());
  bool reported = false;
  for (const ObjectChange& c : changes) {
    reported |= c.kind == ObjectChange::Kind::kUpdated && c.object_id == map.Resolve(foot_id);
  }
  EXPECT_TRUE(reported);
}

// fr1_rpy, live run: the keyboard's masks bled onto the cup beside it in a few of its 75 views,
// so every voxel of the cup was also among the keyboard's, and the cup (62 views) stayed a
// candidate as a "part" of the keyboard. A part lies inside what shapes the whole, not inside
// every view fused into it: a cup caught by 2 of the keyboard's 12 views stays confirmed.
TEST(ObjectRules, ACupThatAFewOfAKeyboardsViewsBledOntoIsNotItsPart) {
  const Eigen::Vector3d cup_min(0.47, 0.0, 0.78), cup_max(0.54, 0.07, 0.88);
  const auto grid = [](const std::string& cls, int64_t track, int64_t kf,
                       const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    return Grid(cls, track, kf, lo, hi, Eigen::Vector3d::Constant(0.01));
  };
  FusionOptions opt = WithSizes(1.5);
  opt.max_size_m["cup"] = 0.3;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t cup = 0, keyboard = 0;
  for (int64_t kf = 1; kf <= 12; ++kf) {
    MapObservation keys = grid("keyboard", 1, kf, {0.0, 0.0, 0.78}, {0.50, 0.16, 0.78});
    if (kf == 6 || kf == 12) {  // the mask ran onto the cup
      const MapObservation bleed = grid("keyboard", 1, kf, cup_min, cup_max);
      keys.points_m.insert(keys.points_m.end(), bleed.points_m.begin(), bleed.points_m.end());
      keys.centroid_m = {0.25, 0.08, 0.78};
      keys.half_size_m = 0.25;
    }
    std::vector<MapObservation> views = {keys};
    if (kf >= 3 && kf <= 8) views.push_back(grid("cup", 2, kf, cup_min, cup_max));
    const std::vector<int64_t> ids = map.Integrate(views, &changes);
    keyboard = ids[0];
    if (views.size() > 1) cup = ids[1];
  }
  ASSERT_NE(map.Resolve(cup), map.Resolve(keyboard));
  EXPECT_TRUE(map.Find(map.Resolve(keyboard))->confirmed());
  EXPECT_TRUE(map.Find(map.Resolve(cup))->confirmed());
}

}  // namespace
}  // namespace loci::server

// Object map rules measured on TUM fr1_rpy (docs/results.md, session 9): class size priors across
// classes, furniture kept apart from what stands on it (session 24) and from furniture beside it
// (session 25), the merge of same-class objects whose boxes overlap (far, smeared duplicates), and
// existence judged by the class's own detection rate (session 23).
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "loci/store/v1/map_state.pb.h"
#include "server/map/object_map.h"
#include "server/map/visibility.h"
#include "tests/server/object_observations.h"

namespace loci::server {
namespace {

using testing::Grid;
using testing::Rect;
using testing::WithSizes;

// Size priors, and "dining table" as flat-topped furniture.
FusionOptions TableOptions() {
  FusionOptions opt = WithSizes(1.5);
  opt.flat_top_classes = {"dining table"};
  return opt;
}

// A level table top x0..x1, y0..y1 at z_m, seen as one tracker's box (0: untracked).
struct Top {
  int64_t track;
  double x0, x1, y0, y1, z_m;
};

// Each of keyframes 1-3 sees both tops, one "dining table" observation each.
void SeeTopsInThreeKeyframes(ObjectMap* map, const Top& a, const Top& b) {
  std::vector<ObjectChange> changes;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    map->Integrate({Rect("dining table", 0.4, a.track, kf, a.x0, a.x1, a.y0, a.y1, a.z_m),
                    Rect("dining table", 0.4, b.track, kf, b.x0, b.x1, b.y0, b.y1, b.z_m)},
                   &changes);
  }
}

// A desk seen in part (1.0 x 0.6 m, weak "dining table" boxes), then blurred views that call the
// monitor on it and the desk under the monitor a "laptop" (0.55 m, inside the desk's points, a
// compatible size): they must not turn the desk into a laptop.
std::string DeskClass(double class_size_slack) {
  ObjectMap map(WithSizes(class_size_slack), 0.01);
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

TEST(ObjectRules, ClassSizePriorKeepsADeskFromBecomingALaptop) {
  EXPECT_EQ(DeskClass(0.0), "laptop");  // off: the laptop views fuse into the desk and win
  EXPECT_EQ(DeskClass(1.5), "dining table");
}

// A book (0.25 x 0.19 m) on a desk, then views of the desk top around it that show only a
// 0.43 x 0.35 m piece (a partial view): the desk pieces lie over the book's points and their size
// fits a book's class limit, yet furniture is never what stands on it.
// Returns the object count and the book's class.
std::string BookClassAfterDeskPieces(bool flat_top_desks) {
  FusionOptions opt = WithSizes(1.5);
  if (flat_top_desks) opt.flat_top_classes = {"dining table"};
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

TEST(ObjectRules, APieceOfADeskTopNeverJoinsTheBookOnIt) {
  // The size prior alone lets the pieces in: one object, and the book is gone.
  EXPECT_EQ(BookClassAfterDeskPieces(false), "1 dining table");
  EXPECT_EQ(BookClassAfterDeskPieces(true), "2 book");
}

// fr1_rpy's two desks back to back (objects_gt.json: tops x -0.75..0.19 at z 0.74 and x
// 0.21..1.04 at z 0.77, y -0.04..1.5), each seen alone in 3 views; then a view of one detector
// box whose plane runs through both tops (session 24 counted 5 such pieces in about 50).
// Returns the count of table objects and the views of each.
std::string DesksAfterAStraddlingView(double straddle_share) {
  FusionOptions opt = TableOptions();
  opt.straddle_share = straddle_share;
  opt.furniture_merge_containment = 0;  // the straddle rule alone (merge_containment 0.5)
  ObjectMap map(opt, 0.01);
  SeeTopsInThreeKeyframes(&map, {0, 0.21, 1.04, 0.0, 1.0, 0.77}, {0, -0.75, 0.19, 0.0, 1.0, 0.74});
  std::vector<ObjectChange> changes;
  // One plane through both tops: each part at its own desk's height, one observation.
  MapObservation across = Rect("dining table", 0.4, 0, 4, 0.21, 0.75, 0.1, 0.9, 0.77);
  const MapObservation person_part = Rect("dining table", 0.4, 0, 4, -0.45, 0.19, 0.1, 0.9, 0.74);
  across.points_m.insert(across.points_m.end(), person_part.points_m.begin(),
                         person_part.points_m.end());
  across.centroid_m = {0.15, 0.5, 0.755};
  across.half_size_m = 0.6;
  std::vector<int64_t> straddled;
  const auto ids = map.Integrate({across}, &changes, &straddled);
  std::ostringstream out;
  out << map.size() << " objects, straddled " << straddled.size() << ", id " << ids[0] << ":";
  for (const MapObject& o : map.Snapshot(false)) out << " " << o.observation_count;
  return out.str();
}

TEST(ObjectRules, AViewStraddlingTwoDesksJoinsNeither) {
  // Without the rule the straddling view fuses into one desk and then holds the other: one table.
  EXPECT_EQ(DesksAfterAStraddlingView(0), "1 objects, straddled 0, id 1: 4");
  // With it the view is a hit for both desks and adds no points: two tables, seen 4 times each.
  EXPECT_EQ(DesksAfterAStraddlingView(0.25), "2 objects, straddled 2, id 0: 4 4");
}

// One desk top (1 x 1 m at 0.77 m) seen in two overlapping pieces, x 0-0.6 m and 0.35-1.0 m
// (tracker boxes 1 and 2, keyframes 1-3): each lies 0.38-0.42 on the other, too little for a
// merge (footprint containment 0.5, voxel 0.85) and too much for two desks side by side. Then a
// view of the whole top (keyframe 4), 0.6 and 0.65 on the pieces: it joins them rather than
// straddling them (fr1_rpy start 60: desk_main stayed two pieces, every view over both left
// out). Returns the objects, how many the view straddled, and the table's views (keyframes).
std::string TopAfterAViewOverItsPieces() {
  FusionOptions opt = TableOptions();
  opt.furniture_footprint_containment = 0.5;
  ObjectMap map(opt, 0.01);
  SeeTopsInThreeKeyframes(&map, {1, 0.0, 0.6, 0.0, 1.0, 0.77}, {2, 0.35, 1.0, 0.0, 1.0, 0.77});
  EXPECT_EQ(map.size(), 2u);
  std::vector<ObjectChange> changes;
  std::vector<int64_t> straddled;
  map.Integrate({Rect("dining table", 0.4, 0, 4, 0.0, 1.0, 0.0, 1.0, 0.77)}, &changes, &straddled);
  std::ostringstream out;
  out << map.size() << " objects, straddled " << straddled.size() << ":";
  for (const MapObject& o : map.Snapshot(false)) out << " " << o.observation_count;
  return out.str();
}

TEST(ObjectRules, AViewOverTwoOverlappingPiecesOfATopJoinsThem) {
  EXPECT_EQ(TopAfterAViewOverItsPieces(), "1 objects, straddled 0: 4");
}

// A desk (1 x 1 m, tracker box 1) and a small table 10 cm beside it (0.3 x 0.3 m, box 2), each
// seen in keyframes 1-3, then one view straddling both (keyframe 4: 43 % of its voxels on each,
// as fr1_rpy's single boxes over both desks). Then the desk's tracker box takes in the small
// table (keyframe 5, 6 % of it on the table: no straddle), so the desk's object holds all of
// the table's voxels: fr1_rpy's desks became one 2.4 m table through such growth (session 29).
// `checkpoint`: the map goes through SaveState / LoadState before keyframe 5. Returns how many
// objects the map holds.
size_t TablesAfterTheDeskGrows(int straddle_apart_views, bool checkpoint) {
  FusionOptions opt = TableOptions();
  opt.straddle_apart_views = straddle_apart_views;
  ObjectMap map(opt, 0.01);
  SeeTopsInThreeKeyframes(&map, {1, 0.0, 1.0, 0.0, 1.0, 0.77}, {2, 1.1, 1.4, 0.0, 0.3, 0.77});
  std::vector<ObjectChange> changes;
  std::vector<int64_t> straddled;
  map.Integrate({Rect("dining table", 0.4, 0, 4, 0.7, 1.4, 0.0, 0.3, 0.77)}, &changes, &straddled);
  EXPECT_EQ(straddled.size(), 2u);
  if (checkpoint) {
    loci::store::v1::ObjectMapState state;
    map.SaveState(&state);
    EXPECT_TRUE(map.LoadState(state).ok());
  }
  map.Integrate({Rect("dining table", 0.4, 1, 5, 0.0, 1.4, 0.0, 1.0, 0.77)}, &changes);
  return map.size();
}

TEST(ObjectRules, FurnitureAViewStraddledStaysTwoWhenOnePieceGrowsOverTheOther) {
  EXPECT_EQ(TablesAfterTheDeskGrows(0, false), 1u);  // off: merged by voxel containment
  EXPECT_EQ(TablesAfterTheDeskGrows(1, false), 2u);
  EXPECT_EQ(TablesAfterTheDeskGrows(1, true), 2u);  // the straddle survives a checkpoint
}

// A table (1 x 1 m) seen in keyframes 1-3, then a one-view piece of table top (keyframe 4,
// untracked) that lies 55 % on it: too little to be associated with it (assoc_containment 0.6),
// enough for a merge at merge_containment 0.5, which takes its other half into the table. Such
// pieces let fr1_rpy's main desk creep over the desk beside it (session 29). Returns the
// number of objects and the table's views (keyframes).
std::string TableAfterAHalfOnPiece(double furniture_merge_containment) {
  FusionOptions opt = TableOptions();
  opt.furniture_merge_containment = furniture_merge_containment;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t table = 0;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    table =
        map.Integrate({Rect("dining table", 0.4, 1, kf, 0.0, 1.0, 0.0, 1.0, 0.77)}, &changes)[0];
  }
  map.Integrate({Rect("dining table", 0.4, 0, 4, 0.45, 1.45, 0.0, 1.0, 0.77)}, &changes);
  return std::to_string(map.size()) + " objects, the table seen " +
         std::to_string(map.Find(map.Resolve(table))->observation_count());
}

TEST(ObjectRules, AOneViewPieceHalfOnATableDoesNotJoinIt) {
  // 0: merge_containment 0.5 for furniture too
  EXPECT_EQ(TableAfterAHalfOnPiece(0), "1 objects, the table seen 4");
  // The piece stays a candidate of its own (one view: never confirmed on its own).
  EXPECT_EQ(TableAfterAHalfOnPiece(0.85), "2 objects, the table seen 3");
}

// fr1_rpy's two desks back to back (as above) and a piece across both: views of one detector box
// whose top plane came out 3 cm higher than the main desk's (one plane through two tops at
// different heights, depth noise), so that its voxels lie on neither desk and the view is no
// straddle of them. First the piece is seen in `piece_views` keyframes (track 3), then each
// desk alone in keyframes 11-13 (tracks 1 and 2). Returns the objects, the confirmed ones, and
// whether the piece was confirmed before the desks came and after (and a change announced it).
std::string ConfirmedTablesWithAPieceAcross(bool straddle_pieces, int piece_views) {
  FusionOptions opt = TableOptions();
  opt.straddle_pieces = straddle_pieces;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t piece = 0;
  for (int64_t kf = 1; kf <= piece_views; ++kf) {
    piece =
        map.Integrate({Rect("dining table", 0.4, 3, kf, -0.45, 0.75, 0.1, 0.9, 0.80)}, &changes)[0];
  }
  const bool confirmed_alone = map.Find(piece)->confirmed();
  changes.clear();
  for (int64_t kf = 11; kf <= 13; ++kf) {
    map.Integrate({Rect("dining table", 0.4, 1, kf, 0.21, 1.04, 0.0, 1.0, 0.77),
                   Rect("dining table", 0.4, 2, kf, -0.75, 0.19, 0.0, 1.0, 0.74)},
                  &changes);
  }
  bool piece_updated = false;
  for (const ObjectChange& c : changes) piece_updated |= c.object_id == piece;
  size_t tables = 0;
  for (const MapObject& o : map.Snapshot(/*confirmed_only=*/true)) tables += o.confirmed ? 1 : 0;
  std::ostringstream out;
  out << map.size() << " objects, " << tables << " confirmed; the piece "
      << (confirmed_alone ? "confirmed" : "a candidate") << " alone, then "
      << (map.Find(piece)->confirmed() ? "confirmed" : "a candidate")
      << (piece_updated ? " (updated)" : "");
  return out.str();
}

TEST(ObjectRules, APieceAcrossTwoDesksStaysACandidate) {
  EXPECT_EQ(ConfirmedTablesWithAPieceAcross(false, 3),
            "3 objects, 3 confirmed; the piece confirmed alone, then confirmed");
  // The desks, each seen as often as the piece, stand apart and hold 45 % and 53 % of its
  // footprint: the piece goes back to a candidate, and WatchObjects hears of it.
  EXPECT_EQ(ConfirmedTablesWithAPieceAcross(true, 3),
            "3 objects, 2 confirmed; the piece confirmed alone, then a candidate (updated)");
  // A piece seen more often than each desk is what most views showed: it stays.
  EXPECT_EQ(ConfirmedTablesWithAPieceAcross(true, 5),
            "3 objects, 3 confirmed; the piece confirmed alone, then confirmed");
}

// One desk (x 0.21-1.04, y 0-1.5) seen first from near (tracker 1, keyframes 1-3, y 0-near_y1_m)
// and then, under another tracker id, from afar where its top comes out 4 cm higher (keyframes
// 21-23, 6 s later, y far_y0_m-1.5); a second desk stands back to back with it (x -0.75-0.19,
// tops 3 cm apart) in keyframes 31-33. Returns the number of pieces of furniture.
size_t DeskPieces(double footprint_containment, double near_y1_m = 1.5, double far_y0_m = 0.3) {
  FusionOptions opt = TableOptions();
  opt.furniture_footprint_containment = footprint_containment;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  for (int64_t kf = 1; kf <= 3; ++kf) {
    map.Integrate({Rect("dining table", 0.4, 1, kf, 0.21, 1.04, 0.0, near_y1_m, 0.77)}, &changes);
  }
  for (int64_t kf = 21; kf <= 23; ++kf) {
    map.Integrate({Rect("dining table", 0.4, 2, kf, 0.21, 0.80, far_y0_m, 1.5, 0.81)}, &changes);
  }
  for (int64_t kf = 31; kf <= 33; ++kf) {
    map.Integrate({Rect("dining table", 0.4, 3, kf, -0.75, 0.19, 0.0, 1.5, 0.74)}, &changes);
  }
  return map.size();
}

TEST(ObjectRules, ADeskSeenAtTwoHeightsIsOnePieceByItsFootprint) {
  EXPECT_EQ(DeskPieces(0.0), 3u);  // the voxels 4 cm apart never meet
  EXPECT_EQ(DeskPieces(0.6), 2u);  // the far view lies within the near one's footprint
  EXPECT_EQ(DeskPieces(1.0), 3u);  // no footprint holds more than all of another
}

// The near end (y 0-1.0) and the far end (x 0.21-0.8, y 0.4-1.5) of one desk, 4 cm apart in
// height: 55 % of the smaller piece's footprint lies under the other. On fr1_rpy the main desk came
// out as two such pieces (55 %) in the demo's run, and the book on its near end stood on the wrong
// one (docs/results.md, session 35). Physically two tops cannot share floor at one height, so the
// majority (config/server.yaml: 0.5) joins them; the back-to-back desk shares none.
TEST(ObjectRules, TheTwoEndsOfOneDeskJoinWhenMostOfOneLiesUnderTheOther) {
  EXPECT_EQ(DeskPieces(0.6, 1.0, 0.4), 3u);
  EXPECT_EQ(DeskPieces(0.5, 1.0, 0.4), 2u);
  EXPECT_EQ(DeskPieces(0.5, 1.0, 0.75), 3u);  // 33 %: pieces that only overlap a little stay apart
}

// A "mouse" 0.41 m long: fr1_rpy's bench map fused mouse boxes at the main monitor's foot into one
// (session 26). Seen in 6 keyframes over 1.5 s, it is confirmed only when no size prior holds it;
// a 0.12 m mouse is confirmed either way.
bool MouseConfirmed(double length_m, double class_size_slack) {
  FusionOptions opt = WithSizes(class_size_slack);
  opt.max_size_m["mouse"] = 0.25;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  int64_t id = 0;
  for (int64_t kf = 1; kf <= 6; ++kf) {
    id = map.Integrate({Rect("mouse", 0.6, 1, kf, 0.0, length_m, 0.0, 0.06, 0.78)}, &changes)[0];
  }
  return map.Find(map.Resolve(id))->confirmed();
}

TEST(ObjectRules, AnObjectTooLongForItsClassIsNotConfirmed) {
  EXPECT_TRUE(MouseConfirmed(0.41, 0.0));   // no prior
  EXPECT_FALSE(MouseConfirmed(0.41, 1.5));  // longer than 1.5 x 0.25 m
  EXPECT_TRUE(MouseConfirmed(0.12, 1.5));
  EXPECT_TRUE(MouseConfirmed(0.12, 0.0));
}

// fr1_rpy's monitor at the back right returns no depth; views cut by the image border gave a
// "tv" of the wall and window beside and behind it, 0.36-0.38 m along its thinnest side over 7-8
// views (session 40), where the map's real monitors are 0.05-0.20 m. Seen in 6 keyframes over
// 1.5 s, the thick one is confirmed only when no thickness prior holds it; a panel with its foot
// is confirmed either way.
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

TEST(ObjectRules, ATvThickerThanAPanelIsNotConfirmed) {
  EXPECT_TRUE(TvConfirmed(0.38, false));  // no prior
  EXPECT_FALSE(TvConfirmed(0.38, true));
  EXPECT_TRUE(TvConfirmed(0.2, true));
  EXPECT_TRUE(TvConfirmed(0.06, true));
}

// fr1_rpy start 60 (session 40): blurred views call the main monitor "laptop" with boxes that hold
// the keyboard before it. Such a view joins the keyboard or the monitor, and the merge rules then
// found the one inside the other by all their voxels: one object, the monitor lost. Merges now
// compare what shapes each object (its own class's views), and the two stay apart.
TEST(ObjectRules, LaptopViewsOverAKeyboardAndAMonitorDoNotMergeThem) {
  FusionOptions opt = WithSizes(1.5);
  opt.max_size_m["keyboard"] = 0.7;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const Eigen::Vector3d step(0.02, 0.02, 0.02);
  int64_t keyboard = 0, tv = 0;
  for (int64_t kf = 1; kf <= 6; ++kf) {
    const std::vector<int64_t> ids =
        map.Integrate({Grid("keyboard", 1, kf, {0.5, 0.0, 0.76}, {0.95, 0.16, 0.8}, step),
                       Grid("tv", 2, kf, {0.5, 0.36, 0.86}, {0.95, 0.42, 1.2}, step)},
                      &changes);
    keyboard = ids[0];
    tv = ids[1];
  }
  ASSERT_NE(keyboard, tv);
  // The "laptop" boxes: the keyboard and the screen above and behind it.
  for (int64_t kf = 7; kf <= 9; ++kf) {
    map.Integrate({Grid("laptop", 0, kf, {0.5, 0.0, 0.76}, {0.95, 0.42, 1.2}, step)}, &changes);
  }
  EXPECT_NE(map.Resolve(tv), map.Resolve(keyboard));
  EXPECT_EQ(map.Find(map.Resolve(keyboard))->labels().Argmax(), "keyboard");
  EXPECT_EQ(map.Find(map.Resolve(tv))->labels().Argmax(), "tv");
}

// Each track its own object before merging (association by track only).
FusionOptions TrackOnly(double merge_box_containment) {
  FusionOptions opt = WithSizes(1.5);
  opt.weight_centroid = 0;
  opt.weight_overlap = 0;
  opt.merge_box_containment = merge_box_containment;
  return opt;
}

// A level desk top (half sizes hx, hy, turned by yaw about z) with its front face down to
// z_bottom, 2 cm apart: one view as the mapper builds it.
MapObservation DeskTop(int64_t track, int64_t kf, const Eigen::Vector2d& centre, double hx,
                       double hy, double yaw, double z_top, double z_bottom) {
  MapObservation o = Rect("dining table", 0.6, track, kf, 0, -1, 0, -1, 0);  // no points yet
  const Eigen::Rotation2Dd R(yaw);
  for (double u = -hx; u <= hx + 1e-9; u += 0.02) {
    for (double v = -hy; v <= hy + 1e-9; v += 0.02) {
      const Eigen::Vector2d p = centre + R * Eigen::Vector2d(u, v);
      o.points_m.push_back({Eigen::Vector3f(p.x(), p.y(), z_top), 0});
      if (v <= -hy + 1e-9) {  // the front face
        for (double z = z_bottom; z < z_top - 1e-9; z += 0.02) {
          o.points_m.push_back({Eigen::Vector3f(p.x(), p.y(), z), 0});
        }
      }
    }
  }
  o.centroid_m = Eigen::Vector3d(centre.x(), centre.y(), z_top);
  o.half_size_m = std::max(hx, hy);
  return o;
}

TEST(ObjectRules, DesksSetDiagonallyAreNotMergedByTheirBoxes) {
  // fr1_rpy's desks back to back, turned 45 deg to the map's axes (the map's x is the first
  // camera's heading; session 26): the main desk (1.56 x 0.83 m, top at 0.77 m) seen whole,
  // and a 0.5 x 0.4 m piece of the person's desk (top 3 cm lower) just beyond the seam. The
  // piece's map-frame box lies inside the main desk's box, though the two tops never meet.
  const double yaw = M_PI / 4;
  const Eigen::Vector2d across(-std::sin(yaw), std::cos(yaw));  // the desks' short axis
  auto tables = [&](const std::vector<std::string>& flat_top_classes) {
    FusionOptions opt = TrackOnly(0.75);
    opt.flat_top_classes = flat_top_classes;
    ObjectMap map(opt, 0.01);
    std::vector<ObjectChange> changes;
    map.Integrate({DeskTop(1, 1, {0, 0}, 0.78, 0.415, yaw, 0.77, 0.45)}, &changes);
    const Eigen::Vector2d piece = (0.415 + 0.22) * across;  // 2 cm beyond the seam
    map.Integrate({DeskTop(2, 2, piece, 0.25, 0.2, yaw, 0.74, 0.45)}, &changes);
    return map.size();
  };
  EXPECT_EQ(tables({}), 1u);                // boxes of any class: merged by box containment
  EXPECT_EQ(tables({"dining table"}), 2u);  // tables: their boxes are no solids
}

TEST(ObjectRules, SameClassBoxesThatOverlapAreOneObject) {
  // A monitor 3.3 m away (x is the viewing direction): its screen and back 12 cm apart, then a
  // view of its upper right part that depth noise (~z^2) puts between them: no common 3 cm
  // voxel, centroids 0.13 m apart, its box inside the first one's.
  for (double containment : {1.0, 0.75}) {
    ObjectMap map(TrackOnly(containment), 0.01);
    std::vector<ObjectChange> changes;
    map.Integrate({Grid("tv", 1, 1, {0, 0, 0.8}, {0.12, 0.5, 1.2}, {0.12, 0.01, 0.01})}, &changes);
    map.Integrate({Grid("tv", 2, 2, {0.045, 0.25, 0.95}, {0.075, 0.48, 1.18}, {0.03, 0.01, 0.01})},
                  &changes);
    EXPECT_EQ(map.size(), containment < 1 ? 1u : 2u) << containment;
  }
  // Two books side by side, 0.2 m apart, 4 cm thick: their boxes overlap by a fifth; two books.
  ObjectMap map(TrackOnly(0.75), 0.01);
  std::vector<ObjectChange> changes;
  const Eigen::Vector3d step(0.01, 0.01, 0.02);
  map.Integrate({Grid("book", 1, 1, {0, 0, 0.81}, {0.25, 0.19, 0.85}, step)}, &changes);
  map.Integrate({Grid("book", 2, 1, {0.20, 0, 0.81}, {0.46, 0.25, 0.85}, step)}, &changes);
  EXPECT_EQ(map.size(), 2u);
}

// Two cups 0.126 m apart, each seen by its own robot (session, track) in 3 views: the same thing
// at 3.2 m on fr1_rpy's far desk (two robots' poses and depth noise put it in two places), and the
// mug and pen holder 0.12 m apart at 0.9 m.
size_t CupsAt(double range_m, double merge_sigmas, double second_range_m = -1) {
  FusionOptions opt = TrackOnly(0.75);
  opt.merge_sigmas = merge_sigmas;
  ObjectMap map(opt, 0.01);
  std::vector<ObjectChange> changes;
  const Eigen::Vector3d step(0.01, 0.01, 0.01), size(0.1, 0.1, 0.12);
  const Eigen::Vector3d a(-1.58, 1.65, 1.02), b(-1.54, 1.61, 0.91);  // 0.126 m apart
  for (int64_t kf = 1; kf <= 3; ++kf) {
    MapObservation first = Grid("cup", 1, kf, a - size / 2, a + size / 2, step);
    MapObservation second = Grid("cup", 2, 10 + kf, b - size / 2, b + size / 2, step);
    first.range_m = range_m;
    second.range_m = second_range_m < 0 ? range_m : second_range_m;
    second.session_row = 2;
    map.Integrate({first}, &changes);
    map.Integrate({second}, &changes);
  }
  return map.size();
}

TEST(ObjectRules, FarObjectsMergeWithinTheirRangeUncertainty) {
  EXPECT_EQ(CupsAt(3.2, 1.0), 1u);       // gate sqrt(2) * s(3.2 m) = 0.19 m
  EXPECT_EQ(CupsAt(0.9, 1.0), 2u);       // gate 0.1 m (merge_centroid_m): s(0.9 m) = 0.024 m
  EXPECT_EQ(CupsAt(3.2, 0.0), 2u);       // off
  EXPECT_EQ(CupsAt(0.0, 1.0), 2u);       // range unknown
  EXPECT_EQ(CupsAt(0.9, 1.0, 3.2), 2u);  // a near object does not take in a far view's blob
}

// A camera at the map origin (optical frame = map frame) sees a flat surface 1 m ahead with two
// 10 cm mice on it: a real one at x = -0.15 m, detected in two views of three, and a box that
// recurs at x = +0.15 m (a monitor's foot) in 4 of 30 views. Returns whether each ends confirmed
// and whether the recurring one is still in the map (real_present: the real mouse is there).
struct MiceResult {
  bool real_confirmed = false, recurring_confirmed = false, recurring_kept = false;
};
MiceResult Mice(double class_prior_views, bool real_present) {
  FusionOptions opt = WithSizes(1.5);
  opt.existence_class_prior_views = class_prior_views;
  ObjectMap map(opt, 0.01);
  const PinholeCamera camera = PinholeCamera::TumFr1();
  const cv::Mat depth_m(480, 640, CV_32FC1, cv::Scalar(1.0f));
  std::vector<ObjectChange> changes;
  int64_t real = 0, recurring = 0;
  for (int64_t kf = 1; kf <= 30; ++kf) {
    std::vector<MapObservation> seen;
    std::vector<Detection2D> boxes;
    auto detect = [&](double x0) {
      seen.push_back(Rect("mouse", 0.6, 0, kf, x0, x0 + 0.1, -0.05, 0.05, 1.0));
      Detection2D d;
      d.class_name = "mouse";
      const Eigen::Vector2d corner = *camera.Project({x0, -0.05, 1.0});
      d.box_px = cv::Rect2f(corner.x(), corner.y(), 0.1 * camera.fx, 0.1 * camera.fy);
      boxes.push_back(d);
    };
    if (real_present && kf % 3 != 0) detect(-0.2);
    if (kf <= 3 || kf == 20) detect(0.1);
    const std::vector<int64_t> ids = map.Integrate(seen, &changes);
    if (real_present && kf % 3 != 0) real = ids.front();
    if (kf == 1) recurring = ids.back();
    map.ObserveView(kf, {&camera, &depth_m, 1, SE3d::Identity(), &boxes}, ids, &changes);
  }
  MiceResult r;
  const FusedObject* real_object = map.Find(map.Resolve(real));
  const FusedObject* recurring_object = map.Find(map.Resolve(recurring));
  r.real_confirmed = real_object && real_object->confirmed();
  r.recurring_kept = recurring_object != nullptr;
  r.recurring_confirmed = recurring_object && recurring_object->confirmed();
  return r;
}

TEST(ObjectRules, ARecurringBoxIsJudgedByHowOftenItsClassIsSeen) {
  // One rate for every class (0.15): 4 hits in 30 views pass as a rarely detected real object.
  MiceResult off = Mice(0.0, true);
  EXPECT_TRUE(off.real_confirmed);
  EXPECT_TRUE(off.recurring_confirmed);
  // The class's rate from the real mouse (2 in 3, with 50 views of prior at 0.15: 0.34): the
  // recurring box is a candidate, kept with its evidence, not confirmed.
  MiceResult on = Mice(50.0, true);
  EXPECT_TRUE(on.real_confirmed);
  EXPECT_TRUE(on.recurring_kept);
  EXPECT_FALSE(on.recurring_confirmed);
  // Alone, it has no class rate to be judged by but the base one.
  EXPECT_TRUE(Mice(50.0, false).recurring_confirmed);
}

// A camera at the map origin sees a desk top (1.0 x 0.6 m at map z 1.5, 1.5 m ahead), boxed as
// "dining table" in 3 keyframes of 80 (kf 1, 10, 20): a cluttered desk, as fr1_rpy's main desk
// under its monitors. With things on it, a keyboard and a mug detected in every keyframe.
// Returns "confirmed", "candidate" or "removed" for the desk.
std::string RarelyBoxedDesk(int confirm_loads, bool with_loads) {
  FusionOptions opt = TableOptions();
  opt.existence_class_prior_views = 0;
  opt.top_loads.confirm_loads = confirm_loads;
  ObjectMap map(opt, 0.01);
  const PinholeCamera camera = PinholeCamera::TumFr1();
  const cv::Mat depth_m(480, 640, CV_32FC1, cv::Scalar(1.5f));
  const Eigen::Vector3d step(0.01, 0.01, 0.01);
  std::vector<ObjectChange> changes;
  int64_t desk = 0;
  for (int64_t kf = 1; kf <= 80; ++kf) {
    std::vector<MapObservation> seen;
    if (with_loads) {
      seen.push_back(Grid("keyboard", 1, kf, {-0.2, -0.1, 1.5}, {0.25, 0.05, 1.53}, step));
      seen.push_back(Grid("cup", 2, kf, {0.3, 0.1, 1.5}, {0.4, 0.2, 1.6}, step));
    }
    const bool boxed = kf == 1 || kf == 10 || kf == 20;
    if (boxed) seen.push_back(Rect("dining table", 0.4, 3, kf, -0.5, 0.5, -0.3, 0.3, 1.5));
    const std::vector<int64_t> ids = map.Integrate(seen, &changes);
    if (kf == 1) desk = ids.back();
    const std::vector<Detection2D> boxes;  // no box excuses the desk's misses
    map.ObserveView(kf, {&camera, &depth_m, 1, SE3d::Identity(), &boxes}, ids, &changes);
  }
  const FusedObject* object = map.Find(map.Resolve(desk));
  if (object == nullptr) return "removed";
  return object->confirmed() ? "confirmed" : "candidate";
}

TEST(ObjectRules, ADeskThatThingsRestOnIsRealHoweverRarelyItIsBoxed) {
  // 3 hits and 77 misses at p_real 0.15: LLR 3 x 1.61 - 77 x 0.13 = -5.4, under remove_llr.
  EXPECT_EQ(RarelyBoxedDesk(0, true), "removed");
  EXPECT_EQ(RarelyBoxedDesk(2, false), "removed");
  // The keyboard and the mug rest on its top: it is a real top, confirmed and kept.
  EXPECT_EQ(RarelyBoxedDesk(2, true), "confirmed");
  EXPECT_EQ(RarelyBoxedDesk(3, true), "removed");  // two loads are not three
}

}  // namespace
}  // namespace loci::server

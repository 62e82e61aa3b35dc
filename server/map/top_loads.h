// A table top runs on under what rests on it. The map object of a desk holds the top the camera
// sees between the monitors, keyboard and books standing on it, so its box and centroid cover
// only that part, often a strip in front. ExtendTopsUnderLoads widens the footprint of each
// confirmed piece of flat-topped furniture (a table) to take in the footprints of the confirmed
// objects resting on its top: an object whose box bottom lies at most max_gap_m (plus its class's
// stand) above the top's height and at most max_sink_m below it, and whose footprint comes within
// reach_m of the table's, or of the part of the table already grown under other loads.
// Footprints are the outlines of the oriented boxes (common/footprint.h; map frame, z up), else
// of the axis-aligned boxes: a desk piece turned 40 deg to the map's axes has an axis-aligned box
// that holds the books on the desk beside it. An object near two tables rests on the one its
// footprint overlaps most, then the one nearest, then the one whose top is closest to its
// bottom. Only footprints change: the top's height, the table's label and evidence stay; the
// centroid moves with its box's centre.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/map_object.h"

namespace loci::server {

struct TopLoadOptions {
  // Horizontal distance from a table's footprint within which an object at its top's height
  // rests on it, m. 0: off (tables keep the footprint of their own points).
  double reach_m = 0.15;
  // Box bottom at most this above the top's height, m: a thing resting on the top (a foot's
  // height).
  double max_gap_m = 0.05;
  // Per class, the stand or feet its points leave out, m: a monitor's points end at its panel,
  // so its box bottom may lie this much more than max_gap_m above the top it stands on
  // (config/classes.yaml `stand_m`; the query's "on" allows the same).
  std::map<std::string, double> stand_m = {{"tv", 0.25}};
  // ... and at most this below it, m: a box reaches under the top it rests on when it caught some
  // of the top's own points, and two desks' tops a few cm apart must not decide by that alone
  // which desk a book lies on (its footprint does).
  double max_sink_m = 0.1;
  // An unconfirmed piece of such furniture seen at least this often (a desk the detector
  // rarely boxes under its monitors and keyboard) still takes the loads it holds best: they
  // widen no confirmed table, whose top would otherwise run on across it (0: off).
  int rival_min_views = 3;
  // A piece of such furniture that holds at least this many confirmed loads (each resting on it
  // better than on any other table or rival piece) is a real top, however rarely the detector
  // boxes it: it is confirmed from confirm_observations views on and never removed for the views
  // that missed it (0: off). A cluttered desk is boxed in a few views in a hundred, and a false
  // box that recurs at one spot does not carry a keyboard, a monitor and a cup at its height.
  int confirm_loads = 2;
  // Things that stand on the floor hold no top up: two chairs on a "table" piece of floor around
  // a kitchen table do not make it one (loads for confirm_loads only).
  std::vector<std::string> floor_classes = {"chair", "couch", "bed", "bench", "person"};
  // A thing resting on a top reaches down to it (LowerLoadsOntoTops; false: off).
  bool lower_loads = true;
};

// Widens the tables among `objects` (flat_top_classes, confirmed, with a top height) in place,
// in rounds: a top grown under one load reaches the next (the mouse beside the keyboard). Each
// load joins one table; tables are never loads. Unconfirmed pieces with rival_min_views views
// compete for the loads and are not widened.
void ExtendTopsUnderLoads(const std::vector<std::string>& flat_top_classes,
                          const TopLoadOptions& options, std::vector<MapObject>* objects);

// A thing resting on a top reaches down to it: the camera sees a monitor's panel and not its
// stand, a cup's rim and not its foot. Each confirmed load (not furniture, not of floor_classes)
// whose box bottom lies above the top of the confirmed table it rests on best (after
// ExtendTopsUnderLoads) gets its boxes extended down to the top's height: the axis-aligned box,
// the oriented box when one of its axes is within 20 deg of up, the centroid (the box centre)
// and bottom_z_m. Loads whose boxes already reach the top are left as they are.
void LowerLoadsOntoTops(const std::vector<std::string>& flat_top_classes,
                        const TopLoadOptions& options, std::vector<MapObject>* objects);

// Ids of the confirmed loads among `objects` (a snapshot that ExtendTopsUnderLoads widened and
// LowerLoadsOntoTops did not lower yet) that LowerLoadsOntoTops lowers onto one of the tables
// `table_ids`: when only a table changed, their snapshots changed too.
std::vector<int64_t> LoadsLoweredOnto(const std::vector<int64_t>& table_ids,
                                      const std::vector<std::string>& flat_top_classes,
                                      const TopLoadOptions& options,
                                      const std::vector<MapObject>& objects);

// Ids of the tables among `objects` (a snapshot that ExtendTopsUnderLoads widened) that one of
// `loads` rests on (RestsOn; a load that is gone or unconfirmed as it was last): when only a
// load changed, the table's snapshot changed too. Tables among `loads` are no loads.
std::vector<int64_t> TablesUnderLoads(const std::vector<std::string>& flat_top_classes,
                                      const TopLoadOptions& options,
                                      const std::vector<MapObject>& loads,
                                      const std::vector<MapObject>& objects);

// How many confirmed objects among `objects` (not furniture, not of floor_classes) rest on the
// table or rival piece `table_id` better than on any other (the first round of
// ExtendTopsUnderLoads: no widening); 0 when `table_id` is neither.
int LoadsHeldBy(int64_t table_id, const std::vector<std::string>& flat_top_classes,
                const TopLoadOptions& options, const std::vector<MapObject>& objects);

// Horizontal distance between two axis-aligned boxes' footprints (map frame, z up), m; 0 when
// they overlap.
double FootprintDistanceM(const Eigen::Vector3d& a_min, const Eigen::Vector3d& a_max,
                          const Eigen::Vector3d& b_min, const Eigen::Vector3d& b_max);

// Whether `load` rests on `table` by those rules; when it does, its footprint's distance to the
// table's in *distance_m and the share of its footprint over the table's in *overlap (either may
// be null). The heights and the boxes' distance are tested before any outline is made.
bool RestsOn(const MapObject& load, const MapObject& table, const TopLoadOptions& options,
             double* distance_m, double* overlap);

}  // namespace loci::server

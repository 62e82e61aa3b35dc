// Ground-truth scenes (objects.json layout): every "on" relation is answered correctly, "what is
// on the Y" lists exactly the ground truth, counts are right, negatives say no. Runs on the
// synthetic office generator (through an objects.json round trip) and on `loci synth` scenes.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <random>
#include <set>

#include "absl/strings/str_cat.h"
#include "common/objects_json.h"
#include "query/query_engine.h"
#include "query/synthetic_map.h"
#include "synth/scene.h"

namespace loci::query {
namespace {

std::set<int64_t> IdSet(const AskResult& r) {
  std::set<int64_t> ids;
  for (const MapObject& o : r.objects) ids.insert(o.id);
  return ids;
}

// Checks the scene's "on" ground truth through questions.
void CheckScene(const GroundTruthScene& scene) {
  QueryOptions options = QueryOptions::Defaults();
  options.max_result_objects = 100000;
  const QueryEngine engine(options);
  const auto index = engine.Index(MapObjectsFromGroundTruth(scene), scene.up);
  std::map<int64_t, const GroundTruthObject*> by_id;
  std::map<int64_t, std::set<int64_t>> on_gt;  // support id -> ids on it
  std::map<std::string, int64_t> class_count;
  for (const GroundTruthObject& g : scene.objects) {
    by_id[g.id] = &g;
    ++class_count[g.class_name];
    if (g.on_id != 0) on_gt[g.on_id].insert(g.id);
  }
  ASSERT_FALSE(on_gt.empty());
  // "what is on #Y" lists exactly the ground truth, for every object (empty for most).
  for (const GroundTruthObject& y : scene.objects) {
    const AskResult r = engine.Ask("what is on #" + std::to_string(y.id), *index, AskContext{});
    ASSERT_TRUE(r.status.ok()) << r.answer;
    const std::set<int64_t> expected = on_gt.count(y.id) ? on_gt[y.id] : std::set<int64_t>{};
    EXPECT_EQ(IdSet(r), expected) << "#" << y.id << " " << y.class_name << ": " << r.answer;
    EXPECT_EQ(r.count, static_cast<int64_t>(expected.size()));
  }
  // "is the #X on the #Y" says yes for every pair; "where is the X on the Y" finds #X.
  size_t checked = 0;
  for (const GroundTruthObject& x : scene.objects) {
    if (x.on_id == 0) continue;
    // (StrCat: GCC 12 sees a false -Wrestrict in "#" + std::to_string(...), bug 105329.)
    const std::string pair = absl::StrCat("#", x.id, " on #", x.on_id);
    const AskResult yes = engine.Ask("is " + pair, *index, AskContext{});
    EXPECT_EQ(yes.yes, true) << pair << ": " << yes.answer;
    if (checked++ < 300) {
      const AskResult where =
          engine.Ask("where is the " + x.class_name + " on the " + by_id[x.on_id]->class_name,
                     *index, AskContext{});
      EXPECT_TRUE(IdSet(where).count(x.id)) << pair << ": " << where.answer;
    }
  }
  // Per class pair: "how many X are on the Y" equals the ground truth.
  std::map<std::pair<std::string, std::string>, int64_t> pair_count;
  for (const GroundTruthObject& x : scene.objects) {
    if (x.on_id != 0) ++pair_count[{x.class_name, by_id[x.on_id]->class_name}];
  }
  const Vocabulary& vocab = index->vocabulary();
  for (const auto& [classes, n] : pair_count) {
    const std::string q =
        "how many " + vocab.Plural(classes.first) + " are on the " + classes.second;
    EXPECT_EQ(engine.Ask(q, *index, AskContext{}).count, n) << q;
  }
  for (const auto& [cls, n] : class_count) {
    const std::string q = "how many " + vocab.Plural(cls) + " are there";
    EXPECT_EQ(engine.Ask(q, *index, AskContext{}).count, n) << q;
  }
  // Negatives: nothing stands on an object of a class that never supports anything.
  for (const auto& [cls, n] : class_count) {
    bool supports = false;
    for (const auto& [y, xs] : on_gt) supports |= by_id[y]->class_name == cls;
    if (supports) continue;
    const AskResult r = engine.Ask("is there anything on the " + cls, *index, AskContext{});
    EXPECT_EQ(r.yes, false) << cls << ": " << r.answer;
  }
}

TEST(SyntheticSceneTest, OfficeRoundTripThroughObjectsJson) {
  SyntheticMapOptions o;
  o.object_count = 600;
  o.seed = 7;
  const GroundTruthScene scene = MakeSyntheticOffice(o);
  ASSERT_EQ(scene.objects.size(), 600u);
  const std::string path =
      (std::filesystem::temp_directory_path() / "loci_query_test_objects.json").string();
  ASSERT_TRUE(WriteObjectsJson(path, scene).ok());
  auto read = ReadObjectsJson(path);
  ASSERT_TRUE(read.ok()) << read.status();
  std::filesystem::remove(path);
  CheckScene(*read);
}

TEST(SyntheticSceneTest, TenThousandObjectsCountsAndSupports) {
  const GroundTruthScene scene = MakeSyntheticOffice({});
  ASSERT_EQ(scene.objects.size(), 10000u);
  const QueryEngine engine;
  const auto index = engine.Index(MapObjectsFromGroundTruth(scene));
  int64_t chairs = 0, books_on_shelves = 0;
  std::map<int64_t, std::string> class_of;
  for (const auto& g : scene.objects) class_of[g.id] = g.class_name;
  for (const auto& g : scene.objects) {
    chairs += g.class_name == "chair";
    books_on_shelves += g.class_name == "book" && g.on_id && class_of[g.on_id] == "shelf";
  }
  EXPECT_EQ(engine.Ask("how many chairs are there", *index, {}).count, chairs);
  EXPECT_EQ(engine.Ask("how many books are on the shelves", *index, {}).count, books_on_shelves);
  EXPECT_EQ(engine.Ask("list all objects", *index, {}).count, 10000);
}

// Fused boxes are never exact: jitter every box face by N(0, 5 mm) and the centroid with it; the
// "on" answers must still match the ground truth exactly.
TEST(SyntheticSceneTest, NoisyBoxesKeepOnRelations) {
  SyntheticMapOptions o;
  o.object_count = 400;
  o.seed = 11;
  GroundTruthScene scene = MakeSyntheticOffice(o);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.005);
  for (GroundTruthObject& g : scene.objects) {
    for (int k = 0; k < 3; ++k) {
      g.aabb_min_m[k] += noise(rng);
      g.aabb_max_m[k] += noise(rng);
    }
    g.centroid_m = 0.5 * (g.aabb_min_m + g.aabb_max_m);
    g.extent_m = g.aabb_max_m - g.aabb_min_m;
  }
  CheckScene(scene);
}

// The scenes of `loci synth` (synth/scene.h): table, shelf and up to 40 objects on them or on
// the floor, for many seeds.
TEST(SyntheticSceneTest, LociSynthScenes) {
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    synth::SceneOptions o;
    o.seed = seed;
    o.num_frames = 1;
    o.num_objects = 10 + static_cast<int>(seed % 4) * 10;
    o.dynamic = seed % 2 == 0;
    auto scene = synth::MakeScene(o);
    ASSERT_TRUE(scene.ok()) << scene.status();
    SCOPED_TRACE("synth seed " + std::to_string(seed));
    CheckScene(synth::ToGroundTruth(*scene));
  }
}

}  // namespace
}  // namespace loci::query

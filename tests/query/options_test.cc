// Query options: the shipped config/query.yaml loads and matches the defaults where it should;
// bad values are rejected with the key named.
#include <gtest/gtest.h>

#include "common/config.h"
#include "query/query_options.h"

namespace loci::query {
namespace {

TEST(QueryOptionsTest, ShippedConfigLoads) {
  auto o = LoadQueryOptions(SourceDir() + "/config/query.yaml");
  ASSERT_TRUE(o.ok()) << o.status();
  EXPECT_EQ(o->Validate(), "");
  const QueryOptions d = QueryOptions::Defaults();
  EXPECT_DOUBLE_EQ(o->relations.on_gap_sigma_m, d.relations.on_gap_sigma_m);
  EXPECT_DOUBLE_EQ(o->relations.near_max_m, d.relations.near_max_m);
  EXPECT_EQ(o->synonyms.at("monitor"), std::vector<std::string>{"tv"});
  EXPECT_EQ(o->synonyms.at("desk"), std::vector<std::string>{"dining table"});
  EXPECT_EQ(o->classes.size(), d.classes.size());
  EXPECT_TRUE(o->default_up_map.isApprox(Eigen::Vector3d::UnitZ()));
}

TEST(QueryOptionsTest, OverridesAndRejects) {
  auto o = QueryOptionsFromYaml(YAML::Load(
      "relations: {near_max_m: 2.5}\nsynonyms: {telly: [tv]}\ndefault_up_map: [0, 1, 0]"));
  ASSERT_TRUE(o.ok()) << o.status();
  EXPECT_DOUBLE_EQ(o->relations.near_max_m, 2.5);
  EXPECT_EQ(o->synonyms.at("telly"), std::vector<std::string>{"tv"});
  EXPECT_EQ(o->synonyms.at("sofa"), std::vector<std::string>{"couch"});  // defaults kept
  EXPECT_TRUE(o->default_up_map.isApprox(Eigen::Vector3d::UnitY()));

  auto bad = QueryOptionsFromYaml(YAML::Load("relations: {on_min_overlap: 1.5}"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(std::string(bad.status().message()).find("on_min_overlap"), std::string::npos);
  EXPECT_FALSE(QueryOptionsFromYaml(YAML::Load("relations: {near_min_m: abc}")).ok());
  // The stands are a class prior of config/classes.yaml (shared with the map), not a query key.
  auto stand = QueryOptionsFromYaml(YAML::Load("relations: {on_stand_m: {tv: 0.1}}"));
  ASSERT_FALSE(stand.ok());
  EXPECT_NE(std::string(stand.status().message()).find("on_stand_m"), std::string::npos);
  EXPECT_FALSE(QueryOptionsFromYaml(YAML::Load("default_up_map: [0, 0]")).ok());
  EXPECT_FALSE(QueryOptionsFromYaml(YAML::Load("default_up_map: [0, 0, 0]")).ok());
  EXPECT_FALSE(LoadQueryOptions("/nonexistent/query.yaml").ok());
}

}  // namespace
}  // namespace loci::query

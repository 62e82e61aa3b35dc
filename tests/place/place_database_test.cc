// The inverted index: tf-idf ranking, the exclusion window of the querying robot's newest
// keyframes, scores in [0, 1], duplicate ids.
#include "server/place/place_database.h"

#include <gtest/gtest.h>

#include <random>

namespace loci::place {
namespace {

// n random ORB-shaped descriptors.
cv::Mat RandomDescriptors(int n, uint64_t seed) {
  cv::Mat m(n, 32, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

QueryOptions Window(int recent) {
  QueryOptions q;
  q.exclude_recent_keyframes = recent;
  q.max_candidates = 5;
  q.min_score = 0.0;
  return q;
}

TEST(MakeBowTest, TermFrequenciesSumToOneAndSkipNoWord) {
  const BowVector bow = MakeBow({3, 1, 3, kNoWord, 3});
  ASSERT_EQ(bow.counts.size(), 2u);
  EXPECT_EQ(bow.total, 4u);
  EXPECT_EQ(bow.counts[0].first, 1u);
  EXPECT_FLOAT_EQ(bow.Tf(0), 0.25f);
  EXPECT_FLOAT_EQ(bow.Tf(1), 0.75f);
}

TEST(PlaceDatabaseTest, FindsTheKeyframeSharingWordsAndRanksByOverlap) {
  PlaceDatabase db(VocabularyOptions{}, Window(0));
  std::vector<cv::Mat> places;
  for (int p = 0; p < 20; ++p) places.push_back(RandomDescriptors(300, 100 + p));
  for (int p = 0; p < 20; ++p) {
    ASSERT_TRUE(db.Insert(p, "a", db.Quantise(places[p], true)).ok());
  }
  // A view of place 7 sharing 200 of its 300 descriptors, and 100 of place 3's.
  cv::Mat query;
  cv::vconcat(places[7].rowRange(0, 200), places[3].rowRange(0, 100), query);
  const std::vector<PlaceCandidate> c = db.Query(db.Quantise(query, false), "b");
  ASSERT_GE(c.size(), 2u);
  EXPECT_EQ(c[0].keyframe_id, 7);
  EXPECT_EQ(c[1].keyframe_id, 3);
  EXPECT_EQ(c[0].robot, "a");
  EXPECT_GT(c[0].score, c[1].score);
  EXPECT_NEAR(c[0].score, 2.0 / 3.0, 0.02);  // shares 2/3 of the query's (equal-idf) mass
  EXPECT_LE(c[0].score, 1.0);
}

TEST(PlaceDatabaseTest, ExcludesOnlyTheQueryingRobotsNewestKeyframes) {
  PlaceDatabase db(VocabularyOptions{}, Window(3));
  const cv::Mat place = RandomDescriptors(200, 1);
  // Other places (robot c), so that the place's words are not in every keyframe (idf 0).
  for (int p = 0; p < 10; ++p) {
    ASSERT_TRUE(db.Insert(100 + p, "c", db.Quantise(RandomDescriptors(200, 50 + p), true)).ok());
  }
  // The same place seen by robot a (ids 0..5) and once by robot b (id 10).
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(db.Insert(i, "a", db.Quantise(place, true)).ok());
  ASSERT_TRUE(db.Insert(10, "b", db.Quantise(place, true)).ok());
  std::vector<int64_t> ids;
  for (const PlaceCandidate& c : db.Query(db.Quantise(place, false), "a")) {
    ids.push_back(c.keyframe_id);
  }
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<int64_t>{0, 1, 2, 10}));  // a's newest 3 (3, 4, 5) left out
  // Robot b's window holds only its own keyframe 10.
  ids.clear();
  for (const PlaceCandidate& c : db.Query(db.Quantise(place, false), "b")) {
    ids.push_back(c.keyframe_id);
  }
  EXPECT_EQ(ids.size(), 5u);  // max_candidates of a's six
  EXPECT_EQ(std::count(ids.begin(), ids.end(), 10), 0);
}

// A robot that revisits a place: its newest views of it score highest and fill the candidates,
// while its first visit, before its local-map window, follows the best with older_candidates.
TEST(PlaceDatabaseTest, OlderCandidatesBringTheFirstVisitBackBehindTheBest) {
  const cv::Mat place = RandomDescriptors(300, 7);
  // A keyframe `share` of whose 300 descriptors are the place's, the rest its own.
  auto view = [&](double share, uint64_t seed) {
    const int n = static_cast<int>(share * 300);
    if (n == 0) return RandomDescriptors(300, seed);
    cv::Mat m;
    cv::vconcat(place.rowRange(0, n), RandomDescriptors(300 - n, seed), m);
    return m;
  };
  auto fill = [&](PlaceDatabase* db) {
    for (int p = 0; p < 10; ++p) {  // other places (robot c), so the place's words have idf > 0
      ASSERT_TRUE(db->Insert(100 + p, "c", db->Quantise(RandomDescriptors(300, 50 + p), true)).ok());
    }
    // Robot a: its first visit (ids 0..2, 30 % of the place), 40 keyframes elsewhere, then the
    // place again (ids 43..52, 60 %).
    for (int i = 0; i < 53; ++i) {
      const double share = i < 3 ? 0.3 : i < 43 ? 0.0 : 0.6;
      ASSERT_TRUE(db->Insert(i, "a", db->Quantise(view(share, 1000 + i), true)).ok());
    }
  };
  QueryOptions q = Window(0);
  q.min_score = 0.05;
  q.older_candidates = 0;
  PlaceDatabase plain(VocabularyOptions{}, q);
  fill(&plain);
  const cv::Mat query = view(0.6, 999);
  std::vector<int64_t> ids;
  for (const PlaceCandidate& c : plain.Query(plain.Quantise(query, false), "a")) {
    ids.push_back(c.keyframe_id);
  }
  ASSERT_EQ(ids.size(), 5u);
  for (int64_t id : ids) EXPECT_GE(id, 43) << "the newest views of the place rank first";
  q.older_candidates = 2;
  q.older_than_keyframes = 30;
  PlaceDatabase diverse(VocabularyOptions{}, q);
  fill(&diverse);
  const std::vector<PlaceCandidate> c = diverse.Query(diverse.Quantise(query, false), "a");
  ASSERT_EQ(c.size(), 7u);
  EXPECT_EQ(c[0].keyframe_id, ids[0]);  // the best stays first
  EXPECT_LT(c[1].keyframe_id, 3);       // then the first visit's two best
  EXPECT_LT(c[2].keyframe_id, 3);
  EXPECT_GE(c[1].score, c[2].score);
  EXPECT_LT(c[1].score, c[0].score);
  for (size_t i = 3; i < c.size(); ++i) EXPECT_EQ(c[i].keyframe_id, ids[i - 2]);
  // Another robot's query gets no such candidates: the window is the querying robot's.
  EXPECT_EQ(diverse.Query(diverse.Quantise(query, false), "b").size(), 5u);
  // With no window every keyframe of the robot may follow the best: the two best not among the
  // five, here the second visit's sixth and seventh.
  q.older_than_keyframes = 0;
  PlaceDatabase no_window(VocabularyOptions{}, q);
  fill(&no_window);
  const std::vector<PlaceCandidate> all = no_window.Query(no_window.Quantise(query, false), "a");
  ASSERT_EQ(all.size(), 7u);
  EXPECT_GE(all[1].keyframe_id, 43);
  EXPECT_GE(all[2].keyframe_id, 43);
  // Within the window there is nothing older to add.
  q.older_than_keyframes = 60;
  PlaceDatabase short_robot(VocabularyOptions{}, q);
  fill(&short_robot);
  EXPECT_EQ(short_robot.Query(short_robot.Quantise(query, false), "a").size(), 5u);
}

TEST(PlaceDatabaseTest, UnrelatedPlacesScoreBelowMinScore) {
  QueryOptions q = Window(0);
  q.min_score = 0.05;
  PlaceDatabase db(VocabularyOptions{}, q);
  for (int p = 0; p < 10; ++p) {
    ASSERT_TRUE(db.Insert(p, "a", db.Quantise(RandomDescriptors(300, 200 + p), true)).ok());
  }
  EXPECT_TRUE(db.Query(db.Quantise(RandomDescriptors(300, 999), true), "b").empty());
}

TEST(PlaceDatabaseTest, RefusesDuplicateIdsAndUnknownWords) {
  PlaceDatabase db(VocabularyOptions{}, Window(0));
  const BowVector bow = db.Quantise(RandomDescriptors(10, 1), true);
  ASSERT_TRUE(db.Insert(1, "a", bow).ok());
  EXPECT_EQ(db.Insert(1, "b", bow).code(), absl::StatusCode::kAlreadyExists);
  BowVector bad;
  bad.counts.emplace_back(static_cast<WordId>(db.words() + 5), 1);
  bad.total = 1;
  EXPECT_EQ(db.Insert(2, "a", bad).code(), absl::StatusCode::kInvalidArgument);
  BowVector wrong_total = bow;
  wrong_total.total += 1;
  EXPECT_EQ(db.Insert(3, "a", wrong_total).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(db.keyframes(), 1u);
}

// A posting keeps a word's count in 8 bits: a bag queried against itself scores 1, and a word
// seen more than 255 times in one keyframe still counts, saturated.
TEST(PlaceDatabaseTest, ABagScoresOneAgainstItselfAndSaturatedCountsStillScore) {
  PlaceDatabase db(VocabularyOptions{}, Window(0));
  ASSERT_TRUE(db.Insert(0, "a", db.Quantise(RandomDescriptors(200, 5), true)).ok());
  ASSERT_GE(db.words(), 150u);
  std::vector<WordId> plain, repeated;
  for (WordId w = 0; w < 60; ++w) plain.insert(plain.end(), {w, w});
  for (int i = 0; i < 300; ++i) repeated.push_back(100);
  for (WordId w = 101; w < 120; ++w) repeated.push_back(w);
  ASSERT_TRUE(db.Insert(1, "a", MakeBow(plain)).ok());
  ASSERT_TRUE(db.Insert(2, "a", MakeBow(repeated)).ok());
  // Spread the words' idf: keyframes 3.. hold other words only.
  for (int k = 3; k < 8; ++k) {
    ASSERT_TRUE(db.Insert(k, "a", MakeBow({static_cast<WordId>(140 + k)})).ok());
  }
  const std::vector<PlaceCandidate> same = db.Query(MakeBow(plain), "b");
  ASSERT_FALSE(same.empty());
  EXPECT_EQ(same[0].keyframe_id, 1);
  EXPECT_NEAR(same[0].score, 1.0, 1e-5);
  const std::vector<PlaceCandidate> saturated = db.Query(MakeBow(repeated), "b");
  ASSERT_FALSE(saturated.empty());
  EXPECT_EQ(saturated[0].keyframe_id, 2);
  EXPECT_LT(saturated[0].score, 1.0);
  EXPECT_GT(saturated[0].score, 0.8);
}

}  // namespace
}  // namespace loci::place

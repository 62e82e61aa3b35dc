// The incremental vocabulary: words found again, new words for new descriptors, splits that keep
// every word findable, and k-majority clustering.
#include <gtest/gtest.h>

#include <random>

#include "server/place/incremental_vocabulary.h"

namespace loci::place {
namespace {

Descriptor256 RandomDescriptor(std::mt19937_64& rng) { return {rng(), rng(), rng(), rng()}; }

// d with `bits` distinct bits flipped.
Descriptor256 Flip(Descriptor256 d, int bits, std::mt19937_64& rng) {
  std::vector<int> order(256);
  for (int i = 0; i < 256; ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  for (int i = 0; i < bits; ++i) d[order[i] / 64] ^= uint64_t{1} << (order[i] % 64);
  return d;
}

TEST(IncrementalVocabularyTest, NearDescriptorsShareAWordFarOnesFoundNewWords) {
  std::mt19937_64 rng(7);
  VocabularyOptions o;
  IncrementalVocabulary v(o);
  const Descriptor256 d = RandomDescriptor(rng);
  EXPECT_EQ(v.Quantise(d, false), kNoWord);  // empty vocabulary, nothing added
  EXPECT_EQ(v.size(), 0u);
  const WordId w = v.Quantise(d, true);
  EXPECT_EQ(w, 0u);
  EXPECT_EQ(v.Quantise(d, true), w);
  EXPECT_EQ(v.Quantise(Flip(d, o.word_max_hamming, rng), true), w);  // at the threshold
  EXPECT_EQ(v.size(), 1u);
  const Descriptor256 far = Flip(d, o.word_max_hamming + 1, rng);
  EXPECT_EQ(v.Quantise(far, false), kNoWord);
  EXPECT_EQ(v.Quantise(far, true), 1u);
  EXPECT_EQ(v.size(), 2u);
}

TEST(IncrementalVocabularyTest, EveryWordIsFoundAgainAfterManySplits) {
  std::mt19937_64 rng(11);
  VocabularyOptions o;
  IncrementalVocabulary v(o);
  std::vector<Descriptor256> words;
  for (int i = 0; i < 20000; ++i) words.push_back(RandomDescriptor(rng));
  for (size_t i = 0; i < words.size(); ++i) ASSERT_EQ(v.Quantise(words[i], true), i);
  EXPECT_EQ(v.size(), words.size());  // random descriptors are ~128 bits apart: all new words
  EXPECT_GE(v.depth(), 2);            // 20000 / 256 words per leaf: more than 16 leaves
  for (size_t i = 0; i < words.size(); ++i) {
    ASSERT_EQ(v.Quantise(words[i], false), i) << "word " << i << " lost after the splits";
    EXPECT_EQ(v.word(static_cast<WordId>(i)), words[i]);
  }
}

TEST(IncrementalVocabularyTest, QuantisesRowsOfADescriptorMatrix) {
  std::mt19937_64 rng(3);
  cv::Mat m(5, 32, CV_8UC1);
  cv::randu(m, 0, 256);
  VocabularyOptions o;
  IncrementalVocabulary v(o);
  const std::vector<WordId> words = v.Quantise(m, true);
  ASSERT_EQ(words.size(), 5u);
  EXPECT_EQ(v.Quantise(m, false), words);
  EXPECT_TRUE(v.Quantise(cv::Mat(5, 16, CV_8UC1), true).empty());  // not ORB-shaped
}

TEST(KMajorityTest, SeparatesTwoClusters) {
  std::mt19937_64 rng(5);
  const Descriptor256 a = RandomDescriptor(rng), b = RandomDescriptor(rng);
  std::vector<Descriptor256> items;
  for (int i = 0; i < 20; ++i) items.push_back(Flip(i % 2 ? a : b, 10, rng));
  std::vector<Descriptor256> centres;
  const std::vector<int> labels = KMajority(items, 2, 10, 1, &centres);
  ASSERT_EQ(centres.size(), 2u);
  for (int i = 2; i < 20; ++i) EXPECT_EQ(labels[i], labels[i % 2]) << i;
  EXPECT_NE(labels[0], labels[1]);
  // The majority of 10 noisy copies is (nearly) the clean descriptor.
  EXPECT_LE(std::min(Hamming(centres[0], a), Hamming(centres[1], a)), 3);
}

}  // namespace
}  // namespace loci::place

// A vocabulary of binary words that grows with the map (the choice is argued in README.md): a
// descriptor belongs to the nearest existing word within word_max_hamming bits, or founds a new
// word. Words live in the leaves of a tree; a leaf that holds more than max_leaf_words words is
// split into `branching` children by k-majority clustering (bitwise-majority centres, as in
// DBoW2's training). A search descends to the nearest centre at each level and then visits up to
// search_leaves leaves in the order of their centres' distances (a priority search like FLANN's
// `checks`), so finding a word costs about search_leaves * (branching * depth + max_leaf_words)
// Hamming distances whatever the vocabulary's size. It is approximate, like any vocabulary tree:
// a descriptor may miss its word when that sits beyond the leaves visited. A new word joins the
// first leaf visited.
//
// Word ids are dense (0, 1, 2, ...) and never change. Deterministic: the same descriptors in
// the same order give the same words. Not thread-safe.
#pragma once

#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "server/place/binary_descriptor.h"
#include "server/place/place_options.h"

namespace loci::place {

using WordId = uint32_t;
inline constexpr WordId kNoWord = std::numeric_limits<WordId>::max();

class IncrementalVocabulary {
 public:
  explicit IncrementalVocabulary(const VocabularyOptions& options);

  // The word of each row of `descriptors` (CV_8UC1, 32 columns; other shapes give no words).
  // With add_words, rows farther than word_max_hamming from every word become new words;
  // without, they get kNoWord.
  std::vector<WordId> Quantise(const cv::Mat& descriptors, bool add_words);
  WordId Quantise(const Descriptor256& d, bool add_words);

  size_t size() const { return words_.size(); }
  const Descriptor256& word(WordId id) const { return words_[id]; }
  // Deepest leaf, for statistics (the root is depth 0).
  int depth() const { return max_depth_seen_; }

 private:
  struct Node {
    std::vector<Descriptor256> centres;      // internal node: one per child
    std::vector<int> children;               // internal node: indices into nodes_
    std::vector<WordId> words;               // leaf: the words it holds ...
    std::vector<Descriptor256> descriptors;  // ... and their descriptors (a contiguous scan)
    int depth = 0;
    int split_at = 0;  // leaf: split when holding more words than this
  };

  // The leaves a search visits, in order.
  struct LeafList {
    int count = 0;
    int leaves[kMaxSearchLeaves];
  };

  // A search in two steps: the descents to the leaves (nearest centres first), which depend
  // only on the tree, and the scan of those leaves for the nearest word within
  // word_max_hamming (kNoWord if none). A new word joins the first leaf of the list.
  void CollectLeaves(const Descriptor256& d, LeafList* out) const;
  WordId ScanLeaves(const Descriptor256& d, const LeafList& list) const;
  void SplitLeaf(int leaf);

  VocabularyOptions options_;
  std::vector<Node> nodes_;  // nodes_[0] is the root
  std::vector<Descriptor256> words_;
  int max_depth_seen_ = 0;
};

// k-majority clustering of binary descriptors: `k` centres (bitwise majority of their members)
// after at most `iterations` rounds from a deterministic k-means++ start (seeded by `seed`).
// Returns the cluster of each item; clusters may end up fewer than k (empty ones dropped,
// labels stay dense).
std::vector<int> KMajority(const std::vector<Descriptor256>& items, int k, int iterations,
                           uint64_t seed, std::vector<Descriptor256>* centres);

}  // namespace loci::place

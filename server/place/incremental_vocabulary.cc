#include "server/place/incremental_vocabulary.h"

#include <algorithm>
#include <queue>
#include <random>
#include <utility>

#include "server/place/keyframe_features.h"

namespace loci::place {
namespace {

constexpr int kSplitIterations = 10;
// Bytes of each visited leaf fetched ahead of its scan (a leaf holds up to 32 bytes per word).
constexpr size_t kPrefetchBytes = 1024;

// Index of the centre nearest d (the first of equals).
int Nearest(const std::vector<Descriptor256>& centres, const Descriptor256& d) {
  int best = 0, best_dist = 257;
  for (size_t c = 0; c < centres.size(); ++c) {
    const int dist = Hamming(centres[c], d);
    if (dist < best_dist) {
      best_dist = dist;
      best = static_cast<int>(c);
    }
  }
  return best;
}

// Bitwise majority of the items with label `label` (a bit is set when more than half have it).
Descriptor256 Majority(const std::vector<Descriptor256>& items, const std::vector<int>& labels,
                       int label) {
  int counts[256] = {};
  int n = 0;
  for (size_t i = 0; i < items.size(); ++i) {
    if (labels[i] != label) continue;
    ++n;
    for (int b = 0; b < 256; ++b)
      counts[b] += static_cast<int>((items[i][b / 64] >> (b % 64)) & 1u);
  }
  Descriptor256 centre{};
  for (int b = 0; b < 256; ++b) {
    if (2 * counts[b] > n) centre[b / 64] |= uint64_t{1} << (b % 64);
  }
  return centre;
}

// k-means++ seeding: each next centre drawn with probability proportional to the squared
// distance to the nearest centre chosen so far.
LOCI_POPCNT_CLONES std::vector<Descriptor256> SeedCentres(const std::vector<Descriptor256>& items,
                                                          int k, std::mt19937_64& rng) {
  std::vector<Descriptor256> centres{items[rng() % items.size()]};
  std::vector<double> weight(items.size());
  while (static_cast<int>(centres.size()) < k) {
    double total = 0;
    for (size_t i = 0; i < items.size(); ++i) {
      const int d = Hamming(items[i], centres[Nearest(centres, items[i])]);
      weight[i] = static_cast<double>(d) * d;
      total += weight[i];
    }
    if (total <= 0) break;  // every item equals a centre
    double pick = std::uniform_real_distribution<double>(0, total)(rng);
    size_t i = 0;
    while (i + 1 < items.size() && pick >= weight[i]) pick -= weight[i++];
    centres.push_back(items[i]);
  }
  return centres;
}

// Drops empty clusters and renumbers the labels densely.
void CompactLabels(std::vector<int>* labels, std::vector<Descriptor256>* centres) {
  std::vector<int> remap(centres->size(), -1);
  std::vector<Descriptor256> kept;
  for (int& l : *labels) {
    if (remap[l] < 0) {
      remap[l] = static_cast<int>(kept.size());
      kept.push_back((*centres)[l]);
    }
    l = remap[l];
  }
  *centres = std::move(kept);
}

}  // namespace

LOCI_POPCNT_CLONES std::vector<int> KMajority(const std::vector<Descriptor256>& items, int k,
                                              int iterations, uint64_t seed,
                                              std::vector<Descriptor256>* centres) {
  std::vector<int> labels(items.size(), 0);
  if (items.empty()) {
    centres->clear();
    return labels;
  }
  std::mt19937_64 rng(seed);
  *centres = SeedCentres(items, k, rng);
  for (int it = 0; it < iterations; ++it) {
    bool changed = it == 0;
    for (size_t i = 0; i < items.size(); ++i) {
      const int l = Nearest(*centres, items[i]);
      changed |= l != labels[i];
      labels[i] = l;
    }
    if (!changed) break;
    for (size_t c = 0; c < centres->size(); ++c) {
      if (std::find(labels.begin(), labels.end(), static_cast<int>(c)) != labels.end()) {
        (*centres)[c] = Majority(items, labels, static_cast<int>(c));
      }
    }
  }
  CompactLabels(&labels, centres);
  return labels;
}

IncrementalVocabulary::IncrementalVocabulary(const VocabularyOptions& options)
    : options_(options), nodes_(1) {
  options_.search_leaves = std::clamp(options_.search_leaves, 1, kMaxSearchLeaves);
  nodes_[0].split_at = options_.max_leaf_words;
}

LOCI_POPCNT_CLONES void IncrementalVocabulary::CollectLeaves(const Descriptor256& d,
                                                             LeafList* out) const {
  using Entry = std::pair<int, int>;  // (distance to the branch's centre, node)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> branches;
  branches.emplace(0, 0);
  out->count = 0;
  while (out->count < options_.search_leaves && !branches.empty()) {
    int n = branches.top().second;
    branches.pop();
    while (!nodes_[n].children.empty()) {  // descend, remembering the other branches
      const Node& node = nodes_[n];
      const int nearest = Nearest(node.centres, d);
      for (size_t c = 0; c < node.children.size(); ++c) {
        if (static_cast<int>(c) != nearest) {
          branches.emplace(Hamming(node.centres[c], d), node.children[c]);
        }
      }
      n = node.children[nearest];
    }
    out->leaves[out->count++] = n;
    // The leaf is scanned later: start fetching its descriptors now, so that the cache misses
    // of several leaves overlap (the hardware prefetcher follows each stream).
    const std::vector<Descriptor256>& words = nodes_[n].descriptors;
    const char* bytes = reinterpret_cast<const char*>(words.data());
    const size_t size = words.size() * sizeof(Descriptor256);
    for (size_t at = 0; at < size && at < kPrefetchBytes; at += 64) __builtin_prefetch(bytes + at);
  }
}

LOCI_POPCNT_CLONES WordId IncrementalVocabulary::ScanLeaves(const Descriptor256& d,
                                                            const LeafList& list) const {
  WordId best = kNoWord;
  int best_dist = options_.word_max_hamming + 1;
  for (int l = 0; l < list.count; ++l) {
    const Node& leaf = nodes_[list.leaves[l]];
    for (size_t i = 0; i < leaf.descriptors.size(); ++i) {
      const int dist = Hamming(leaf.descriptors[i], d);
      if (dist < best_dist) {
        best_dist = dist;
        best = leaf.words[i];
      }
    }
  }
  return best;
}

WordId IncrementalVocabulary::Quantise(const Descriptor256& d, bool add_words) {
  LeafList list;
  CollectLeaves(d, &list);
  const WordId best = ScanLeaves(d, list);
  if (best != kNoWord || !add_words || list.count == 0) return best;
  const int leaf = list.leaves[0];
  const WordId id = static_cast<WordId>(words_.size());
  words_.push_back(d);
  nodes_[leaf].words.push_back(id);
  nodes_[leaf].descriptors.push_back(d);
  if (nodes_[leaf].words.size() > static_cast<size_t>(nodes_[leaf].split_at) &&
      nodes_[leaf].depth < options_.max_depth) {
    SplitLeaf(leaf);
  }
  return id;
}

std::vector<WordId> IncrementalVocabulary::Quantise(const cv::Mat& descriptors, bool add_words) {
  std::vector<WordId> out;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes) return out;
  out.reserve(descriptors.rows);
  for (int r = 0; r < descriptors.rows; ++r) {
    out.push_back(Quantise(DescriptorRow(descriptors, r), add_words));
  }
  return out;
}

LOCI_POPCNT_CLONES void IncrementalVocabulary::SplitLeaf(int leaf) {
  const std::vector<Descriptor256> items = nodes_[leaf].descriptors;
  std::vector<Descriptor256> centres;
  KMajority(items, options_.branching, kSplitIterations, static_cast<uint64_t>(leaf), &centres);
  // Words go where FindLeaf will look for them: to the nearest final centre.
  std::vector<int> route(items.size());
  std::vector<int> members(centres.size(), 0);
  for (size_t i = 0; i < items.size(); ++i) ++members[route[i] = Nearest(centres, items[i])];
  if (std::count_if(members.begin(), members.end(), [](int m) { return m > 0; }) < 2) {
    nodes_[leaf].split_at *= 2;  // no structure to split on: try again when twice as full
    return;
  }
  const int child_depth = nodes_[leaf].depth + 1;
  max_depth_seen_ = std::max(max_depth_seen_, child_depth);
  std::vector<int> children;
  for (size_t c = 0; c < centres.size(); ++c) {
    children.push_back(static_cast<int>(nodes_.size()));
    Node child;
    child.depth = child_depth;
    child.split_at = options_.max_leaf_words;
    nodes_.push_back(std::move(child));
  }
  for (size_t i = 0; i < items.size(); ++i) {
    nodes_[children[route[i]]].words.push_back(nodes_[leaf].words[i]);
    nodes_[children[route[i]]].descriptors.push_back(items[i]);
  }
  Node& parent = nodes_[leaf];
  parent.words.clear();
  parent.words.shrink_to_fit();
  parent.descriptors.clear();
  parent.descriptors.shrink_to_fit();
  parent.centres = std::move(centres);
  parent.children = std::move(children);
}

}  // namespace loci::place

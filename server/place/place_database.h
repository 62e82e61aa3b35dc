// Place recognition over every stored keyframe of every robot: bags of words of an
// IncrementalVocabulary, tf-idf weighted, and an inverted index (word -> keyframes holding it).
//
// Score of a stored keyframe d for a query q (both bags L1-normalised term frequencies tf):
//   s(q, d) = sum_w idf(w) * min(tf_q(w), tf_d(w))  /  sum_w idf(w) * tf_q(w)
//   idf(w)  = log((N + 1) / (n_w + 1)),  N keyframes indexed, n_w of them holding w
// the share of the query's tf-idf mass that d holds too (0..1; DBoW2's L1 score is the same
// histogram intersection on weighted, normalised vectors). The inverted index makes a query
// cost the postings of the query's words, not the number of keyframes. idf is evaluated at
// query time, so weights follow the growing map. Not thread-safe: one owner serialises calls.
#pragma once

#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "common/status.h"
#include "server/place/incremental_vocabulary.h"
#include "server/place/place_options.h"

namespace loci::place {

// A keyframe's bag of words: (word, count) sorted by word id, out of `total` quantised
// descriptors (descriptors without a word are left out). A word's term frequency is its share.
struct BowVector {
  std::vector<std::pair<WordId, uint32_t>> counts;
  uint32_t total = 0;  // the sum of the counts
  float Tf(size_t i) const {
    return static_cast<float>(counts[i].second) / static_cast<float>(total);
  }
};
BowVector MakeBow(const std::vector<WordId>& words);

struct PlaceCandidate {
  int64_t keyframe_id = 0;
  std::string robot;
  double score = 0;  // s(q, d) above, 0..1
};

class PlaceDatabase {
 public:
  PlaceDatabase(const VocabularyOptions& vocabulary, const QueryOptions& query);

  // The bag of words of a keyframe's descriptors (CV_8UC1, 32 columns). With add_words its
  // descriptors that match no word found new ones (for a keyframe about to be inserted).
  BowVector Quantise(const cv::Mat& descriptors, bool add_words);

  // Indexes a keyframe of `robot`; AlreadyExists when the id is indexed already, InvalidArgument
  // for a bag with a word the vocabulary lacks or counts that do not sum to its total,
  // ResourceExhausted past kMaxKeyframes.
  static constexpr uint32_t kMaxKeyframes = 1u << 24;
  Status Insert(int64_t keyframe_id, const std::string& robot, const BowVector& bow);

  // The best max_candidates keyframes for the bag `bow` of a keyframe of `robot`, best first,
  // each with score >= min_score; the newest exclude_recent_keyframes keyframes that `robot`
  // inserted are left out (other robots' keyframes never are). The best older_candidates of
  // `robot`'s keyframes before its newest older_than_keyframes that are not among them follow
  // the first.
  std::vector<PlaceCandidate> Query(const BowVector& bow, const std::string& robot) const;

  size_t keyframes() const { return docs_.size(); }
  size_t words() const { return vocabulary_.size(); }
  const IncrementalVocabulary& vocabulary() const { return vocabulary_; }

 private:
  // A posting packs the document (index into docs_, the high 24 bits) and the word's count in
  // it (the low 8 bits, saturated at 255): 4 bytes a posting, the bulk of the index's memory
  // (700-830 postings a keyframe at 1000 features).
  using Posting = uint32_t;
  struct Doc {
    int64_t keyframe_id;
    int robot;        // index into robot_names_
    float inv_total;  // 1 / the bag's total: a posting's tf is its count times this
  };
  static void Append(std::vector<Posting>* postings, Posting p);

  static bool Better(const std::pair<float, uint32_t>& a, const std::pair<float, uint32_t>& b);
  // The best QueryOptions::older_candidates of `robot`'s keyframes before its newest
  // older_than_keyframes among ranked[k..] (score, doc).
  std::vector<std::pair<float, uint32_t>> OlderOwn(
      const std::vector<std::pair<float, uint32_t>>& ranked, size_t k,
      const std::string& robot) const;
  double Idf(WordId w) const;
  std::vector<uint32_t> ExcludedDocs(const std::string& robot) const;

  QueryOptions query_options_;
  IncrementalVocabulary vocabulary_;
  std::vector<std::vector<Posting>> postings_;  // by word id
  std::vector<Doc> docs_;
  std::map<int64_t, uint32_t> doc_of_keyframe_;
  std::vector<std::string> robot_names_;
  std::map<std::string, std::vector<uint32_t>> docs_of_robot_;  // in insertion order
};

}  // namespace loci::place

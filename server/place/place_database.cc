#include "server/place/place_database.h"

#include <algorithm>
#include <cmath>

namespace loci::place {

BowVector MakeBow(const std::vector<WordId>& words) {
  std::vector<WordId> sorted;
  sorted.reserve(words.size());
  for (const WordId w : words) {
    if (w != kNoWord) sorted.push_back(w);
  }
  std::sort(sorted.begin(), sorted.end());
  BowVector bow;
  bow.total = static_cast<uint32_t>(sorted.size());
  for (const WordId w : sorted) {
    if (bow.counts.empty() || bow.counts.back().first != w) bow.counts.emplace_back(w, 0);
    ++bow.counts.back().second;
  }
  return bow;
}

PlaceDatabase::PlaceDatabase(const VocabularyOptions& vocabulary, const QueryOptions& query)
    : query_options_(query), vocabulary_(vocabulary) {}

BowVector PlaceDatabase::Quantise(const cv::Mat& descriptors, bool add_words) {
  return MakeBow(vocabulary_.Quantise(descriptors, add_words));
}

Status PlaceDatabase::Insert(int64_t keyframe_id, const std::string& robot, const BowVector& bow) {
  if (doc_of_keyframe_.count(keyframe_id)) {
    return absl::AlreadyExistsError(absl::StrCat("place database: keyframe ", keyframe_id));
  }
  if (docs_.size() >= kMaxKeyframes) {
    return absl::ResourceExhaustedError(
        absl::StrCat("place database: full at ", kMaxKeyframes, " keyframes"));
  }
  uint64_t sum = 0;
  for (const auto& [w, count] : bow.counts) {
    if (w >= vocabulary_.size()) {
      return absl::InvalidArgumentError(absl::StrCat("place database: unknown word ", w));
    }
    sum += count;
  }
  if (sum != bow.total) {
    return absl::InvalidArgumentError(
        absl::StrCat("place database: counts sum to ", sum, ", not the bag's total ", bow.total));
  }
  const uint32_t doc = static_cast<uint32_t>(docs_.size());
  auto robot_it = std::find(robot_names_.begin(), robot_names_.end(), robot);
  if (robot_it == robot_names_.end()) robot_it = robot_names_.insert(robot_names_.end(), robot);
  const float inv_total = bow.total > 0 ? 1.0f / static_cast<float>(bow.total) : 0.0f;
  docs_.push_back({keyframe_id, static_cast<int>(robot_it - robot_names_.begin()), inv_total});
  doc_of_keyframe_[keyframe_id] = doc;
  docs_of_robot_[robot].push_back(doc);
  if (postings_.size() < vocabulary_.size()) postings_.resize(vocabulary_.size());
  for (const auto& [w, count] : bow.counts) {
    Append(&postings_[w], doc << 8 | std::min<uint32_t>(count, 255));
  }
  return absl::OkStatus();
}

// Grows a posting list by a quarter rather than doubling it: the lists are the index's memory,
// and doubling leaves a third of it unused on average.
void PlaceDatabase::Append(std::vector<Posting>* postings, Posting p) {
  if (postings->size() == postings->capacity()) {
    postings->reserve(postings->capacity() + postings->capacity() / 4 + 2);
  }
  postings->push_back(p);
}

double PlaceDatabase::Idf(WordId w) const {
  const size_t n_w = w < postings_.size() ? postings_[w].size() : 0;
  return std::log((static_cast<double>(docs_.size()) + 1.0) / (static_cast<double>(n_w) + 1.0));
}

std::vector<uint32_t> PlaceDatabase::ExcludedDocs(const std::string& robot) const {
  const auto it = docs_of_robot_.find(robot);
  if (it == docs_of_robot_.end()) return {};
  const std::vector<uint32_t>& own = it->second;
  const size_t n =
      std::min(own.size(), static_cast<size_t>(query_options_.exclude_recent_keyframes));
  return {own.end() - static_cast<std::ptrdiff_t>(n), own.end()};
}

std::vector<PlaceCandidate> PlaceDatabase::Query(const BowVector& bow,
                                                 const std::string& robot) const {
  std::vector<float> score(docs_.size(), 0.0f);
  double query_mass = 0;
  for (size_t i = 0; i < bow.counts.size(); ++i) {
    const WordId w = bow.counts[i].first;
    const float tf_q = bow.Tf(i);
    const float idf = static_cast<float>(Idf(w));
    query_mass += idf * tf_q;
    if (w >= postings_.size()) continue;
    for (const Posting p : postings_[w]) {
      const uint32_t doc = p >> 8;
      const float tf_d = static_cast<float>(p & 0xffu) * docs_[doc].inv_total;
      score[doc] += idf * std::min(tf_q, tf_d);
    }
  }
  if (!(query_mass > 0)) return {};
  for (const uint32_t doc : ExcludedDocs(robot)) score[doc] = 0.0f;
  std::vector<std::pair<float, uint32_t>> ranked;
  const float min_score = static_cast<float>(query_options_.min_score * query_mass);
  for (uint32_t d = 0; d < score.size(); ++d) {
    if (score[d] > 0.0f && score[d] >= min_score) ranked.emplace_back(score[d], d);
  }
  const size_t k = std::min(ranked.size(), static_cast<size_t>(query_options_.max_candidates));
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(k), ranked.end(),
                    Better);
  std::vector<std::pair<float, uint32_t>> best(ranked.begin(),
                                               ranked.begin() + static_cast<std::ptrdiff_t>(k));
  const std::vector<std::pair<float, uint32_t>> older = OlderOwn(ranked, k, robot);
  best.insert(best.begin() + std::min<std::ptrdiff_t>(1, static_cast<std::ptrdiff_t>(best.size())),
              older.begin(), older.end());
  std::vector<PlaceCandidate> out;
  for (const auto& [s, d] : best) {
    const Doc& doc = docs_[d];
    out.push_back({doc.keyframe_id, robot_names_[doc.robot], s / query_mass});
  }
  return out;
}

bool PlaceDatabase::Better(const std::pair<float, uint32_t>& a,
                           const std::pair<float, uint32_t>& b) {
  return a.first != b.first ? a.first > b.first : a.second < b.second;
}

std::vector<std::pair<float, uint32_t>> PlaceDatabase::OlderOwn(
    const std::vector<std::pair<float, uint32_t>>& ranked, size_t k,
    const std::string& robot) const {
  std::vector<std::pair<float, uint32_t>> older;
  const auto it = docs_of_robot_.find(robot);
  const size_t window = static_cast<size_t>(query_options_.older_than_keyframes);
  if (query_options_.older_candidates <= 0 || it == docs_of_robot_.end() ||
      it->second.size() <= window) {
    return older;
  }
  // Docs are numbered in insertion order: the robot's older keyframes have smaller numbers than
  // its window's first (with no window, every one of its keyframes is older).
  const uint32_t first_in_window = window == 0 ? static_cast<uint32_t>(docs_.size())
                                               : it->second[it->second.size() - window];
  const int robot_index = docs_[it->second.front()].robot;
  for (size_t i = k; i < ranked.size(); ++i) {  // the ranked ones are among the best already
    const uint32_t d = ranked[i].second;
    if (d < first_in_window && docs_[d].robot == robot_index) older.push_back(ranked[i]);
  }
  const size_t n = std::min(older.size(), static_cast<size_t>(query_options_.older_candidates));
  std::partial_sort(older.begin(), older.begin() + static_cast<std::ptrdiff_t>(n), older.end(),
                    Better);
  older.resize(n);
  return older;
}

}  // namespace loci::place

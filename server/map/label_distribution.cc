#include "server/map/label_distribution.h"

#include <algorithm>
#include <cmath>

namespace loci::server {

LabelDistribution::LabelDistribution(int universe_size, double min_likelihood)
    : universe_size_(std::max(2, universe_size)), min_likelihood_(min_likelihood) {}

void LabelDistribution::Update(const std::string& class_name, double score) {
  const double s = std::clamp(score, min_likelihood_, 1.0 - min_likelihood_);
  // The universe grows when classes outside the configured list show up.
  if (!log_p_.count(class_name) && static_cast<int>(log_p_.size()) + 1 >= universe_size_) {
    ++universe_size_;
  }
  const double log_hit = std::log(s);
  const double log_miss = std::log((1.0 - s) / (universe_size_ - 1));
  if (!log_p_.count(class_name)) log_p_[class_name] = log_p_unseen_;
  for (auto& [name, lp] : log_p_) lp += (name == class_name) ? log_hit : log_miss;
  log_p_unseen_ += log_miss;
  // Keep the numbers bounded: shift so the largest is 0.
  double max_lp = log_p_unseen_;
  for (const auto& [name, lp] : log_p_) max_lp = std::max(max_lp, lp);
  for (auto& [name, lp] : log_p_) lp -= max_lp;
  log_p_unseen_ -= max_lp;
}

void LabelDistribution::Merge(const LabelDistribution& other) {
  // Uniform prior: the product of the posteriors, per class, over the union of observed classes.
  std::map<std::string, double> merged;
  for (const auto& [name, lp] : log_p_) {
    auto it = other.log_p_.find(name);
    merged[name] = lp + (it != other.log_p_.end() ? it->second : other.log_p_unseen_);
  }
  for (const auto& [name, lp] : other.log_p_) {
    if (!merged.count(name)) merged[name] = log_p_unseen_ + lp;
  }
  log_p_ = std::move(merged);
  log_p_unseen_ += other.log_p_unseen_;
  universe_size_ =
      std::max({universe_size_, other.universe_size_, static_cast<int>(log_p_.size()) + 1});
  double max_lp = log_p_unseen_;
  for (const auto& [name, lp] : log_p_) max_lp = std::max(max_lp, lp);
  for (auto& [name, lp] : log_p_) lp -= max_lp;
  log_p_unseen_ -= max_lp;
}

double LabelDistribution::LogNormaliser() const {
  double sum = 0;
  for (const auto& [name, lp] : log_p_) sum += std::exp(lp);
  const int unseen = universe_size_ - static_cast<int>(log_p_.size());
  sum += std::max(0, unseen) * std::exp(log_p_unseen_);
  return std::log(sum);
}

std::string LabelDistribution::Argmax() const {
  std::string best;
  double best_lp = -INFINITY;
  for (const auto& [name, lp] : log_p_) {
    if (lp > best_lp) {
      best_lp = lp;
      best = name;
    }
  }
  return best;
}

double LabelDistribution::Probability(const std::string& class_name) const {
  if (log_p_.empty()) return 0.0;
  auto it = log_p_.find(class_name);
  const double lp = it != log_p_.end() ? it->second : log_p_unseen_;
  return std::exp(lp - LogNormaliser());
}

std::vector<std::pair<std::string, double>> LabelDistribution::Observed() const {
  std::vector<std::pair<std::string, double>> out;
  double sum = 0;
  for (const auto& [name, lp] : log_p_) {
    out.emplace_back(name, std::exp(lp));
    sum += std::exp(lp);
  }
  for (auto& [name, p] : out) p /= sum;
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  return out;
}

}  // namespace loci::server

// Class distribution of one object, fused per observation with Bayes' rule (paper 004 III.D.2).
//
// The label universe has K classes (the detector's mapped classes). A detection of class c with
// score s is a measurement with likelihood s for c and (1 - s) / (K - 1) for every other class.
// Classes never observed share one per-class probability, so the set of stored classes grows
// only when a new class is seen (paper 004 adds l_n to the set). Stored in log space.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace loci::store::v1 {
class LabelState;
}  // namespace loci::store::v1

namespace loci::server {

class LabelDistribution {
 public:
  // universe_size = K (>= 2); min_likelihood clamps scores to [min, 1 - min].
  explicit LabelDistribution(int universe_size = 13, double min_likelihood = 0.05);

  // Posterior after one detection of `class_name` with confidence `score` in [0, 1].
  void Update(const std::string& class_name, double score);
  // Posterior of two independent evidence sets (duplicate objects merged): p ∝ pA * pB / prior.
  void Merge(const LabelDistribution& other);

  // Most probable observed class ("" when nothing observed) and its full posterior probability.
  std::string Argmax() const;
  double Probability(const std::string& class_name) const;
  // Observed classes with their probabilities renormalised over the observed set (sums to 1),
  // most probable first.
  std::vector<std::pair<std::string, double>> Observed() const;
  bool empty() const { return log_p_.empty(); }

  // Checkpoint state (map_checkpoint.cc); the options come from the constructor.
  void SaveState(loci::store::v1::LabelState* out) const;
  void LoadState(const loci::store::v1::LabelState& in);

 private:
  // log of the normaliser over the whole universe.
  double LogNormaliser() const;

  int universe_size_;
  double min_likelihood_;
  std::map<std::string, double> log_p_;  // unnormalised log posterior of observed classes
  double log_p_unseen_ = 0;              // unnormalised log posterior of each unseen class
};

}  // namespace loci::server

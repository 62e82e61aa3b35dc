// How often the detector finds each class in this map: the existence test's p_real per class.
//
// A detector's recall differs by class and by place (books lying flat: one view in six; a lit
// monitor: most views). A single p_real must be low enough for the worst class, so a false box
// that recurs at one spot (a "mouse" on a monitor's foot in 10 of 91 views) passes as easily as
// a real book. Each class's rate is estimated from the map's own confirmed objects of the class
// (empirical Bayes: a Beta prior of `prior_views` views at the base p_real, plus their hits and
// the views that should have shown them), leaving the judged object out, so an object is tested
// against how often its class is seen elsewhere in the map. The rate never falls below the base
// p_real: a class the detector finds rarely is judged as before.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "server/map/fused_object.h"

namespace loci::server {

class ClassDetectionRates {
 public:
  // base: the map's existence model; prior_views <= 0 turns the per-class rates off.
  ClassDetectionRates(const FusedObject::ExistenceModel& base, double prior_views)
      : base_(base), prior_views_(prior_views) {}

  // Counts a confirmed object: its hits and misses go to its most likely class.
  void Add(const FusedObject& object);
  // The existence model to judge `object` by: p_real from the other confirmed objects of its
  // class (what Add counted of it left out), at least the base p_real and at most kMaxRate.
  FusedObject::ExistenceModel For(const FusedObject& object) const;
  const FusedObject::ExistenceModel& base() const { return base_; }

  // One miss in ten stays possible for any class (a view's blur, a glare).
  static constexpr double kMaxRate = 0.9;

 private:
  struct Counts {
    double hits = 0, views = 0;
  };
  FusedObject::ExistenceModel base_;
  double prior_views_;
  std::map<std::string, Counts> classes_;
  std::map<int64_t, std::pair<std::string, Counts>> counted_;  // object id -> what Add counted
};

}  // namespace loci::server

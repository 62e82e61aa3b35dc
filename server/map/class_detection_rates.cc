#include "server/map/class_detection_rates.h"

#include <algorithm>

namespace loci::server {

void ClassDetectionRates::Add(const FusedObject& object) {
  if (prior_views_ <= 0) return;
  const std::string cls = object.labels().Argmax();
  const Counts own{double(object.observation_count()),
                   double(object.observation_count()) + object.misses()};
  Counts& c = classes_[cls];
  c.hits += own.hits;
  c.views += own.views;
  counted_[object.id()] = {cls, own};
}

FusedObject::ExistenceModel ClassDetectionRates::For(const FusedObject& object) const {
  if (prior_views_ <= 0) return base_;
  const std::string cls = object.labels().Argmax();
  const auto it = classes_.find(cls);
  if (it == classes_.end()) return base_;
  double hits = it->second.hits, views = it->second.views;
  const auto own = counted_.find(object.id());
  if (own != counted_.end() && own->second.first == cls) {
    hits -= own->second.second.hits;
    views -= own->second.second.views;
  }
  const double rate = (prior_views_ * base_.p_real + hits) / (prior_views_ + views);
  FusedObject::ExistenceModel model = base_;
  model.p_real = std::clamp(rate, base_.p_real, std::max(base_.p_real, kMaxRate));
  return model;
}

}  // namespace loci::server

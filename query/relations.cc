#include "query/relations.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "absl/strings/str_format.h"

namespace loci::query {
namespace {

struct KindInfo {
  RelationKind kind;
  const char* name;
  const char* phrase;
};
constexpr std::array<KindInfo, 13> kKinds = {{
    {RelationKind::kOn, "on", "on"},
    {RelationKind::kUnder, "under", "under"},
    {RelationKind::kAbove, "above", "above"},
    {RelationKind::kBelow, "below", "below"},
    {RelationKind::kNear, "near", "near"},
    {RelationKind::kNextTo, "next_to", "next to"},
    {RelationKind::kInside, "inside", "inside"},
    {RelationKind::kBetween, "between", "between"},
    {RelationKind::kNearest, "nearest", "nearest to"},
    {RelationKind::kLeftOf, "left_of", "to the left of"},
    {RelationKind::kRightOf, "right_of", "to the right of"},
    {RelationKind::kInFrontOf, "in_front_of", "in front of"},
    {RelationKind::kBehind, "behind", "behind"},
}};

double Clamp01(double v) { return std::clamp(v, 0.0, 1.0); }

// Fraction of `s`'s footprint over `a`'s: of the oriented footprints when both objects have one
// (common/footprint.h), else of their boxes'; a degenerate footprint counts by its centroid.
double FootprintFraction(const ObjectGeom& s, const ObjectGeom& a) {
  const double area = s.box.FootprintArea();
  const double oriented = PolygonArea(s.footprint_g);
  if (oriented > 1e-9 && PolygonArea(a.footprint_g) > 1e-9) {
    // An outline lies within its box: boxes apart, outlines apart (most pairs; cheap).
    if (area >= 1e-9 && FootprintOverlapArea(s.box, a.box) <= 0) return 0.0;
    return ConvexOverlapArea(s.footprint_g, a.footprint_g) / oriented;
  }
  if (area < 1e-9) {
    const Vec3d& c = s.centroid_g;
    return c.x() >= a.box.min.x() && c.x() <= a.box.max.x() && c.y() >= a.box.min.y() &&
                   c.y() <= a.box.max.y()
               ? 1.0
               : 0.0;
  }
  return FootprintOverlapArea(s.box, a.box) / area;
}

// Overlap as a fraction of the smaller footprint: of the oriented footprints when both objects
// have one (footprint.h), else of their boxes' footprints.
double FootprintFractionOfSmaller(const ObjectGeom& s, const ObjectGeom& a) {
  const double oriented = std::min(PolygonArea(s.footprint_g), PolygonArea(a.footprint_g));
  if (oriented > 1e-9) return ConvexOverlapArea(s.footprint_g, a.footprint_g) / oriented;
  const double smaller = std::min(s.box.FootprintArea(), a.box.FootprintArea());
  if (smaller < 1e-9) return std::max(FootprintFraction(s, a), FootprintFraction(a, s));
  return FootprintOverlapArea(s.box, a.box) / smaller;
}

std::string AboveBelow(double gap_m) {
  return absl::StrFormat("%.2f m %s", std::abs(gap_m), gap_m >= 0 ? "above" : "below");
}

}  // namespace

std::string_view RelationName(RelationKind kind) {
  for (const KindInfo& k : kKinds) {
    if (k.kind == kind) return k.name;
  }
  return "unknown";
}

std::string_view RelationPhrase(RelationKind kind) {
  for (const KindInfo& k : kKinds) {
    if (k.kind == kind) return k.phrase;
  }
  return "related to";
}

std::optional<RelationKind> RelationFromName(std::string_view name) {
  for (const KindInfo& k : kKinds) {
    if (name == k.name) return k.kind;
  }
  return std::nullopt;
}

bool NeedsViewpoint(RelationKind kind) {
  return kind == RelationKind::kLeftOf || kind == RelationKind::kRightOf ||
         kind == RelationKind::kInFrontOf || kind == RelationKind::kBehind;
}

RelationResult RelationEvaluator::Evaluate(RelationKind kind, const ObjectGeom& s,
                                           const ObjectGeom& a, const ViewpointG* viewpoint,
                                           bool with_evidence) const {
  RelationResult r;
  switch (kind) {
    case RelationKind::kOn:
      r = On(s, a, with_evidence);
      break;
    case RelationKind::kUnder:
      r = Under(s, a, with_evidence);
      break;
    case RelationKind::kAbove:
      r = Above(s, a, with_evidence);
      break;
    case RelationKind::kBelow:
      r = Below(s, a, with_evidence);
      break;
    case RelationKind::kNear:
    case RelationKind::kNearest:
      r = Near(s, a, with_evidence);
      break;
    case RelationKind::kNextTo:
      r = NextTo(s, a, with_evidence);
      break;
    case RelationKind::kInside:
      r = Inside(s, a, with_evidence);
      break;
    case RelationKind::kBetween:
      if (with_evidence) r.evidence = "between needs two anchors";
      break;
    default:
      r = Directional(kind, s, a, viewpoint, with_evidence);
      break;
  }
  r.kind = kind;
  r.subject_id = s.id;
  r.anchor_id = a.id;
  r.confidence = Clamp01(r.confidence);
  r.holds = r.holds && r.confidence >= opt_.min_confidence && s.id != a.id;
  return r;
}

RelationResult RelationEvaluator::On(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  // A class that stands on feet its points leave out (a monitor) may hover by their height.
  const auto stand = opt_.on_stand_m.find(s.class_name);
  const double stand_m = stand == opt_.on_stand_m.end() ? 0.0 : stand->second;
  const double raw_gap = s.bottom_z - a.top_z;
  const double gap = raw_gap > 0 ? std::max(0.0, raw_gap - stand_m) : raw_gap;
  const double overlap = FootprintFraction(s, a);
  // Penetration (negative gap) is common in fused boxes that caught a few support points, so it
  // is scored with twice the sigma.
  const double sigma = gap >= 0 ? opt_.on_gap_sigma_m : 2.0 * opt_.on_gap_sigma_m;
  r.confidence = std::exp(-0.5 * (gap / sigma) * (gap / sigma)) * (0.5 + 0.5 * Clamp01(overlap));
  // A thing resting on a surface rises above it: its top must be above the anchor's top (a
  // keyboard on a desk is not "on" the taller chair tucked under the desk). Not its centre: the
  // fused centre of a thin object (keyboard, 3 cm) can sit at the surface height.
  r.holds = std::abs(gap) <= opt_.on_max_gap_m && overlap >= opt_.on_min_overlap &&
            s.box.max.z() > a.top_z && s.size_m > 0;
  r.distance_m = std::abs(gap);
  if (ev) {
    r.evidence = absl::StrFormat("bottom %s the top surface (z %.2f m), footprint overlap %.2f",
                                 AboveBelow(raw_gap), a.top_z, overlap);
    if (stand_m > 0 && raw_gap > 0) {
      r.evidence += absl::StrFormat(" (a %s stands up to %.2f m above it)", s.class_name, stand_m);
    }
  }
  return r;
}

RelationResult RelationEvaluator::Under(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  const double overlap = FootprintFraction(s, a);
  // Below the anchor's top surface, as On measures it: a desk's box that caught a monitor reaches
  // far above its top, and the mouse on the desk is not under it.
  const double depth = a.top_z - s.centroid_g.z();
  r.confidence = 0.5 + 0.5 * Clamp01(overlap / std::max(0.6, opt_.under_min_overlap));
  const bool shelter = std::find(opt_.under_anchors.begin(), opt_.under_anchors.end(),
                                 a.class_name) != opt_.under_anchors.end();
  r.holds = shelter && overlap >= opt_.under_min_overlap && depth > opt_.vertical_tolerance_m &&
            s.box.min.z() < a.top_z - opt_.vertical_tolerance_m &&
            s.box.FootprintArea() <= a.box.FootprintArea() * 1.5;
  r.distance_m = std::max(0.0, a.box.min.z() - s.box.max.z());
  if (ev) {
    r.evidence = absl::StrFormat(
        "centre %.2f m below the top surface (z %.2f m), footprint "
        "overlap %.2f",
        depth, a.top_z, overlap);
  }
  return r;
}

RelationResult RelationEvaluator::Above(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  const double gap = s.bottom_z - a.box.max.z();
  const double overlap = FootprintFractionOfSmaller(s, a);
  r.confidence = 0.5 + 0.5 * Clamp01(overlap / std::max(0.6, opt_.above_min_overlap));
  // Its centre clears the anchor's top too: a desk piece 4 cm higher beside another (boxes
  // that overlap by a few centimetres of noise) is not above it.
  r.holds = gap >= -opt_.vertical_tolerance_m && overlap >= opt_.above_min_overlap &&
            s.centroid_g.z() > a.box.max.z() + opt_.vertical_tolerance_m;
  r.distance_m = std::max(0.0, gap);
  if (ev) {
    r.evidence = absl::StrFormat("bottom %s the top (z %.2f m), footprint overlap %.2f",
                                 AboveBelow(gap), a.box.max.z(), overlap);
  }
  return r;
}

RelationResult RelationEvaluator::Below(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  const double gap = a.bottom_z - s.box.max.z();
  const double overlap = FootprintFractionOfSmaller(s, a);
  r.confidence = 0.5 + 0.5 * Clamp01(overlap / std::max(0.6, opt_.above_min_overlap));
  // Its centre lies under the anchor's bottom too: two furniture tops that meet a few cm apart in
  // height have boxes overlapping by a few cm, which alone would put the lower under the higher.
  r.holds = gap >= -opt_.vertical_tolerance_m && overlap >= opt_.above_min_overlap &&
            s.centroid_g.z() < a.bottom_z - opt_.vertical_tolerance_m;
  r.distance_m = std::max(0.0, gap);
  if (ev) {
    r.evidence =
        absl::StrFormat("top %.2f m %s the bottom (z %.2f m), footprint overlap %.2f",
                        std::abs(gap), gap >= 0 ? "below" : "above", a.bottom_z, overlap);
  }
  return r;
}

double RelationEvaluator::NearThreshold(const ObjectGeom& s, const ObjectGeom& a) const {
  return std::clamp(opt_.near_factor * 0.5 * (s.size_m + a.size_m), opt_.near_min_m,
                    opt_.near_max_m);
}

RelationResult RelationEvaluator::Near(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  const double gap = BoxGap(s.box, a.box);
  const double threshold = NearThreshold(s, a);
  r.confidence = 1.0 - 0.5 * gap / threshold;
  r.holds = gap <= threshold;
  r.distance_m = gap;
  if (ev) {
    r.evidence = absl::StrFormat("boxes %.2f m apart (near within %.2f m), centres %.2f m apart",
                                 gap, threshold, (s.centroid_g - a.centroid_g).norm());
  }
  return r;
}

RelationResult RelationEvaluator::NextTo(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  const double hgap = HorizontalGap(s.box, a.box);
  const double level = std::abs(s.bottom_z - a.bottom_z);
  const double z_overlap = std::max(
      0.0, std::min(s.box.max.z(), a.box.max.z()) - std::max(s.box.min.z(), a.box.min.z()));
  const double min_height = std::max(1e-6, std::min(s.box.Size().z(), a.box.Size().z()));
  const bool same_level = level <= opt_.next_to_level_tolerance_m || z_overlap >= 0.5 * min_height;
  const double threshold = std::clamp(opt_.next_to_factor * 0.5 * (s.size_m + a.size_m),
                                      opt_.next_to_min_m, opt_.next_to_max_m);
  const double stacked = FootprintFractionOfSmaller(s, a);
  r.confidence = 1.0 - 0.5 * hgap / threshold;
  r.holds = hgap <= threshold && same_level && stacked < 0.3;
  r.distance_m = hgap;
  if (ev) {
    r.evidence = absl::StrFormat(
        "%.2f m apart side by side (next to within %.2f m), bottoms %.2f m apart in height", hgap,
        threshold, level);
  }
  return r;
}

RelationResult RelationEvaluator::Inside(const ObjectGeom& s, const ObjectGeom& a, bool ev) const {
  RelationResult r;
  const double volume = s.box.Volume();
  double fraction = 0;
  if (volume > 1e-12) {
    fraction = IntersectionVolume(s.box, a.box) / volume;
  } else {
    const Vec3d& c = s.centroid_g;
    fraction = (c.array() >= a.box.min.array()).all() && (c.array() <= a.box.max.array()).all();
  }
  // Only containers hold things (a keyboard is never "inside" a monitor whose box happens to
  // reach over it), and only smaller things.
  const bool container = std::find(opt_.inside_containers.begin(), opt_.inside_containers.end(),
                                    a.class_name) != opt_.inside_containers.end();
  const bool smaller = s.size_m <= opt_.inside_max_size_ratio * a.size_m;
  r.confidence = container && smaller ? fraction : 0.0;
  r.holds = r.confidence >= opt_.inside_min_fraction && a.box.Volume() > volume;
  r.distance_m = 0;
  if (ev) r.evidence = absl::StrFormat("%.0f%% of its box inside the other's box", 100 * fraction);
  return r;
}

RelationResult RelationEvaluator::Directional(RelationKind kind, const ObjectGeom& s,
                                              const ObjectGeom& a, const ViewpointG* v,
                                              bool ev) const {
  RelationResult r;
  if (v == nullptr) {
    if (ev) r.evidence = "no viewpoint: left, right, front and behind need a robot pose";
    return r;
  }
  // Deictic frame: forward is the horizontal direction from the viewer to the anchor.
  Vec3d f = a.centroid_g - v->position_g;
  f.z() = 0;
  f = f.norm() > 0.3 ? f.normalized() : v->forward_g;
  const Vec3d right(f.y(), -f.x(), 0.0);  // forward x up
  Vec3d d = s.centroid_g - a.centroid_g;
  d.z() = 0;
  const double lateral = d.dot(right);
  const double depth = d.dot(f);
  Vec3d dir;
  switch (kind) {
    case RelationKind::kLeftOf:
      dir = -right;
      break;
    case RelationKind::kRightOf:
      dir = right;
      break;
    case RelationKind::kInFrontOf:
      dir = -f;
      break;
    default:
      dir = f;
      break;
  }
  const double norm = d.norm();
  const double cos_angle = norm > 1e-6 ? d.dot(dir) / norm : 0.0;
  const double c0 = std::cos(opt_.directional_half_angle_deg * M_PI / 180.0);
  const double gap = BoxGap(s.box, a.box);
  const double range = std::clamp(opt_.directional_factor * 0.5 * (s.size_m + a.size_m),
                                  opt_.directional_min_m, opt_.directional_max_m);
  r.confidence = cos_angle >= c0 ? 0.5 + 0.5 * (cos_angle - c0) / std::max(1e-6, 1.0 - c0)
                                 : 0.5 * std::max(0.0, cos_angle);
  r.holds = norm > 1e-3 && cos_angle >= c0 && gap <= range;
  r.distance_m = gap;
  if (ev) {
    r.evidence = absl::StrFormat(
        "centre %.2f m to the %s and %.2f m %s, seen from %s; boxes %.2f m apart (within %.2f m)",
        std::abs(lateral), lateral < 0 ? "left" : "right", std::abs(depth),
        depth < 0 ? "closer" : "farther", v->robot.empty() ? "the viewpoint" : v->robot, gap,
        range);
  }
  return r;
}

RelationResult RelationEvaluator::Between(const ObjectGeom& s, const ObjectGeom& a,
                                          const ObjectGeom& b, bool ev) const {
  RelationResult r;
  r.kind = RelationKind::kBetween;
  r.subject_id = s.id;
  r.anchor_id = a.id;
  r.anchor2_id = b.id;
  Vec3d ab = b.centroid_g - a.centroid_g;
  ab.z() = 0;
  Vec3d as = s.centroid_g - a.centroid_g;
  as.z() = 0;
  const double len2 = ab.squaredNorm();
  if (len2 < 1e-6 || s.id == a.id || s.id == b.id || a.id == b.id) {
    if (ev) r.evidence = "the two anchors coincide";
    return r;
  }
  // Position along the horizontal segment, distance to the 3-D segment at that position (a
  // chair on the floor is not between two things on a table).
  const double t = as.dot(ab) / len2;
  const Vec3d on_segment = a.centroid_g + std::clamp(t, 0.0, 1.0) * (b.centroid_g - a.centroid_g);
  const double dist = (s.centroid_g - on_segment).norm();
  // A table under both anchors is not between them.
  const bool holds_anchor = FootprintFraction(a, s) >= 0.5 || FootprintFraction(b, s) >= 0.5;
  const double threshold = std::max(opt_.between_min_m, opt_.between_factor * 0.5 * s.size_m);
  r.confidence = Clamp01(1.0 - 0.5 * dist / threshold);
  r.holds = t > 0.05 && t < 0.95 && dist <= threshold && !holds_anchor &&
            r.confidence >= opt_.min_confidence;
  r.distance_m = dist;
  if (ev) {
    r.evidence = absl::StrFormat("%.2f m from the line joining the two, %.0f%% of the way along",
                                 dist, 100 * t);
  }
  return r;
}

double RelationEvaluator::SearchRadius(RelationKind kind, const ObjectGeom& anchor) const {
  switch (kind) {
    case RelationKind::kOn:
    case RelationKind::kUnder:
    case RelationKind::kAbove:
    case RelationKind::kBelow:
    case RelationKind::kInside:
      return 0.01;
    case RelationKind::kNear:
      return opt_.near_max_m;
    case RelationKind::kNextTo:
      return opt_.next_to_max_m;
    case RelationKind::kLeftOf:
    case RelationKind::kRightOf:
    case RelationKind::kInFrontOf:
    case RelationKind::kBehind:
      return opt_.directional_max_m;
    default:
      return std::max(opt_.near_max_m, anchor.size_m);
  }
}

}  // namespace loci::query

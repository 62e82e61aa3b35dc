#include "server/runtime/proto_convert.h"

#include "common/se3.h"

namespace loci::server {
namespace {

Eigen::Vector3d GetVec(const loci::v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

void ToProto(const MapObject& in, loci::v1::Object* out) {
  out->set_id(in.id);
  out->set_class_name(in.class_name);
  out->set_confidence(in.confidence);
  for (const auto& [name, p] : in.labels) {
    auto* l = out->add_labels();
    l->set_class_name(name);
    l->set_probability(p);
  }
  ToProto(in.centroid_m, out->mutable_centroid_m());
  ToProto(in.aabb_min_m, out->mutable_aabb()->mutable_min_m());
  ToProto(in.aabb_max_m, out->mutable_aabb()->mutable_max_m());
  ToProto(in.obb_center_m, out->mutable_obb()->mutable_center_m());
  ToProto(in.obb_half_extent_m, out->mutable_obb()->mutable_half_extent_m());
  SE3d R = SE3d::Identity();
  R.linear() = in.R_map_box;
  ToProto(R, out->mutable_obb()->mutable_r_map_box());
  out->set_first_seen_ns(in.first_seen_ns);
  out->set_last_seen_ns(in.last_seen_ns);
  for (const auto& r : in.robots) out->add_robots(r);
  out->set_observation_count(in.observation_count);
  out->set_confirmed(in.confirmed);
  out->set_point_count(in.point_count);
  out->set_last_robot(in.last_robot);
  out->set_missed_views(in.missed_views);
  out->set_existence(in.existence);
  out->set_island(in.island);
  for (const ObjectPlaceChange& c : in.history) {
    loci::v1::PlaceChange* h = out->add_history();
    h->set_kind(static_cast<loci::v1::PlaceChange::Kind>(c.kind));
    h->set_t_ns(c.t_ns);
    ToProto(c.centroid_m, h->mutable_centroid_m());
    ToProto(c.from_m, h->mutable_from_m());
    for (int64_t id : c.evidence_keyframe_ids) h->add_evidence_keyframe_ids(id);
  }
  out->set_removed_t_ns(in.removed_t_ns);
}

MapObject FromProto(const loci::v1::Object& in) {
  MapObject o;
  o.id = in.id();
  o.class_name = in.class_name();
  o.confidence = in.confidence();
  for (const auto& l : in.labels()) o.labels.emplace_back(l.class_name(), l.probability());
  o.centroid_m = GetVec(in.centroid_m());
  o.aabb_min_m = GetVec(in.aabb().min_m());
  o.aabb_max_m = GetVec(in.aabb().max_m());
  o.obb_center_m = GetVec(in.obb().center_m());
  o.obb_half_extent_m = GetVec(in.obb().half_extent_m());
  const auto& q = in.obb().r_map_box();
  if (q.qw() != 0 || q.qx() != 0 || q.qy() != 0 || q.qz() != 0) {
    o.R_map_box = Quatd(q.qw(), q.qx(), q.qy(), q.qz()).normalized().toRotationMatrix();
  }
  o.first_seen_ns = in.first_seen_ns();
  o.last_seen_ns = in.last_seen_ns();
  o.robots.assign(in.robots().begin(), in.robots().end());
  o.last_robot = in.last_robot();
  o.missed_views = in.missed_views();
  o.existence = in.existence();
  o.island = in.island();
  o.observation_count = in.observation_count();
  o.point_count = in.point_count();
  o.confirmed = in.confirmed();
  for (const loci::v1::PlaceChange& h : in.history()) {
    ObjectPlaceChange c;
    c.kind = h.kind() == loci::v1::PlaceChange::MOVED     ? ObjectPlaceChange::Kind::kMoved
             : h.kind() == loci::v1::PlaceChange::REMOVED ? ObjectPlaceChange::Kind::kRemoved
                                                          : ObjectPlaceChange::Kind::kAppeared;
    c.t_ns = h.t_ns();
    c.centroid_m = GetVec(h.centroid_m());
    c.from_m = GetVec(h.from_m());
    c.evidence_keyframe_ids.assign(h.evidence_keyframe_ids().begin(),
                                   h.evidence_keyframe_ids().end());
    o.history.push_back(std::move(c));
  }
  o.removed_t_ns = in.removed_t_ns();
  return o;
}

void ToProto(const SemanticPoint& in, loci::v1::CloudPoint* out) {
  out->set_x_m(in.p_m.x());
  out->set_y_m(in.p_m.y());
  out->set_z_m(in.p_m.z());
  out->set_rgb(in.rgb);
  out->set_object_id(in.object_id);
}

void ToProto(const ColoredPoint& in, int64_t object_id, loci::v1::CloudPoint* out) {
  out->set_x_m(in.p_m.x());
  out->set_y_m(in.p_m.y());
  out->set_z_m(in.p_m.z());
  out->set_rgb(in.rgb);
  out->set_object_id(object_id);
}

void ToProto(const Status& in, loci::v1::Status* out) {
  out->set_code(static_cast<int>(in.code()));
  out->set_message(std::string(in.message()));
}

}  // namespace loci::server

#include "server/service/services.h"

#include <set>

#include <algorithm>
#include <chrono>
#include <cmath>

#include <absl/strings/str_cat.h>
#include <grpcpp/support/method_handler.h>

#include "common/time.h"
#include "server/runtime/proto_convert.h"

namespace loci::server {
namespace {

bool Inside(const Eigen::Vector3d& p, const loci::v1::Aabb& box) {
  return p.x() >= box.min_m().x() && p.y() >= box.min_m().y() && p.z() >= box.min_m().z() &&
         p.x() <= box.max_m().x() && p.y() <= box.max_m().y() && p.z() <= box.max_m().z();
}

// Whether a FindObjects request selects the object (class, confidence, region).
bool Wanted(const loci::v1::FindObjectsRequest& req, const MapObject& o) {
  if (!req.classes().empty() &&
      std::find(req.classes().begin(), req.classes().end(), o.class_name) == req.classes().end()) {
    return false;
  }
  if (o.confidence < req.min_confidence()) return false;
  if (req.has_within_box() && !Inside(o.centroid_m, req.within_box())) return false;
  const Eigen::Vector3d center(req.near_center_m().x(), req.near_center_m().y(),
                               req.near_center_m().z());
  return req.radius_m() <= 0 || (o.centroid_m - center).norm() <= req.radius_m();
}

}  // namespace

grpc::Status ToGrpc(const Status& s) {
  if (s.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()), std::string(s.message()));
}

Status FromGrpc(const grpc::Status& s) {
  if (s.ok()) return absl::OkStatus();
  return Status(static_cast<absl::StatusCode>(s.error_code()), s.error_message());
}

StatusOr<Principal> Caller(const Authorizer& auth, const grpc::ServerContext& ctx) {
  const auto& metadata = ctx.client_metadata();
  const auto it = metadata.find("authorization");
  std::optional<std::string_view> header;
  if (it != metadata.end()) header = std::string_view(it->second.data(), it->second.size());
  return auth.Authenticate(header);
}

grpc::Status MappingService::OpenSession(grpc::ServerContext* ctx,
                                         const loci::v1::OpenSessionRequest* req,
                                         loci::v1::OpenSessionResponse* resp) {
  const StatusOr<Principal> who = Caller(*auth_, *ctx);
  if (!who.ok()) return ToGrpc(who.status());
  if (Status s = Authorizer::AllowRobot(*who, req->robot_name()); !s.ok()) return ToGrpc(s);
  auto r = server_->OpenSession(*req);
  if (!r.ok()) return ToGrpc(r.status());
  *resp = std::move(*r);
  return grpc::Status::OK;
}

MappingService::MappingService(MapServer* server, const Authorizer* auth)
    : server_(server), auth_(auth) {
  constexpr int kStreamKeyframesIndex = 1;  // the method's place in mapping.proto
  using Handler = grpc::internal::BidiStreamingHandler<MappingService, grpc::ByteBuffer,
                                                       loci::v1::KeyframeAck>;
  MarkMethodStreamed(kStreamKeyframesIndex,
                     new Handler(
                         [](MappingService* service, grpc::ServerContext* ctx,
                            grpc::ServerReaderWriter<loci::v1::KeyframeAck, grpc::ByteBuffer>*
                                stream) { return service->StreamKeyframeBytes(ctx, stream); },
                         this));
}

grpc::Status MappingService::StreamKeyframeBytes(
    grpc::ServerContext* ctx,
    grpc::ServerReaderWriter<loci::v1::KeyframeAck, grpc::ByteBuffer>* stream) {
  const StatusOr<Principal> who = Caller(*auth_, *ctx);
  if (!who.ok()) return ToGrpc(who.status());
  if (who->role == Principal::Role::kQuery) {
    return ToGrpc(absl::PermissionDeniedError("a query token may not stream keyframes"));
  }
  const std::string* only_robot = who->role == Principal::Role::kRobot ? &who->robot : nullptr;
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  grpc::ByteBuffer bytes;
  for (int64_t n = 1; !ctx->IsCancelled() && stream->Read(&bytes); ++n) {
    const size_t size = bytes.Length();
    loci::v1::Keyframe kf;
    if (!grpc::SerializationTraits<loci::v1::Keyframe>::Deserialize(&bytes, &kf).ok()) {
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                          absl::StrCat("message ", n, " of this stream (", size,
                                       " bytes) is not a loci.v1.Keyframe; the stream ends here "
                                       "and the keyframes acknowledged before it are stored"));
    }
    const loci::v1::KeyframeAck ack = server_->Ingest(kf, only_robot);
    if (!stream->Write(ack)) break;
  }
  return grpc::Status::OK;
}

grpc::Status MappingService::CloseSession(grpc::ServerContext* ctx,
                                          const loci::v1::CloseSessionRequest* req,
                                          loci::v1::CloseSessionResponse* resp) {
  const StatusOr<Principal> who = Caller(*auth_, *ctx);
  if (!who.ok()) return ToGrpc(who.status());
  if (who->role == Principal::Role::kQuery) {
    return ToGrpc(absl::PermissionDeniedError("a query token may not close sessions"));
  }
  auto r = server_->CloseSession(
      *req, who->role == Principal::Role::kRobot ? &who->robot : nullptr);
  if (!r.ok()) return ToGrpc(r.status());
  *resp = std::move(*r);
  return grpc::Status::OK;
}

grpc::Status CheckFindObjects(const loci::v1::FindObjectsRequest& req) {
  if (!std::isfinite(req.min_confidence()) || !std::isfinite(req.radius_m()) ||
      req.radius_m() < 0) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                        "min_confidence and radius_m must be finite, radius_m >= 0");
  }
  return grpc::Status::OK;
}

void SelectObjects(const loci::v1::FindObjectsRequest& req, const std::vector<MapObject>& objects,
                   loci::v1::FindObjectsResponse* resp) {
  for (const MapObject& o : objects) {
    if (req.limit() > 0 && resp->objects_size() >= static_cast<int>(req.limit())) break;
    if (Wanted(req, o)) ToProto(o, resp->add_objects());
  }
}

grpc::Status AllowRead(const Authorizer& auth, const grpc::ServerContext& ctx) {
  const StatusOr<Principal> who = Caller(auth, ctx);
  if (!who.ok()) return ToGrpc(who.status());
  return ToGrpc(Authorizer::AllowRead(*who));
}

grpc::Status QueryService::AllowRead(const grpc::ServerContext& ctx) const {
  return ::loci::server::AllowRead(*auth_, ctx);
}

grpc::Status QueryService::Ask(grpc::ServerContext* ctx, const loci::v1::AskRequest* req,
                               loci::v1::AskResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  return Ask(*req, resp);
}

grpc::Status QueryService::FindObjects(grpc::ServerContext* ctx,
                                       const loci::v1::FindObjectsRequest* req,
                                       loci::v1::FindObjectsResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  return FindObjects(*req, resp);
}

grpc::Status QueryService::GetObject(grpc::ServerContext* ctx,
                                     const loci::v1::GetObjectRequest* req,
                                     loci::v1::GetObjectResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  return GetObject(*req, resp);
}

grpc::Status QueryService::GetStats(grpc::ServerContext* ctx, const loci::v1::GetStatsRequest*,
                                    loci::v1::GetStatsResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  return GetStats(resp);
}

grpc::Status QueryService::Ask(const loci::v1::AskRequest& req,
                               loci::v1::AskResponse* resp) {
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  if (!engine_) {
    return grpc::Status(grpc::StatusCode::UNIMPLEMENTED,
                        "this server answers no questions (no query engine); use FindObjects");
  }
  StatusOr<loci::v1::AskResponse> answer = engine_->Ask(req, *server_);
  if (!answer.ok()) return ToGrpc(answer.status());
  *resp = std::move(*answer);
  return grpc::Status::OK;
}

grpc::Status QueryService::FindObjects(const loci::v1::FindObjectsRequest& req,
                                       loci::v1::FindObjectsResponse* resp) {
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  if (grpc::Status s = CheckFindObjects(req); !s.ok()) return s;
  std::vector<MapObject> objects = server_->mapper().Snapshot(req.confirmed_only());
  const bool region = req.has_within_box() || req.radius_m() > 0;
  if (req.include_islands() && !region && server_->islands() != nullptr) {
    for (MapObject& o : server_->islands()->Snapshot(req.confirmed_only())) {
      objects.push_back(std::move(o));  // after the shared map's
    }
  }
  if (req.include_removed()) {
    for (MapObject& o : server_->mapper().Removed()) objects.push_back(std::move(o));
  }
  SelectObjects(req, objects, resp);
  return grpc::Status::OK;
}

grpc::Status QueryService::GetObject(const loci::v1::GetObjectRequest& req,
                                     loci::v1::GetObjectResponse* resp) {
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  std::vector<ColoredPoint> cloud;
  std::vector<int64_t> keyframes;
  auto o = server_->mapper().GetObject(req.id(), req.with_cloud() ? &cloud : nullptr, &keyframes);
  if (!o && server_->islands() != nullptr) {  // an island's object (its own id range)
    if (auto island = server_->islands()->FindByObjectId(req.id())) {
      o = island->map->GetObject(req.id(), req.with_cloud() ? &cloud : nullptr, &keyframes);
      if (o) o->island = island->name;
    }
  }
  if (!o) {
    return grpc::Status(grpc::StatusCode::NOT_FOUND, absl::StrCat("no object ", req.id()));
  }
  ToProto(*o, resp->mutable_object());
  for (const auto& p : cloud) ToProto(p, o->id, resp->add_cloud());
  for (int64_t k : keyframes) resp->add_keyframe_ids(k);
  return grpc::Status::OK;
}

grpc::Status QueryService::GetCloud(grpc::ServerContext* ctx, const loci::v1::GetCloudRequest* req,
                                    loci::v1::GetCloudResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  return GetCloud(*req, resp);
}

grpc::Status QueryService::GetCloud(const loci::v1::GetCloudRequest& req,
                                    loci::v1::GetCloudResponse* resp) {
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  if (!std::isfinite(req.voxel_m()) || req.voxel_m() < 0) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "voxel_m must be finite and >= 0");
  }
  const std::vector<std::string> classes(req.classes().begin(), req.classes().end());
  for (const SemanticPoint& p : server_->mapper().Cloud(req.voxel_m(), classes)) {
    ToProto(p, resp->add_points());
  }
  return grpc::Status::OK;
}

StatusOr<std::shared_ptr<const Mapper>> QueryService::MapNamed(const std::string& island) const {
  if (island.empty()) {  // not owned: the server outlives the call
    return std::shared_ptr<const Mapper>(std::shared_ptr<const Mapper>(), &server_->mapper());
  }
  std::optional<IslandMaps::Island> found =
      server_->islands() ? server_->islands()->FindByName(island) : std::nullopt;
  if (!found) {
    return absl::NotFoundError("no map island named '" + island + "' (GetStats lists them)");
  }
  return found->map;
}

grpc::Status QueryService::GetOctomap(grpc::ServerContext* ctx,
                                      const loci::v1::GetOctomapRequest* req,
                                      loci::v1::GetOctomapResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  StatusOr<std::shared_ptr<const Mapper>> named = MapNamed(req->island());
  if (!named.ok()) return ToGrpc(named.status());
  const Mapper& map = **named;
  // Waits for the queued scans, and for a running rebuild only when asked to; `rebuilding` when
  // one ran before or after the tree was taken.
  const bool rebuilding_before = map.OctomapRebuilding();
  resp->set_octomap_bt(map.OctomapBt(req->wait_for_rebuild()));
  resp->set_rebuilding((rebuilding_before && !req->wait_for_rebuild()) || map.OctomapRebuilding());
  resp->set_resolution_m(map.OctomapResolution());
  resp->set_node_count(map.Stats().octomap_nodes);
  return grpc::Status::OK;
}

void ToProto(const ObjectEventOut& in, int64_t t_ns, loci::v1::ObjectEvent* out) {
  switch (in.kind) {
    case ObjectChange::Kind::kCreated:
      out->set_kind(loci::v1::ObjectEvent::CREATED);
      break;
    case ObjectChange::Kind::kUpdated:
      out->set_kind(loci::v1::ObjectEvent::UPDATED);
      break;
    case ObjectChange::Kind::kMerged:
      out->set_kind(loci::v1::ObjectEvent::MERGED);
      break;
    case ObjectChange::Kind::kRemoved:
      out->set_kind(loci::v1::ObjectEvent::REMOVED);
      break;
    case ObjectChange::Kind::kMoved:
      out->set_kind(loci::v1::ObjectEvent::MOVED);
      ToProto(in.from_m, out->mutable_previous_center_m());
      break;
  }
  ToProto(in.object, out->mutable_object());
  out->set_merged_from_id(in.merged_from_id);
  out->set_t_ns(t_ns);
  for (int64_t id : in.evidence_keyframe_ids) out->add_evidence_keyframe_ids(id);
  out->set_evidence_t_ns(in.evidence_t_ns);
}

Status QueryService::SubscribeObjects(std::shared_ptr<ObjectEventQueue> queue) {
  return server_->events().Subscribe(std::move(queue));
}

void QueryService::UnsubscribeObjects(const std::shared_ptr<ObjectEventQueue>& queue) {
  server_->events().Unsubscribe(queue);
}

grpc::Status QueryService::WatchObjects(grpc::ServerContext* ctx,
                                        const loci::v1::WatchObjectsRequest*,
                                        grpc::ServerWriter<loci::v1::ObjectEvent>* writer) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  return StreamObjectEvents(*this, ctx, writer);
}

grpc::Status StreamObjectEvents(QueryApi& api, grpc::ServerContext* ctx,
                                grpc::ServerWriter<loci::v1::ObjectEvent>* writer) {
  auto queue = std::make_shared<ObjectEventQueue>(1024);
  if (Status s = api.SubscribeObjects(queue); !s.ok()) return ToGrpc(s);
  writer->SendInitialMetadata();
  while (!ctx->IsCancelled()) {
    std::optional<ObjectEventOut> e = queue->PopFor(std::chrono::milliseconds(200));
    if (!e) {
      if (queue->closed()) break;
      continue;
    }
    loci::v1::ObjectEvent msg;
    ToProto(*e, NowNs(), &msg);
    if (!writer->Write(msg)) break;
  }
  api.UnsubscribeObjects(queue);
  return grpc::Status::OK;
}

grpc::Status QueryService::GetStats(loci::v1::GetStatsResponse* resp) {
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  auto sessions = server_->store().ListSessions();
  auto keyframes = server_->store().CountKeyframes(std::nullopt);
  if (!sessions.ok()) return ToGrpc(sessions.status());
  if (!keyframes.ok()) return ToGrpc(keyframes.status());
  const MapperStats s = server_->mapper().Stats();
  resp->set_sessions(sessions->size());
  resp->set_keyframes(*keyframes);
  resp->set_objects(s.objects);
  resp->set_confirmed_objects(s.confirmed_objects);
  resp->set_cloud_points(s.cloud_points);
  resp->set_octomap_nodes(s.octomap_nodes);
  resp->set_octomap_pending_scans(s.octomap_pending_scans);
  resp->set_octomap_rebuilds(s.octomap_rebuilds);
  resp->set_octomap_rebuilds_skipped(s.octomap_rebuilds_skipped);
  resp->set_db_bytes(server_->store().DbBytes());
  resp->set_queue_depth(server_->stats().queue_depth);
  resp->set_ingest_ms_mean(server_->times().mapping_ms_mean());
  resp->set_worker_longest_wait_ms(server_->times().worker_longest_wait_ms());
  resp->set_frame_up_source(server_->mapper().FrameSource());
  resp->set_frame_settled(server_->mapper().FrameSettled());
  resp->set_mapped_keyframes(s.keyframes);
  auto bytes = server_->store().Bytes();
  if (!bytes.ok()) return ToGrpc(bytes.status());
  auto per = [](uint64_t total, uint64_t n) { return n == 0 ? 0.0 : double(total) / double(n); };
  resp->set_raw_bytes_per_keyframe(per(bytes->raw_bytes, bytes->keyframes_with_raw));
  resp->set_product_bytes_per_keyframe(per(bytes->product_bytes, bytes->products));
  resp->set_keyframes_with_raw(bytes->keyframes_with_raw);
  resp->set_keyframes_with_products(bytes->products);
  resp->set_checkpoint_bytes(bytes->checkpoint_bytes);
  resp->set_checkpoints_written(server_->stats().checkpoints_written);
  resp->set_place_feature_bytes_per_keyframe(per(bytes->place_feature_bytes, bytes->place_features));
  resp->set_keyframes_with_place_features(bytes->place_features);
  return FillAlignment(*sessions, resp);
}

grpc::Status QueryService::FillAlignment(const std::vector<SessionRecord>& sessions,
                                         loci::v1::GetStatsResponse* resp) {
  const SE3d T_map_base = server_->mapper().MapFromBaseFrame();
  const RuntimeStats runtime = server_->stats();
  for (const SessionRecord& s : sessions) {
    loci::v1::SessionAlignment* out = resp->add_session_alignments();
    out->set_session_id(s.session_id);
    out->set_robot(s.robot_name);
    out->set_aligned(s.aligned);
    if (s.aligned) ToProto(T_map_base * s.T_base_odom, out->mutable_t_map_odom());
    if (!s.aligned && server_->islands() != nullptr) {
      if (auto island = server_->islands()->Find(s.island_row != 0 ? s.island_row : s.row_id)) {
        out->set_island(island->name);
        out->set_island_objects(island->map->Stats().confirmed_objects);
        ToProto(island->map->MapFromBaseFrame() * s.T_island_odom, out->mutable_t_island_odom());
        FillIslandGraph(runtime.loops, island->session_row, out);
      }
    }
    auto n = server_->store().CountKeyframes(s.row_id);
    if (!n.ok()) return ToGrpc(n.status());
    out->set_keyframes(*n);
    if (const std::optional<AlignmentDelay> d = server_->alignment_delay(s.row_id)) {
      out->set_aligned_after_keyframes(static_cast<uint32_t>(d->keyframes));
      out->set_aligned_after_s(d->seconds);
    }
  }
  loci::v1::AlignmentStats* a = resp->mutable_alignment();
  const std::optional<AlignStats>& st = runtime.align;
  a->set_enabled(st.has_value());
  if (!st) return grpc::Status::OK;
  a->set_keyframes_indexed(st->keyframes);
  a->set_queries(st->queries);
  a->set_verified(st->verified);
  a->set_rejected(st->rejected);
  a->set_merges_accepted(st->merges_accepted);
  a->set_merge_resets(st->merge_resets);
  a->set_queries_ahead(st->queries_ahead);
  a->set_merges_ahead(st->merges_ahead);
  a->set_islands_pulled(st->islands_pulled);
  const HeldMergeStats& held = runtime.held_merge;
  a->set_merged_keyframes(held.merged_keyframes);
  a->set_last_merge_ms(held.last_ms);
  a->set_last_merge_chunks(held.last_chunks);
  a->set_last_merge_keyframes(held.last_keyframes);
  a->set_last_merge_longest_hold_ms(held.last_longest_hold_ms);
  a->set_merge_longest_hold_ms(held.longest_hold_ms);
  a->set_place_ms_mean(st->keyframes == 0 ? 0.0 : st->place_ms_total / double(st->keyframes));
  a->set_vocabulary_words(st->vocabulary_words);
  a->set_features_read(st->features_read);
  a->set_features_missing(st->features_missing);
  a->set_keyframes_from_stored_features(st->indexed_from_store);
  a->set_dense_refined(st->dense_refined);
  a->set_dense_refused(st->dense_refused);
  a->set_dense_without_images(st->dense_without_images);
  a->set_dense_frames_read(st->dense_frames_read);
  FillPoseGraph(runtime.loops, resp->mutable_pose_graph());
  return grpc::Status::OK;
}

void QueryService::FillPoseGraph(const std::optional<LoopStats>& st,
                                 loci::v1::PoseGraphStats* out) {
  out->set_enabled(st.has_value());
  if (!st) return;
  out->set_loop_matches(st->loop_matches);
  out->set_merge_matches(st->merge_matches);
  out->set_optimizations(st->optimizations);
  out->set_keyframes_moved(st->keyframes_moved);
  out->set_solve_ms_mean(st->optimizations == 0 ? 0.0
                                                : st->solve_ms_total / double(st->optimizations));
  const GraphStats& g = st->last;
  out->set_nodes(g.nodes);
  out->set_edges(g.odometry_edges + g.loop_edges + g.merge_edges);
  out->set_loops_accepted(g.loops_accepted);
  out->set_loops_rejected(g.loops_rejected);
  out->set_merges_accepted(g.merges_accepted);
  out->set_merges_rejected(g.merges_rejected);
  out->set_islands(g.islands);
  out->set_four_dof(g.four_dof);
  out->set_gravity_priors(g.gravity_priors);
  out->set_landmarks(g.landmarks);
  out->set_landmark_views(g.centroid_observations);
  out->set_last_solve_ms(g.pcm_ms + g.solve_ms);
  out->set_last_apply_ms(st->last_apply_ms);
  out->set_last_apply_chunks(st->last_apply_chunks);
  out->set_last_apply_longest_hold_ms(st->last_apply_longest_hold_ms);
  out->set_longest_hold_ms(st->longest_hold_ms);
}

void QueryService::FillIslandGraph(const std::optional<LoopStats>& st, int64_t island_row,
                                   loci::v1::SessionAlignment* out) {
  if (!st) return;
  auto it = st->islands.find(island_row);
  if (it == st->islands.end()) return;
  out->set_island_optimizations(it->second.optimizations);
  out->set_island_loops_accepted(it->second.last.loops_accepted);
  out->set_island_loops_rejected(it->second.last.loops_rejected);
}

grpc::Status QueryService::GetTrajectories(grpc::ServerContext* ctx,
                                           const loci::v1::GetTrajectoriesRequest* req,
                                           loci::v1::GetTrajectoriesResponse* resp) {
  if (grpc::Status s = AllowRead(*ctx); !s.ok()) return s;
  return GetTrajectories(*req, resp);
}

grpc::Status QueryService::GetTrajectories(const loci::v1::GetTrajectoriesRequest& req,
                                           loci::v1::GetTrajectoriesResponse* resp) {
  if (Status ready = server_->CheckReady(); !ready.ok()) return ToGrpc(ready);
  StatusOr<std::shared_ptr<const Mapper>> map = MapNamed(req.island());
  if (!map.ok()) return ToGrpc(map.status());
  const std::set<std::string> wanted(req.robots().begin(), req.robots().end());
  for (const auto& [robot, traj] : (*map)->Trajectories()) {
    if (!wanted.empty() && !wanted.count(robot)) continue;
    loci::v1::Trajectory* t = resp->add_trajectories();
    t->set_robot(robot);
    for (const StampedPose& p : traj) {
      loci::v1::StampedPose* sp = t->add_poses();
      sp->set_t_ns(p.t_ns);
      ToProto(p.T_world_cam, sp->mutable_t_map_cam());
    }
  }
  return grpc::Status::OK;
}

}  // namespace loci::server

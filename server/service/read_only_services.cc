#include "server/service/read_only_services.h"

#include "absl/strings/str_cat.h"
#include "server/runtime/proto_convert.h"
#include "server/service/services.h"

namespace loci::server {

std::string AtWriterMessage(const std::string& site, const std::string& what,
                            const std::string& writer_address) {
  return absl::StrCat("this is a read-only query server of site '", site, "'; ", what,
                      " at the site's writer ",
                      writer_address.empty() ? std::string("(no writer holds the site now)")
                                             : "(" + writer_address + ")");
}

std::vector<MapObject> PublishedSource::Objects(bool confirmed_only) const {
  if (!confirmed_only) return s_->objects;
  std::vector<MapObject> out;
  for (const MapObject& o : s_->objects) {
    if (o.confirmed) out.push_back(o);
  }
  return out;
}

grpc::Status ReadOnlyQueryService::Loaded(
    std::shared_ptr<const ReplicaSnapshot>* snapshot) const {
  if (Status ready = map_->readiness().Check(); !ready.ok()) return ToGrpc(ready);
  *snapshot = map_->Snapshot();
  return grpc::Status::OK;
}

grpc::Status ReadOnlyQueryService::AtWriter(const std::string& what) const {
  return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                      AtWriterMessage(map_->site(), what, writer_()));
}

grpc::Status ReadOnlyQueryService::Ask(const loci::v1::AskRequest& req,
                                       loci::v1::AskResponse* resp) {
  std::shared_ptr<const ReplicaSnapshot> snapshot;
  if (grpc::Status s = Loaded(&snapshot); !s.ok()) return s;
  StatusOr<loci::v1::AskResponse> answer = engine_->Ask(req, PublishedSource(snapshot));
  if (!answer.ok()) return ToGrpc(answer.status());
  *resp = std::move(*answer);
  return grpc::Status::OK;
}

grpc::Status ReadOnlyQueryService::FindObjects(const loci::v1::FindObjectsRequest& req,
                                               loci::v1::FindObjectsResponse* resp) {
  std::shared_ptr<const ReplicaSnapshot> snapshot;
  if (grpc::Status s = Loaded(&snapshot); !s.ok()) return s;
  if (grpc::Status s = CheckFindObjects(req); !s.ok()) return s;
  if (!req.confirmed_only() && !req.include_removed()) {
    SelectObjects(req, snapshot->objects, resp);  // no copy: the common case
    return grpc::Status::OK;
  }
  std::vector<MapObject> objects = PublishedSource(snapshot).Objects(req.confirmed_only());
  if (req.include_removed()) {
    objects.insert(objects.end(), snapshot->removed.begin(), snapshot->removed.end());
  }
  SelectObjects(req, objects, resp);
  return grpc::Status::OK;
}

grpc::Status ReadOnlyQueryService::GetObject(const loci::v1::GetObjectRequest& req,
                                             loci::v1::GetObjectResponse* resp) {
  std::shared_ptr<const ReplicaSnapshot> snapshot;
  if (grpc::Status s = Loaded(&snapshot); !s.ok()) return s;
  if (req.with_cloud()) return AtWriter("an object's points are served");
  for (const std::vector<MapObject>* list : {&snapshot->objects, &snapshot->removed}) {
    for (const MapObject& o : *list) {
      if (o.id != req.id()) continue;
      ToProto(o, resp->mutable_object());
      return grpc::Status::OK;
    }
  }
  return grpc::Status(grpc::StatusCode::NOT_FOUND, absl::StrCat("no object ", req.id()));
}

grpc::Status ReadOnlyQueryService::GetStats(loci::v1::GetStatsResponse* resp) {
  std::shared_ptr<const ReplicaSnapshot> snapshot;
  if (grpc::Status s = Loaded(&snapshot); !s.ok()) return s;
  auto sessions = store_->ListSessions();
  if (!sessions.ok()) return ToGrpc(sessions.status());
  auto keyframes = store_->CountKeyframes(std::nullopt);
  if (!keyframes.ok()) return ToGrpc(keyframes.status());
  resp->set_sessions(sessions->size());
  resp->set_keyframes(*keyframes);
  resp->set_objects(snapshot->objects.size());
  uint64_t confirmed = 0;
  for (const MapObject& o : snapshot->objects) confirmed += o.confirmed ? 1 : 0;
  resp->set_confirmed_objects(confirmed);
  resp->set_frame_up_source(snapshot->levelled_by);
  resp->set_frame_settled(!snapshot->levelled_by.empty());
  resp->set_db_bytes(store_->DbBytes());
  return grpc::Status::OK;
}

grpc::Status ReadOnlyQueryService::GetCloud(const loci::v1::GetCloudRequest&,
                                            loci::v1::GetCloudResponse*) {
  return AtWriter("the cloud is served");
}

grpc::Status ReadOnlyQueryService::GetTrajectories(const loci::v1::GetTrajectoriesRequest&,
                                                   loci::v1::GetTrajectoriesResponse*) {
  return AtWriter("trajectories are served");
}

Status ReadOnlyQueryService::SubscribeObjects(std::shared_ptr<ObjectEventQueue> queue) {
  LOCI_RETURN_IF_ERROR(map_->readiness().Check());
  return map_->events().Subscribe(std::move(queue));
}

void ReadOnlyQueryService::UnsubscribeObjects(const std::shared_ptr<ObjectEventQueue>& queue) {
  map_->events().Unsubscribe(queue);
}

grpc::Status ReadOnlyQueryService::Ask(grpc::ServerContext* ctx, const loci::v1::AskRequest* req,
                                       loci::v1::AskResponse* resp) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return Ask(*req, resp);
}

grpc::Status ReadOnlyQueryService::FindObjects(grpc::ServerContext* ctx,
                                               const loci::v1::FindObjectsRequest* req,
                                               loci::v1::FindObjectsResponse* resp) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return FindObjects(*req, resp);
}

grpc::Status ReadOnlyQueryService::GetObject(grpc::ServerContext* ctx,
                                             const loci::v1::GetObjectRequest* req,
                                             loci::v1::GetObjectResponse* resp) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return GetObject(*req, resp);
}

grpc::Status ReadOnlyQueryService::GetStats(grpc::ServerContext* ctx,
                                            const loci::v1::GetStatsRequest*,
                                            loci::v1::GetStatsResponse* resp) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return GetStats(resp);
}

grpc::Status ReadOnlyQueryService::GetCloud(grpc::ServerContext* ctx,
                                            const loci::v1::GetCloudRequest* req,
                                            loci::v1::GetCloudResponse* resp) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return GetCloud(*req, resp);
}

grpc::Status ReadOnlyQueryService::GetOctomap(grpc::ServerContext* ctx,
                                              const loci::v1::GetOctomapRequest*,
                                              loci::v1::GetOctomapResponse*) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return AtWriter("the OctoMap is served");
}

grpc::Status ReadOnlyQueryService::GetTrajectories(grpc::ServerContext* ctx,
                                                   const loci::v1::GetTrajectoriesRequest* req,
                                                   loci::v1::GetTrajectoriesResponse* resp) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return GetTrajectories(*req, resp);
}

grpc::Status ReadOnlyQueryService::WatchObjects(grpc::ServerContext* ctx,
                                                const loci::v1::WatchObjectsRequest*,
                                                grpc::ServerWriter<loci::v1::ObjectEvent>* writer) {
  if (grpc::Status s = AllowRead(*auth_, *ctx); !s.ok()) return s;
  return StreamObjectEvents(*this, ctx, writer);
}

grpc::Status ReadOnlyMappingService::Refuse() const {
  return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                      AtWriterMessage(site_, "robots stream keyframes", writer_()));
}

grpc::Status ReadOnlyMappingService::OpenSession(grpc::ServerContext*,
                                                 const loci::v1::OpenSessionRequest*,
                                                 loci::v1::OpenSessionResponse*) {
  return Refuse();
}

grpc::Status ReadOnlyMappingService::StreamKeyframes(
    grpc::ServerContext*, grpc::ServerReaderWriter<loci::v1::KeyframeAck, loci::v1::Keyframe>*) {
  return Refuse();
}

grpc::Status ReadOnlyMappingService::CloseSession(grpc::ServerContext*,
                                                  const loci::v1::CloseSessionRequest*,
                                                  loci::v1::CloseSessionResponse*) {
  return Refuse();
}

}  // namespace loci::server

// While loci-server loads its map, its port is open: the gRPC health service says NOT_SERVING
// and calls get UNAVAILABLE saying it is loading; once loaded, SERVING and answers. The load is
// held on a gate in the store (not a sleep), so the test sees both states for certain.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <future>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/channel.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/storage/sqlite_store.h"
#include "tests/server/keyframe_proto.h"

namespace loci::server {
namespace {

// A SqliteStore whose keyframe scan (the map load) waits until the gate opens.
class GatedStore final : public MapStore {
 public:
  GatedStore(std::unique_ptr<SqliteStore> inner, std::shared_future<void> gate)
      : inner_(std::move(inner)), gate_(std::move(gate)) {}
  Status ForEachKeyframe(int64_t after_id, const std::function<Status(KeyframeRecord)>& fn,
                         const KeyframeScan& scan) override {
    gate_.wait();
    return inner_->ForEachKeyframe(after_id, fn, scan);
  }
  StatusOr<int> SchemaVersion() override { return inner_->SchemaVersion(); }
  StatusOr<SessionRecord> CreateSession(SessionRecord s) override {
    return inner_->CreateSession(std::move(s));
  }
  StatusOr<std::optional<SessionRecord>> LatestOpenSession(const std::string& r) override {
    return inner_->LatestOpenSession(r);
  }
  StatusOr<std::optional<SessionRecord>> FindSession(const std::string& id) override {
    return inner_->FindSession(id);
  }
  StatusOr<std::vector<SessionRecord>> ListSessions() override { return inner_->ListSessions(); }
  Status CloseSession(int64_t row, int64_t ns) override { return inner_->CloseSession(row, ns); }
  Status SetSessionAlignment(int64_t row, const SE3d& T_base_odom) override {
    return inner_->SetSessionAlignment(row, T_base_odom);
  }
  Status SetSessionIsland(int64_t row, int64_t island_row, const SE3d& T_island_odom) override {
    return inner_->SetSessionIsland(row, island_row, T_island_odom);
  }
  StatusOr<InsertResult> InsertKeyframe(const KeyframeRecord& k) override {
    return inner_->InsertKeyframe(k);
  }
  StatusOr<int64_t> LastStoredSeq(int64_t row) override { return inner_->LastStoredSeq(row); }
  StatusOr<LastStamp> LastStoredStamp(int64_t row) override {
    return inner_->LastStoredStamp(row);
  }
  StatusOr<uint64_t> CountKeyframes(std::optional<int64_t> row) override {
    return inner_->CountKeyframes(row);
  }
  Status PutProducts(int64_t id, const std::string& f, const std::string& d) override {
    return inner_->PutProducts(id, f, d);
  }
  Status PutPlaceFeatures(int64_t id, const std::string& f, const std::string& d) override {
    return inner_->PutPlaceFeatures(id, f, d);
  }
  StatusOr<std::optional<std::string>> GetPlaceFeatures(int64_t id,
                                                        const std::string& f) override {
    return inner_->GetPlaceFeatures(id, f);
  }
  StatusOr<std::optional<std::string>> GetProducts(int64_t id, const std::string& f) override {
    return inner_->GetProducts(id, f);
  }
  Status DeleteAllProducts() override { return inner_->DeleteAllProducts(); }
  Status PutKeyframePoses(const std::vector<KeyframePoseRecord>& p) override {
    return inner_->PutKeyframePoses(p);
  }
  Status PutPlaceMatch(const PlaceMatchRecord& m) override { return inner_->PutPlaceMatch(m); }
  StatusOr<std::vector<PlaceMatchRecord>> ListPlaceMatches() override {
    return inner_->ListPlaceMatches();
  }
  Status PutCheckpoint(const CheckpointRecord& c) override { return inner_->PutCheckpoint(c); }
  StatusOr<std::optional<CheckpointRecord>> LatestCheckpoint() override {
    return inner_->LatestCheckpoint();
  }
  Status Publish(const MapPublication& p) override { return inner_->Publish(p); }
  StatusOr<PublishedMap> ReadPublished() override { return inner_->ReadPublished(); }
  StatusOr<int64_t> PublishedVersion() override { return inner_->PublishedVersion(); }
  Status DeleteCheckpoints() override { return inner_->DeleteCheckpoints(); }
  StatusOr<uint64_t> DropRawImages(int64_t before, int64_t keep) override {
    return inner_->DropRawImages(before, keep);
  }
  StatusOr<StorageBytes> Bytes() override { return inner_->Bytes(); }
  uint64_t DbBytes() override { return inner_->DbBytes(); }

 private:
  std::unique_ptr<SqliteStore> inner_;
  std::shared_future<void> gate_;
};

grpc::Status FindObjects(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  loci::v1::FindObjectsResponse resp;
  return loci::v1::Query::NewStub(channel)->FindObjects(&ctx, {}, &resp);
}

grpc::Status OpenSession(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  loci::v1::OpenSessionResponse resp;
  return loci::v1::Mapping::NewStub(channel)->OpenSession(
      &ctx, testing::OpenRequest("robot1", PinholeCamera::TumFr1(), false), &resp);
}

TEST(LoadHealth, NotServingAndUnavailableWhileLoadingThenServing) {
  const std::string db = ::testing::TempDir() + "/loci_load_health.db";
  std::filesystem::remove(db);
  auto sqlite = SqliteStore::Open(db);
  ASSERT_TRUE(sqlite.ok()) << sqlite.status();
  std::promise<void> open_gate;
  auto store = std::make_shared<GatedStore>(std::move(*sqlite), open_gate.get_future().share());
  ServerOptions options;
  ASSERT_TRUE(options.LoadClasses().ok());
  auto server = MapServer::OpenAsync(options, store);
  ASSERT_TRUE(server.ok()) << server.status();
  auto grpc_server = GrpcServer::Start(server->get(), "127.0.0.1:0", 64);
  ASSERT_TRUE(grpc_server.ok()) << grpc_server.status();
  auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", (*grpc_server)->port()),
                                     grpc::InsecureChannelCredentials());

  const Status loading =
      WaitForServing(*channel, std::chrono::system_clock::now() + std::chrono::seconds(5));
  EXPECT_EQ(loading.code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(loading.message().find("NOT_SERVING"), std::string::npos) << loading;
  const grpc::Status find = FindObjects(channel);
  EXPECT_EQ(find.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_NE(find.error_message().find("loading its map"), std::string::npos)
      << find.error_message();
  EXPECT_EQ(OpenSession(channel).error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_FALSE((*server)->readiness().ready());

  open_gate.set_value();
  const Status served =
      WaitForServing(*channel, std::chrono::system_clock::now() + std::chrono::seconds(60));
  EXPECT_TRUE(served.ok()) << served;
  EXPECT_TRUE((*server)->readiness().ready());
  EXPECT_TRUE(FindObjects(channel).ok());
  EXPECT_TRUE(OpenSession(channel).ok());
  grpc_server->reset();
}

}  // namespace
}  // namespace loci::server

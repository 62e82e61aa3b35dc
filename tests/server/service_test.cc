// The gRPC services in process on 127.0.0.1 (port 0): ingest, acknowledgements, duplicates,
// malformed keyframes, the message size limit, resume, queries and object events.
#include <grpcpp/create_channel.h>
#include <grpcpp/support/byte_buffer.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <limits>
#include <map>

#include <opencv2/imgcodecs.hpp>

#include "common/image_codec.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "tests/server/box_world.h"
#include "tests/server/keyframe_proto.h"

namespace loci::server {
namespace {

using loci::v1::Keyframe;
using loci::v1::KeyframeAck;

// Keyframe stamps: one second apart, from 2023-11-14 (the server refuses stamps before 2000).
int64_t StampNs(int i) { return 1'700'000'000'000'000'000 + 1'000'000'000LL * (i + 1); }

// Stands in for the detection module's detectors: the exact boxes of the rendered view whose
// stamp it is asked about (the server runs it on keyframes without detections).
class ViewDetector final : public detection::Detector {
 public:
  explicit ViewDetector(std::map<int64_t, std::vector<Detection2D>> by_t_ns)
      : by_t_ns_(std::move(by_t_ns)) {}
  StatusOr<std::vector<Detection2D>> Detect(const cv::Mat& bgr, int64_t t_ns) override {
    if (bgr.empty()) return absl::InvalidArgumentError("empty image");
    calls.fetch_add(1);
    if (fail) return absl::InternalError("model failed");
    auto it = by_t_ns_.find(t_ns);
    return it == by_t_ns_.end() ? std::vector<Detection2D>{} : it->second;
  }
  std::string Name() const override { return "view"; }
  std::atomic<int> calls{0};
  bool fail = false;  // set before the server starts

 private:
  const std::map<int64_t, std::vector<Detection2D>> by_t_ns_;
};

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = ::testing::TempDir() + "/service_" +
          ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db";
    for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(db_ + s);
    Start();
    const auto boxes = testing::DefaultBoxes(false);
    poses_ = testing::ArcPoses(6);
    for (const SE3d& pose : poses_) views_.push_back(testing::Render(boxes, camera_, pose, true));
  }
  void TearDown() override { Stop(); }

  void Start(std::shared_ptr<KeyframeDetection> detection = nullptr, int max_watchers = 64) {
    ServerOptions o;
    o.db_path = db_;
    o.max_watchers = max_watchers;
    o.map.mapped_classes = {"book", "cup", "laptop"};
    auto s = MapServer::Open(o, nullptr, std::move(detection));
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = std::move(*s);
    auto g = GrpcServer::Start(server_.get(), "127.0.0.1:0", o.max_message_mb);
    ASSERT_TRUE(g.ok()) << g.status();
    grpc_ = std::move(*g);
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(-1);
    args.SetMaxSendMessageSize(-1);
    channel_ = grpc::CreateCustomChannel(absl::StrCat("127.0.0.1:", grpc_->port()),
                                         grpc::InsecureChannelCredentials(), args);
    mapping_ = loci::v1::Mapping::NewStub(channel_);
    query_ = loci::v1::Query::NewStub(channel_);
  }
  void Stop() {
    grpc_.reset();
    server_.reset();
  }

  std::string Open(bool resume = false, int64_t* last_seq = nullptr) {
    grpc::ClientContext ctx;
    loci::v1::OpenSessionResponse resp;
    const grpc::Status s =
        mapping_->OpenSession(&ctx, testing::OpenRequest("robot1", camera_, resume), &resp);
    EXPECT_TRUE(s.ok()) << s.error_message();
    if (last_seq) *last_seq = resp.last_stored_seq();
    return resp.session_id();
  }

  Keyframe Frame(const std::string& session, int i) {
    return testing::MakeKeyframe(session, i, StampNs(i), poses_[i % 6],
                                 views_[i % 6].bgr, views_[i % 6].depth_u16,
                                 views_[i % 6].detections,
                                 poses_[i % 6].rotation().transpose() * Eigen::Vector3d(0, 0, -1));
  }

  // Sends every keyframe on one stream; returns the acks.
  std::vector<KeyframeAck> Send(const std::vector<Keyframe>& frames, grpc::Status* final_status) {
    grpc::ClientContext ctx;
    auto stream = mapping_->StreamKeyframes(&ctx);
    std::vector<KeyframeAck> acks;
    for (const Keyframe& kf : frames) {
      if (!stream->Write(kf)) break;
      KeyframeAck ack;
      if (!stream->Read(&ack)) break;
      acks.push_back(ack);
    }
    stream->WritesDone();
    *final_status = stream->Finish();
    return acks;
  }

  uint64_t StoredKeyframes() { return *server_->store().CountKeyframes(std::nullopt); }

  PinholeCamera camera_ = PinholeCamera::TumFr1();
  std::string db_;
  std::vector<SE3d> poses_;
  std::vector<testing::RenderedView> views_;
  std::unique_ptr<MapServer> server_;
  std::unique_ptr<GrpcServer> grpc_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<loci::v1::Mapping::Stub> mapping_;
  std::unique_ptr<loci::v1::Query::Stub> query_;
};

TEST_F(ServiceTest, IngestAcksDeduplicatesAndAnswersQueries) {
  const std::string session = Open();
  std::vector<Keyframe> frames;
  for (int i = 0; i < 6; ++i) frames.push_back(Frame(session, i));
  frames.push_back(Frame(session, 2));  // a resend after a reconnect
  grpc::Status st;
  const auto acks = Send(frames, &st);
  ASSERT_TRUE(st.ok()) << st.error_message();
  ASSERT_EQ(acks.size(), 7u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(acks[i].status().code(), 0) << acks[i].status().message();
    EXPECT_EQ(acks[i].seq(), i);
    EXPECT_FALSE(acks[i].duplicate());
  }
  EXPECT_TRUE(acks[6].duplicate());
  EXPECT_EQ(acks[6].keyframe_id(), acks[2].keyframe_id());
  EXPECT_EQ(StoredKeyframes(), 6u);
  server_->Flush();

  grpc::ClientContext c1;
  loci::v1::FindObjectsRequest find;
  find.set_confirmed_only(true);
  loci::v1::FindObjectsResponse found;
  ASSERT_TRUE(query_->FindObjects(&c1, find, &found).ok());
  ASSERT_EQ(found.objects_size(), 3);
  // Positions come in the map frame: the box world levelled (here already z up) and anchored
  // at the first keyframe.
  const SE3d T_map_world = server_->mapper().MapFromBaseFrame();
  const SE3d T_world_map = T_map_world.inverse();
  int64_t cup_id = 0;
  for (const auto& o : found.objects()) {
    if (o.class_name() == "cup") {
      cup_id = o.id();
      const Vec3d c_world =
          T_world_map * Vec3d(o.centroid_m().x(), o.centroid_m().y(), o.centroid_m().z());
      EXPECT_NEAR(c_world.x(), 0.04, 0.02);
      EXPECT_NEAR(c_world.z(), 0.06, 0.02);
      EXPECT_EQ(o.robots(0), "robot1");
    }
  }
  ASSERT_NE(cup_id, 0);
  // Radius filter around the book, class filter.
  grpc::ClientContext c2;
  const Vec3d book_map = T_map_world * Vec3d(-0.35, 0.075, 0.0);
  find.mutable_near_center_m()->set_x(book_map.x());
  find.mutable_near_center_m()->set_y(book_map.y());
  find.mutable_near_center_m()->set_z(book_map.z());
  find.set_radius_m(0.1);
  found.Clear();
  ASSERT_TRUE(query_->FindObjects(&c2, find, &found).ok());
  ASSERT_EQ(found.objects_size(), 1);
  EXPECT_EQ(found.objects(0).class_name(), "book");

  grpc::ClientContext c3;
  loci::v1::GetObjectRequest get;
  get.set_id(cup_id);
  get.set_with_cloud(true);
  loci::v1::GetObjectResponse obj;
  ASSERT_TRUE(query_->GetObject(&c3, get, &obj).ok());
  EXPECT_GT(obj.cloud_size(), 20);
  EXPECT_EQ(obj.keyframe_ids_size(), 6);
  grpc::ClientContext c4;
  get.set_id(12345);
  EXPECT_EQ(query_->GetObject(&c4, get, &obj).error_code(), grpc::StatusCode::NOT_FOUND);

  grpc::ClientContext c5;
  loci::v1::GetCloudRequest cloud_req;
  cloud_req.add_classes("background");
  loci::v1::GetCloudResponse cloud;
  ASSERT_TRUE(query_->GetCloud(&c5, cloud_req, &cloud).ok());
  ASSERT_GT(cloud.points_size(), 1000);
  for (const auto& p : cloud.points()) ASSERT_EQ(p.object_id(), 0);

  grpc::ClientContext c6;
  loci::v1::GetOctomapResponse octo;
  ASSERT_TRUE(query_->GetOctomap(&c6, {}, &octo).ok());
  EXPECT_GT(octo.octomap_bt().size(), 100u);
  EXPECT_DOUBLE_EQ(octo.resolution_m(), 0.05);
  EXPECT_FALSE(octo.rebuilding()) << "no pose has changed";
  grpc::ClientContext c6b;
  loci::v1::GetOctomapRequest waiting;
  waiting.set_wait_for_rebuild(true);
  loci::v1::GetOctomapResponse octo_waited;
  ASSERT_TRUE(query_->GetOctomap(&c6b, waiting, &octo_waited).ok());
  EXPECT_EQ(octo_waited.octomap_bt(), octo.octomap_bt());

  grpc::ClientContext c7;
  loci::v1::GetStatsResponse stats;
  ASSERT_TRUE(query_->GetStats(&c7, {}, &stats).ok());
  EXPECT_EQ(stats.keyframes(), 6u);
  EXPECT_EQ(stats.sessions(), 1u);
  EXPECT_EQ(stats.confirmed_objects(), 3u);
  EXPECT_GT(stats.db_bytes(), 0u);

  grpc::ClientContext c8;
  loci::v1::AskRequest ask;
  ask.set_text("where is the cup");
  loci::v1::AskResponse answer;
  const grpc::Status no_engine = query_->Ask(&c8, ask, &answer);
  EXPECT_EQ(no_engine.error_code(), grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_NE(no_engine.error_message().find("query engine"), std::string::npos);
}

TEST_F(ServiceTest, MalformedKeyframesAreRejectedAndChangeNothing) {
  const std::string session = Open();
  std::vector<Keyframe> frames;
  frames.push_back(Frame(session, 0));
  Keyframe corrupt = Frame(session, 1);
  corrupt.set_rgb_jpeg(corrupt.rgb_jpeg().substr(0, 200));
  frames.push_back(corrupt);
  Keyframe wrong_depth = Frame(session, 2);
  cv::Mat small(240, 320, CV_16UC1, cv::Scalar(5000));
  wrong_depth.set_depth_png(*EncodeDepthPng(small));
  frames.push_back(wrong_depth);
  Keyframe nan_pose = Frame(session, 3);
  nan_pose.mutable_t_odom_cam()->set_qx(std::nan(""));
  frames.push_back(nan_pose);
  Keyframe unknown = Frame("no-such-session", 4);
  frames.push_back(unknown);
  Keyframe bad_mask = Frame(session, 5);
  bad_mask.mutable_detections(0)->set_mask_png("not a png");
  frames.push_back(bad_mask);
  Keyframe bad_quality = Frame(session, 6);
  bad_quality.set_tracking_inliers(-3);
  frames.push_back(bad_quality);
  frames.push_back(Frame(session, 7));  // the stream still works

  grpc::Status st;
  const auto acks = Send(frames, &st);
  ASSERT_TRUE(st.ok());
  ASSERT_EQ(acks.size(), 8u);
  EXPECT_EQ(acks[0].status().code(), 0);
  const int kInvalid = static_cast<int>(absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(acks[1].status().code(), kInvalid);
  EXPECT_NE(acks[1].status().message().find("rgb_jpeg"), std::string::npos);
  EXPECT_EQ(acks[2].status().code(), kInvalid);
  EXPECT_NE(acks[2].status().message().find("depth_png"), std::string::npos);
  EXPECT_EQ(acks[3].status().code(), kInvalid);
  EXPECT_NE(acks[3].status().message().find("quaternion"), std::string::npos);
  EXPECT_EQ(acks[4].status().code(), static_cast<int>(absl::StatusCode::kNotFound));
  EXPECT_EQ(acks[5].status().code(), kInvalid);
  EXPECT_NE(acks[5].status().message().find("mask"), std::string::npos);
  EXPECT_EQ(acks[6].status().code(), kInvalid);
  EXPECT_NE(acks[6].status().message().find("tracking_inliers"), std::string::npos);
  for (int i = 1; i <= 6; ++i) EXPECT_EQ(acks[i].keyframe_id(), 0);
  EXPECT_EQ(acks[7].status().code(), 0);
  EXPECT_EQ(StoredKeyframes(), 2u);

  // 200 MB in one message: refused by gRPC's receive limit; the server lives on.
  Keyframe huge = Frame(session, 7);
  huge.set_rgb_jpeg(std::string(200u << 20, 'x'));
  grpc::Status huge_status;
  const auto huge_acks = Send({huge}, &huge_status);
  EXPECT_TRUE(huge_acks.empty());
  EXPECT_EQ(huge_status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << huge_status.error_message();
  const auto after = Send({Frame(session, 8)}, &st);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].status().code(), 0);
  EXPECT_EQ(StoredKeyframes(), 3u);
}

// A message that is not a Keyframe at all (bytes that do not parse) ends the stream with
// INVALID_ARGUMENT instead of an OK that looks like a clean end; what came before is stored.
TEST_F(ServiceTest, UnparseableMessageEndsTheStreamWithInvalidArgument) {
  const std::string session = Open();
  grpc::ClientContext ctx;
  const grpc::internal::RpcMethod method("/loci.v1.Mapping/StreamKeyframes",
                                         grpc::internal::RpcMethod::BIDI_STREAMING, channel_);
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          channel_.get(), method, &ctx));
  grpc::ByteBuffer good;
  bool own = false;
  ASSERT_TRUE(grpc::SerializationTraits<Keyframe>::Serialize(Frame(session, 0), &good, &own).ok());
  ASSERT_TRUE(stream->Write(good));
  grpc::ByteBuffer ack_bytes;
  ASSERT_TRUE(stream->Read(&ack_bytes));
  KeyframeAck ack;
  ASSERT_TRUE(grpc::SerializationTraits<KeyframeAck>::Deserialize(&ack_bytes, &ack).ok());
  EXPECT_EQ(ack.status().code(), 0);

  const std::string garbage = "\x0a\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff";  // bad varint
  grpc::Slice slice(garbage);
  grpc::ByteBuffer bad(&slice, 1);
  stream->Write(bad);
  EXPECT_FALSE(stream->Read(&ack_bytes));  // no ack for a message that is not a keyframe
  const grpc::Status st = stream->Finish();
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << st.error_message();
  EXPECT_NE(st.error_message().find("message 2"), std::string::npos) << st.error_message();
  EXPECT_EQ(StoredKeyframes(), 1u);

  grpc::Status after;
  const auto acks = Send({Frame(session, 1)}, &after);  // the server serves on
  ASSERT_EQ(acks.size(), 1u);
  EXPECT_EQ(acks[0].status().code(), 0);
  EXPECT_TRUE(after.ok());
}

// Keyframes that pass a finiteness check but would poison the map, or cost seconds and
// gigabytes to decode: each is refused with a message naming the problem, nothing is stored, and
// the map is unchanged.
TEST_F(ServiceTest, HostileKeyframesAreRefusedBeforeTheyCostAnything) {
  const std::string session = Open();
  grpc::Status st;
  ASSERT_EQ(Send({Frame(session, 0), Frame(session, 1)}, &st).size(), 2u);
  server_->Flush();
  const size_t objects_before = server_->mapper().Snapshot(false).size();
  std::vector<std::pair<Keyframe, std::string>> cases;
  auto add = [&](Keyframe kf, const std::string& expect) { cases.push_back({kf, expect}); };
  Keyframe far = Frame(session, 2);
  far.mutable_t_odom_cam()->mutable_t_m()->set_x(1e15);
  add(far, "outside the map extent");
  Keyframe epoch = Frame(session, 2);
  epoch.set_t_ns(1);
  add(epoch, "before 2000");
  Keyframe future = Frame(session, 2);
  future.set_t_ns(std::numeric_limits<int64_t>::max());
  add(future, "in the future");
  Keyframe backwards = Frame(session, 2);
  backwards.set_t_ns(StampNs(1) - 10'000'000'000LL);
  add(backwards, "must not go back");
  Keyframe png_rgb = Frame(session, 2);
  png_rgb.set_rgb_jpeg(*EncodeMaskPng(cv::Mat(480, 640, CV_8UC1, cv::Scalar(9))));
  add(png_rgb, "expected JPEG, got PNG");
  Keyframe pgm_depth = Frame(session, 2);
  std::vector<uchar> pgm;
  cv::imencode(".pgm", cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)), pgm);
  pgm_depth.set_depth_png(std::string(pgm.begin(), pgm.end()));
  add(pgm_depth, "neither JPEG nor PNG");
  Keyframe bomb = Frame(session, 2);  // the frame header claims 32000 x 32000 pixels
  std::string jpg = bomb.rgb_jpeg();
  const size_t at = jpg.find("\xFF\xC0") + 5;
  jpg[at] = jpg[at + 2] = static_cast<char>(32000 >> 8);
  jpg[at + 1] = jpg[at + 3] = static_cast<char>(32000 & 0xff);
  bomb.set_rgb_jpeg(jpg.substr(0, 600) + "\xFF\xD9");
  add(bomb, "declared size 32000x32000");
  Keyframe cut = Frame(session, 2);
  cut.set_rgb_jpeg(cut.rgb_jpeg().substr(0, cut.rgb_jpeg().size() / 2) + "\xFF\xD9");
  add(cut, "corrupt JPEG");
  Keyframe changed = Frame(session, 1);  // seq 1 again, with other images
  changed.set_rgb_jpeg(Frame(session, 3).rgb_jpeg());
  add(changed, "already stored with a different");
  std::vector<Keyframe> frames;
  for (const auto& [kf, expect] : cases) frames.push_back(kf);
  frames.push_back(Frame(session, 2));  // the stream still works
  const auto acks = Send(frames, &st);
  ASSERT_TRUE(st.ok()) << st.error_message();
  ASSERT_EQ(acks.size(), frames.size());
  for (size_t i = 0; i < cases.size(); ++i) {
    EXPECT_NE(acks[i].status().code(), 0) << cases[i].second;
    EXPECT_NE(acks[i].status().message().find(cases[i].second), std::string::npos)
        << "case '" << cases[i].second << "': " << acks[i].status().message();
  }
  EXPECT_EQ(acks[cases.size() - 1].status().code(),
            static_cast<int>(absl::StatusCode::kAlreadyExists));
  EXPECT_TRUE(acks[cases.size() - 1].duplicate());
  EXPECT_EQ(acks.back().status().code(), 0);
  EXPECT_EQ(StoredKeyframes(), 3u);
  server_->Flush();
  EXPECT_GE(server_->mapper().Snapshot(false).size(), objects_before);
  for (const MapObject& o : server_->mapper().Snapshot(false)) {
    EXPECT_LT(o.centroid_m.norm(), 20.0) << o.class_name;
  }
}

TEST_F(ServiceTest, ResumeAfterRestartReturnsLastStoredSeqAndSameObjects) {
  const std::string session = Open();
  grpc::Status st;
  Send({Frame(session, 0), Frame(session, 1), Frame(session, 2), Frame(session, 3)}, &st);
  server_->Flush();
  const auto before = server_->mapper().Snapshot(true);
  ASSERT_EQ(before.size(), 3u);
  Stop();
  Start();  // same DB: the map is rebuilt from the stored keyframes
  EXPECT_EQ(server_->stats().replayed_keyframes, 4u);
  const auto after = server_->mapper().Snapshot(true);
  ASSERT_EQ(after.size(), before.size());
  for (size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(after[i].id, before[i].id);
    EXPECT_EQ(after[i].class_name, before[i].class_name);
    EXPECT_TRUE(after[i].centroid_m.isApprox(before[i].centroid_m, 1e-9));
  }
  int64_t last_seq = 0;
  EXPECT_EQ(Open(/*resume=*/true, &last_seq), session);
  EXPECT_EQ(last_seq, 3);
  const auto acks = Send({Frame(session, 3), Frame(session, 4)}, &st);
  ASSERT_EQ(acks.size(), 2u);
  EXPECT_TRUE(acks[0].duplicate());
  EXPECT_FALSE(acks[1].duplicate());
  EXPECT_EQ(StoredKeyframes(), 5u);
}

TEST_F(ServiceTest, WatchObjectsStreamsCreatedEvents) {
  grpc::ClientContext watch_ctx;
  watch_ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  auto reader = query_->WatchObjects(&watch_ctx, {});
  reader->WaitForInitialMetadata();  // sent once the watcher is registered
  const std::string session = Open();
  grpc::Status st;
  Send({Frame(session, 0)}, &st);
  server_->Flush();
  loci::v1::ObjectEvent event;
  ASSERT_TRUE(reader->Read(&event));
  EXPECT_EQ(event.kind(), loci::v1::ObjectEvent::CREATED);
  EXPECT_FALSE(event.object().class_name().empty());
  watch_ctx.TryCancel();
  reader->Finish();
}

// Each watcher holds a server thread: past server.max_watchers a new one is refused at once.
TEST_F(ServiceTest, WatchersBeyondTheCapAreRefused) {
  Stop();
  Start(nullptr, /*max_watchers=*/2);
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<loci::v1::ObjectEvent>>> readers;
  for (int i = 0; i < 3; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    contexts.back()->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    readers.push_back(query_->WatchObjects(contexts.back().get(), {}));
    if (i < 2) readers.back()->WaitForInitialMetadata();  // registered
  }
  loci::v1::ObjectEvent event;
  EXPECT_FALSE(readers[2]->Read(&event));
  const grpc::Status refused = readers[2]->Finish();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("max_watchers"), std::string::npos);
  for (int i = 0; i < 2; ++i) {
    contexts[i]->TryCancel();
    readers[i]->Finish();
  }
}

TEST_F(ServiceTest, ServerDetectorRunsOnKeyframesWithoutDetections) {
  std::map<int64_t, std::vector<Detection2D>> by_t_ns;
  for (int i = 0; i < 6; ++i) by_t_ns[StampNs(i)] = views_[i].detections;
  auto detector = std::make_shared<ViewDetector>(by_t_ns);
  Stop();
  Start(std::make_shared<KeyframeDetection>(
      std::vector<std::shared_ptr<detection::Detector>>{detector}, KeyframeDetectionOptions{}));
  const std::string session = Open();
  std::vector<Keyframe> frames;
  for (int i = 0; i < 6; ++i) {
    frames.push_back(Frame(session, i));
    frames.back().clear_detections();
  }
  grpc::Status st;
  ASSERT_EQ(Send(frames, &st).size(), 6u);
  server_->Flush();
  EXPECT_EQ(detector->calls, 6);
  EXPECT_EQ(server_->mapper().Snapshot(true).size(), 3u);
}

// Mode "all": every keyframe is detected on the server, whatever the robot sent; when the
// server's detector fails, the robot's boxes are mapped instead.
TEST_F(ServiceTest, ServerDetectionInModeAllReplacesTheRobotsBoxesElseFallsBackToThem) {
  std::map<int64_t, std::vector<Detection2D>> by_t_ns;
  for (int i = 0; i < 6; ++i) by_t_ns[StampNs(i)] = views_[i].detections;
  for (const bool server_fails : {false, true}) {
    auto detector = std::make_shared<ViewDetector>(by_t_ns);
    detector->fail = server_fails;
    Stop();
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(db_ + suffix);
    KeyframeDetectionOptions mode_all;
    mode_all.mode = DetectMode::kAll;
    auto detection = std::make_shared<KeyframeDetection>(
        std::vector<std::shared_ptr<detection::Detector>>{detector}, mode_all);
    Start(detection);
    const std::string session = Open();
    std::vector<Keyframe> frames;
    for (int i = 0; i < 6; ++i) {
      frames.push_back(Frame(session, i));
      // The robot's detector saw only the first object: the server's sees all three.
      auto* robot_boxes = frames.back().mutable_detections();
      if (!server_fails && robot_boxes->size() > 1) {
        robot_boxes->DeleteSubrange(1, robot_boxes->size() - 1);
      }
    }
    grpc::Status st;
    ASSERT_EQ(Send(frames, &st).size(), 6u);
    server_->Flush();
    EXPECT_EQ(detector->calls, 6);
    EXPECT_EQ(detection->detected(), server_fails ? 0 : 6);
    EXPECT_EQ(detection->failed(), server_fails ? 6 : 0);
    EXPECT_EQ(server_->mapper().Snapshot(true).size(), 3u) << "server fails: " << server_fails;
  }
}

TEST_F(ServiceTest, OpenSessionValidatesItsRequest) {
  grpc::ClientContext ctx;
  loci::v1::OpenSessionResponse resp;
  EXPECT_EQ(
      mapping_->OpenSession(&ctx, testing::OpenRequest("bad name!", camera_), &resp).error_code(),
      grpc::StatusCode::INVALID_ARGUMENT);
  grpc::ClientContext ctx2;
  PinholeCamera bad = camera_;
  bad.fx = -1;
  EXPECT_EQ(mapping_->OpenSession(&ctx2, testing::OpenRequest("r", bad), &resp).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
}

}  // namespace
}  // namespace loci::server

// End to end on the shipped real sample: a real loci-server on a free loopback port,
// loci-track with YOLOX-Nano streaming tests/data/tum_fr1_rpy_sample (2 s of a real office),
// then questions over gRPC.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>
#include <string>

#include "common/tum_io.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/storage/sqlite_store.h"
#include "tests/support/server_process.h"

namespace loci {
namespace {

namespace fs = std::filesystem;
const std::string kRoot = LOCI_SOURCE_DIR;

struct Bounds {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = Eigen::Vector3d::Constant(-1e9);
  bool Contains(const v1::Vec3& p) const {
    const Eigen::Vector3d v(p.x(), p.y(), p.z());
    return (v.array() >= lo.array()).all() && (v.array() <= hi.array()).all();
  }
};

TEST(DemoPath, TrackStreamDetectAskOnShippedSample) {
  const std::string dir =
      (fs::temp_directory_path() / ("loci_e2e_" + std::to_string(getpid()))).string();
  fs::create_directories(dir);
  testing::ServerProcess server(testing::ServerProcessOptions{
      .db = dir + "/loci.db", .config = kRoot + "/config/server.yaml"});
  ASSERT_GT(server.port(), 0) << "loci-server did not print its port";
  const std::string addr = "127.0.0.1:" + std::to_string(server.port());

  const std::string traj_path = dir + "/trajectory.txt";
  const std::string cmd = std::string(LOCI_TRACK_BIN) + " --tum " + kRoot +
                          "/tests/data/tum_fr1_rpy_sample --server " + addr +
                          " --robot e2e --no-progress --log-level warn --model " + kRoot +
                          "/models/yolox_nano/yolox_nano.onnx --trajectory " + traj_path;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  // The scene: the camera positions of the run (map frame = the session's odometry frame)
  // widened by 4 m.
  auto traj = ReadTumTrajectory(traj_path);
  ASSERT_TRUE(traj.ok());
  ASSERT_GT(traj->size(), 50u);
  Bounds scene;
  for (const StampedPose& p : *traj) {
    scene.lo = scene.lo.cwiseMin(p.T_world_cam.translation());
    scene.hi = scene.hi.cwiseMax(p.T_world_cam.translation());
  }
  scene.lo.array() -= 4.0;
  scene.hi.array() += 4.0;

  auto channel = grpc::CreateChannel(addr, grpc::InsecureChannelCredentials());
  auto query = v1::Query::NewStub(channel);

  // The map holds confirmed objects (the existence belief passed its threshold in these 2 s),
  // each inside the scene.
  v1::FindObjectsRequest find;
  find.set_confirmed_only(true);
  v1::FindObjectsResponse found;
  {
    grpc::ClientContext ctx;
    ASSERT_TRUE(query->FindObjects(&ctx, find, &found).ok());
  }
  ASSERT_GT(found.objects_size(), 0) << "no confirmed object in the map";
  const v1::Object* most_seen = &found.objects(0);
  for (const v1::Object& o : found.objects()) {
    EXPECT_TRUE(o.confirmed()) << o.class_name() << " #" << o.id();
    EXPECT_TRUE(scene.Contains(o.centroid_m())) << o.class_name() << " #" << o.id();
    if (o.observation_count() > most_seen->observation_count()) most_seen = &o;
  }

  // "where is the <class>" for the most observed one names its class with a position inside
  // the scene.
  const std::string target = most_seen->class_name();
  v1::AskRequest ask;
  ask.set_text("where is the " + target);
  v1::AskResponse answer;
  {
    grpc::ClientContext ctx;
    const grpc::Status st = query->Ask(&ctx, ask, &answer);
    ASSERT_TRUE(st.ok()) << st.error_message();
  }
  std::cout << "? " << ask.text() << "\n" << answer.answer() << "\n";
  EXPECT_EQ(answer.intent(), "where");
  EXPECT_NE(answer.answer().find(target), std::string::npos) << answer.answer();
  ASSERT_GT(answer.objects_size(), 0) << answer.answer();
  EXPECT_EQ(answer.objects(0).class_name(), target);
  EXPECT_TRUE(scene.Contains(answer.objects(0).centroid_m())) << answer.answer();
  // The sample was recorded in 2011: ages are told in map time (relative to the newest
  // keyframe), so the object seen during these 2 s was seen seconds ago, not years.
  EXPECT_EQ(answer.answer().find("days ago"), std::string::npos) << answer.answer();
  EXPECT_NE(answer.answer().find(" s ago"), std::string::npos) << answer.answer();

  // SIGTERM: a clean shutdown with exit code 0.
  const int status = server.Stop(SIGTERM);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;

  // The detections were stored with loci-track's depth masks: one mask per detection, the size
  // of its box, covering part of the box (the object without the background).
  {
    auto store = server::SqliteStore::Open(dir + "/loci.db");
    ASSERT_TRUE(store.ok()) << store.status();
    int detections = 0, masked = 0, partial = 0;
    ASSERT_TRUE((*store)
                    ->ForEachKeyframe(0,
                                      [&](server::KeyframeRecord kf) {
                                        for (const Detection2D& d : kf.detections) {
                                          ++detections;
                                          if (d.mask.empty()) continue;
                                          ++masked;
                                          const cv::Rect r = MaskRect(d.box_px, kf.camera.width_px,
                                                                      kf.camera.height_px);
                                          EXPECT_EQ(d.mask.size(), r.size());
                                          partial += cv::countNonZero(d.mask) < 0.95 * r.area();
                                        }
                                        return absl::OkStatus();
                                      })
                    .ok());
    std::cout << "stored detections " << detections << ", with mask " << masked
              << ", mask leaves out part of the box " << partial << "\n";
    ASSERT_GT(detections, 0);
    EXPECT_GE(masked, detections * 9 / 10);
    EXPECT_GE(partial, masked / 2);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loci

// KeyframeStage (loci-track's detect-and-send stage): every keyframe reaches the sink in order,
// the detector's boxes are attached and become LatestDetections, the bounded queue pushes back
// on a slow sink, sink errors come out of Finish, and a Push after Finish is refused, never
// dropped silently. No sleeps: the blocked Push is observed through a future.
#include "client/app/keyframe_stage.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

namespace loci {
namespace {

using namespace std::chrono_literals;

KeyframeData Keyframe(int64_t t_ns) {
  KeyframeData kf;
  kf.t_ns = t_ns;
  kf.bgr = cv::Mat(4, 4, CV_8UC3, cv::Scalar(0, 0, 0));
  return kf;
}

// One box per keyframe, its score the keyframe's stamp in seconds.
class StampDetector : public detection::Detector {
 public:
  StatusOr<std::vector<Detection2D>> Detect(const cv::Mat&, int64_t t_ns) override {
    Detection2D d;
    d.class_name = "cup";
    d.score = static_cast<float>(t_ns) * 1e-9f;
    return std::vector<Detection2D>{d};
  }
  std::string Name() const override { return "stamp"; }
};

// Records what reaches it, on which thread.
struct Recorder {
  std::mutex mu;
  std::vector<int64_t> stamps;
  std::vector<std::thread::id> threads;
  KeyframeStage::Sink Sink() {
    return [this](KeyframeData kf) {
      std::lock_guard<std::mutex> lock(mu);
      stamps.push_back(kf.t_ns);
      threads.push_back(std::this_thread::get_id());
      return absl::OkStatus();
    };
  }
};

TEST(KeyframeStage, LiveStageDeliversEveryKeyframeInOrderOffTheCallersThread) {
  Recorder rec;
  KeyframeStage stage(nullptr, nullptr, rec.Sink(), /*capacity=*/2);
  for (int64_t t = 1; t <= 20; ++t) ASSERT_TRUE(stage.Push(Keyframe(t)).ok());
  ASSERT_TRUE(stage.Finish().ok());
  std::vector<int64_t> want;
  for (int64_t t = 1; t <= 20; ++t) want.push_back(t);
  EXPECT_EQ(rec.stamps, want);
  for (const std::thread::id& id : rec.threads) EXPECT_NE(id, std::this_thread::get_id());
}

TEST(KeyframeStage, SynchronousStageProcessesBeforePushReturns) {
  Recorder rec;
  KeyframeStage stage(std::make_unique<StampDetector>(), nullptr, rec.Sink(), /*capacity=*/0);
  ASSERT_TRUE(stage.Push(Keyframe(2'000'000'000)).ok());
  ASSERT_EQ(rec.stamps.size(), 1u);  // already through the sink
  EXPECT_EQ(rec.threads[0], std::this_thread::get_id());
  const FrameDetections latest = stage.LatestDetections();
  EXPECT_EQ(latest.t_ns, 2'000'000'000);
  ASSERT_EQ(latest.detections.size(), 1u);
  EXPECT_FLOAT_EQ(latest.detections[0].score, 2.0f);
  EXPECT_EQ(stage.detected_keyframes(), 1);
  EXPECT_TRUE(stage.Finish().ok());
}

TEST(KeyframeStage, DetectorBoxesReachTheSink) {
  std::vector<std::vector<Detection2D>> seen;
  KeyframeStage stage(std::make_unique<StampDetector>(), nullptr,
                      [&](KeyframeData kf) {
                        seen.push_back(kf.detections);
                        return absl::OkStatus();
                      },
                      /*capacity=*/1);
  ASSERT_TRUE(stage.Push(Keyframe(1'000'000'000)).ok());
  ASSERT_TRUE(stage.Push(Keyframe(3'000'000'000)).ok());
  ASSERT_TRUE(stage.Finish().ok());  // joins the worker: `seen` is complete
  ASSERT_EQ(seen.size(), 2u);
  ASSERT_EQ(seen[1].size(), 1u);
  EXPECT_EQ(seen[1][0].class_name, "cup");
  EXPECT_FLOAT_EQ(seen[1][0].score, 3.0f);
  EXPECT_EQ(stage.LatestDetections().t_ns, 3'000'000'000);
  EXPECT_EQ(stage.detected_keyframes(), 2);
}

TEST(KeyframeStage, FullQueueBlocksPushUntilTheSinkMovesOn) {
  std::mutex mu;
  std::condition_variable cv;
  bool open = false;
  int entered = 0;
  KeyframeStage stage(nullptr, nullptr,
                      [&](KeyframeData) {
                        std::unique_lock<std::mutex> lock(mu);
                        ++entered;
                        cv.notify_all();
                        cv.wait(lock, [&] { return open; });
                        return absl::OkStatus();
                      },
                      /*capacity=*/1);
  ASSERT_TRUE(stage.Push(Keyframe(1)).ok());
  {
    // Keyframe 1 is in the sink, so keyframe 2 fills the queue.
    std::unique_lock<std::mutex> lock(mu);
    cv.wait(lock, [&] { return entered == 1; });
  }
  ASSERT_TRUE(stage.Push(Keyframe(2)).ok());
  auto third = std::async(std::launch::async, [&] { return stage.Push(Keyframe(3)); });
  // Back-pressure: the third Push cannot return while the sink holds keyframe 1.
  EXPECT_EQ(third.wait_for(100ms), std::future_status::timeout);
  {
    std::lock_guard<std::mutex> lock(mu);
    open = true;
    cv.notify_all();
  }
  EXPECT_TRUE(third.get().ok());
  ASSERT_TRUE(stage.Finish().ok());
  EXPECT_EQ(entered, 3);
}

TEST(KeyframeStage, FinishReportsTheFirstSinkErrorAndKeepsGoing) {
  int calls = 0;
  KeyframeStage stage(nullptr, nullptr,
                      [&](KeyframeData kf) -> Status {
                        ++calls;
                        if (kf.t_ns == 2) return absl::UnavailableError("server gone");
                        if (kf.t_ns == 3) return absl::InternalError("second error");
                        return absl::OkStatus();
                      },
                      /*capacity=*/4);
  for (int64_t t = 1; t <= 4; ++t) ASSERT_TRUE(stage.Push(Keyframe(t)).ok());
  const Status s = stage.Finish();
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable) << s;
  EXPECT_EQ(calls, 4);
}

TEST(KeyframeStage, PushAfterFinishIsRefusedNotDropped) {
  for (size_t capacity : {0u, 2u}) {
    Recorder rec;
    KeyframeStage stage(nullptr, nullptr, rec.Sink(), capacity);
    ASSERT_TRUE(stage.Push(Keyframe(1)).ok());
    ASSERT_TRUE(stage.Finish().ok());
    const Status late = stage.Push(Keyframe(2));
    EXPECT_EQ(late.code(), absl::StatusCode::kFailedPrecondition) << "capacity " << capacity;
    EXPECT_EQ(rec.stamps, std::vector<int64_t>{1}) << "capacity " << capacity;
    EXPECT_TRUE(stage.Finish().ok());  // a second Finish is harmless
  }
}

}  // namespace
}  // namespace loci

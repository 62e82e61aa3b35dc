// LateKeyframeUpdates: keyframes mapped while the pose graph solved follow their session.
#include "server/runtime/late_keyframes.h"

#include <gtest/gtest.h>

#include <map>

namespace loci::server {
namespace {

SE3d Pose(double x, double yaw_deg) {
  return MakeSE3(Vec3d(x, 0.2 * x, 0.0),
                 Quatd(Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Vec3d::UnitZ())));
}

TEST(LateKeyframeUpdates, FollowTheirSessionsNewestSolvedKeyframe) {
  // Session 1: keyframes 1-3 solved, 3 moved; 4 and 5 mapped during the solve.
  // Session 2: keyframe 6 solved and not moved; 7 mapped during the solve.
  // Keyframe 8 belongs to no known session, keyframe 9 to a session the solve never saw.
  const std::map<int64_t, int64_t> session = {{1, 1}, {2, 1}, {3, 1}, {4, 1}, {5, 1},
                                              {6, 2}, {7, 2}, {9, 3}};
  const auto session_of = [&](int64_t id) -> std::optional<int64_t> {
    auto it = session.find(id);
    return it == session.end() ? std::nullopt : std::optional<int64_t>(it->second);
  };
  std::vector<Mapper::KeyframePoseUpdate> solved, now;
  for (int64_t id = 1; id <= 9; ++id) {
    const Mapper::KeyframePoseUpdate p{id, Pose(0.1 * id, 3.0 * id)};
    if (id <= 3 || id == 6) solved.push_back(p);
    now.push_back(p);
  }
  const SE3d correction = Pose(0.05, 4.0);  // the solve moved keyframe 3 by this
  const std::vector<Mapper::KeyframePoseUpdate> moved = {{2, Pose(0.3, 1.0)},
                                                         {3, correction * solved[2].T_base_kf}};
  const auto late = LateKeyframeUpdates(solved, moved, now, session_of);
  ASSERT_EQ(late.size(), 2u);
  for (size_t i = 0; i < late.size(); ++i) {
    const int64_t id = 4 + static_cast<int64_t>(i);
    EXPECT_EQ(late[i].keyframe_id, id);
    // The late keyframe keeps its pose relative to keyframe 3.
    const SE3d rel_before = now[2].T_base_kf.inverse() * now[id - 1].T_base_kf;
    const SE3d rel_after = moved[1].T_base_kf.inverse() * late[i].T_base_kf;
    EXPECT_TRUE(rel_after.matrix().isApprox(rel_before.matrix(), 1e-12)) << id;
  }
  // Nothing moved: nothing follows.
  EXPECT_TRUE(LateKeyframeUpdates(solved, {}, now, session_of).empty());
  // Only keyframe 2 moved: session 1's newest solved keyframe (3) did not, so 4 and 5 stay.
  EXPECT_TRUE(LateKeyframeUpdates(solved, {moved[0]}, now, session_of).empty());
}

}  // namespace
}  // namespace loci::server

#include "common/se3.h"

#include <cmath>

#include <gtest/gtest.h>

namespace loci {
namespace {

TEST(Se3, TumRoundTripAndComposition) {
  const SE3d T_a_b = SE3FromTum(1.0, -2.0, 0.5, 0.1, 0.2, 0.3, 0.927);
  const Quatd q = QuatOf(T_a_b);
  EXPECT_NEAR(q.norm(), 1.0, 1e-12);
  EXPECT_GE(q.w(), 0.0);
  const Vec3d p_b(0.3, 0.4, 2.0);
  const Vec3d p_a = T_a_b * p_b;
  EXPECT_TRUE((T_a_b.inverse() * p_a).isApprox(p_b, 1e-12));
  const SE3d T_b_c = SE3FromTum(0, 0, 1, 0, 0, 0, 1);
  EXPECT_TRUE(((T_a_b * T_b_c) * Vec3d::Zero()).isApprox(T_a_b * Vec3d(0, 0, 1), 1e-12));
}

TEST(Se3, ValidatePoseRejectsNanAndNonUnit) {
  EXPECT_TRUE(ValidatePose(Vec3d(0, 0, 0), 1, 0, 0, 0).ok());
  EXPECT_FALSE(ValidatePose(Vec3d(NAN, 0, 0), 1, 0, 0, 0).ok());
  EXPECT_FALSE(ValidatePose(Vec3d(0, 0, 0), NAN, 0, 0, 0).ok());
  const Status s = ValidatePose(Vec3d(0, 0, 0), 2, 0, 0, 0);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("not unit"), std::string::npos);
}

TEST(Se3, RotationAngleAndAlignment) {
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.4, Vec3d::UnitY()).toRotationMatrix();
  EXPECT_NEAR(RotationAngleRad(T), 0.4, 1e-12);
  const Vec3d up = Vec3d(0.1, -0.9, -0.4).normalized();
  EXPECT_TRUE((RotationAligningToZ(up) * up).isApprox(Vec3d::UnitZ(), 1e-12));
}

}  // namespace
}  // namespace loci

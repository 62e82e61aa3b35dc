#include "server/graph/graph_residuals.h"

#include <Eigen/Cholesky>

namespace loci::server {

RelativePoseError::RelativePoseError(const SE3d& T_a_b, const Information6& information)
    : t_ab_(T_a_b.translation()), q_ab_(QuatOf(T_a_b)) {
  sqrt_information_ = information.llt().matrixL().transpose();
}

ceres::CostFunction* RelativePoseError::Create(const SE3d& T_a_b,
                                               const Information6& information) {
  return new ceres::AutoDiffCostFunction<RelativePoseError, 6, 3, 4, 3, 4>(
      new RelativePoseError(T_a_b, information));
}

ceres::CostFunction* CentroidError::Create(const Vec3d& c_kf_m, double sigma_m) {
  return new ceres::AutoDiffCostFunction<CentroidError, 3, 3, 4, 3>(
      new CentroidError(c_kf_m, sigma_m));
}

ceres::CostFunction* GravityError::Create(const Vec3d& up_kf, double sigma_rad) {
  return new ceres::AutoDiffCostFunction<GravityError, 2, 4>(new GravityError(up_kf, sigma_rad));
}

}  // namespace loci::server

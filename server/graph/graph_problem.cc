#include "server/graph/graph_problem.h"

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <array>
#include <chrono>
#include <memory>

#include "server/graph/graph_residuals.h"

namespace loci::server {
namespace {

struct PoseBlocks {
  std::vector<std::array<double, 3>> t;
  std::vector<std::array<double, 4>> q;  // x, y, z, w
};

PoseBlocks ToBlocks(const std::vector<SE3d>& poses) {
  PoseBlocks b;
  b.t.resize(poses.size());
  b.q.resize(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    Eigen::Map<Vec3d>(b.t[i].data()) = poses[i].translation();
    Eigen::Map<Quatd>(b.q[i].data()) = QuatOf(poses[i]);
  }
  return b;
}

ceres::LossFunction* MakeLoss(const RobustLossOptions& o) {
  if (o.type == "huber") return new ceres::HuberLoss(o.scale);
  if (o.type == "cauchy") return new ceres::CauchyLoss(o.scale);
  return nullptr;
}

void AddPoses(const SolverInput& in, PoseBlocks* b, ceres::Problem* problem) {
  for (size_t i = 0; i < b->t.size(); ++i) {
    problem->AddParameterBlock(b->t[i].data(), 3);
    problem->AddParameterBlock(b->q[i].data(), 4,
                               in.four_dof ? YawOnlyQuaternion::Create()
                                           : new ceres::EigenQuaternionManifold);
  }
  for (const size_t a : in.anchors) {
    problem->SetParameterBlockConstant(b->t[a].data());
    problem->SetParameterBlockConstant(b->q[a].data());
  }
}

void AddEdges(const SolverInput& in, const GraphOptions& o, PoseBlocks* b,
              ceres::Problem* problem) {
  for (const SolverEdge& e : in.edges) {
    problem->AddResidualBlock(RelativePoseError::Create(e.T_a_b, e.information),
                              e.robust ? MakeLoss(o.loss) : nullptr, b->t[e.a].data(),
                              b->q[e.a].data(), b->t[e.b].data(), b->q[e.b].data());
  }
}

void AddLandmarks(const SolverInput& in, const GraphOptions& o, PoseBlocks* b,
                  std::vector<Vec3d>* landmarks, ceres::Problem* problem) {
  const double huber = o.landmarks.huber_m / o.landmarks.sigma_m;
  for (const SolverObservation& obs : in.observations) {
    problem->AddResidualBlock(CentroidError::Create(obs.c_kf_m, o.landmarks.sigma_m),
                              new ceres::HuberLoss(huber), b->t[obs.node].data(),
                              b->q[obs.node].data(), (*landmarks)[obs.landmark].data());
  }
}

void AddGravity(const SolverInput& in, const GraphOptions& o, PoseBlocks* b,
                ceres::Problem* problem) {
  for (const auto& [node, up_kf] : in.gravity) {
    problem->AddResidualBlock(GravityError::Create(up_kf, o.gravity.sigma_rad),
                              new ceres::CauchyLoss(o.gravity.loss_scale), b->q[node].data());
  }
}

ceres::Solver::Options SolverOptions(const GraphSolverOptions& o) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = o.threads;
  so.function_tolerance = o.function_tolerance;
  so.logging_type = ceres::SILENT;
  return so;
}

std::vector<SE3d> FromBlocks(const PoseBlocks& b) {
  std::vector<SE3d> poses(b.t.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    poses[i] = MakeSE3(Eigen::Map<const Vec3d>(b.t[i].data()),
                       Eigen::Map<const Quatd>(b.q[i].data()));
  }
  return poses;
}

}  // namespace

StatusOr<SolverOutput> SolvePoseGraph(const SolverInput& in, const GraphOptions& o) {
  PoseBlocks blocks = ToBlocks(in.T_map_kf);
  std::vector<Vec3d> landmarks = in.landmarks_map;
  ceres::Problem problem;
  AddPoses(in, &blocks, &problem);
  AddEdges(in, o, &blocks, &problem);
  AddLandmarks(in, o, &blocks, &landmarks, &problem);
  AddGravity(in, o, &blocks, &problem);
  SolverOutput out;
  if (problem.NumResidualBlocks() == 0) {
    out.T_map_kf = in.T_map_kf;
    out.landmarks_map = landmarks;
    out.converged = true;
    return out;
  }
  ceres::Solver::Summary summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solve(SolverOptions(o.solver), &problem, &summary);
  out.solve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (summary.termination_type == ceres::FAILURE || !summary.IsSolutionUsable()) {
    return absl::InternalError(absl::StrCat("pose graph: Ceres failed: ", summary.message));
  }
  out.T_map_kf = FromBlocks(blocks);
  out.landmarks_map = landmarks;
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  out.iterations = static_cast<int>(summary.iterations.size()) - 1;
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  return out;
}

}  // namespace loci::server

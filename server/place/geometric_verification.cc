#include "server/place/geometric_verification.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <vector>

#include "server/place/binary_descriptor.h"
#include "server/place/point_alignment.h"

namespace loci::place {
namespace {

constexpr int kAlignIterations = 5;
constexpr int kRefineIterations = 10;

// A descriptor match: index of the keypoint in a and in b.
struct Match {
  int a;
  int b;
};

// Matches of a's descriptors in b passing the ratio test and max_hamming.
std::vector<Match> RatioMatches(const KeyframeFeatures& a, const KeyframeFeatures& b,
                                const VerifyOptions& options) {
  std::vector<Match> out;
  if (a.size() == 0 || b.size() < 2) return out;
  const std::vector<TwoNearest> nearest = TwoNearestRows(a.descriptors, b.descriptors);
  for (size_t i = 0; i < nearest.size(); ++i) {
    const TwoNearest& n = nearest[i];
    if (n.best > options.max_hamming) continue;
    if (n.best < options.ratio * n.second) out.push_back({static_cast<int>(i), n.index});
  }
  return out;
}

SE3d ToSE3(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Mat3d R_e;
  Vec3d t_e;
  cv::cv2eigen(R, R_e);
  cv::cv2eigen(tvec, t_e);
  SE3d T = SE3d::Identity();
  T.linear() = R_e;
  T.translation() = t_e;
  return T;
}

// PnP-RANSAC of b's 3D points against a's pixels: T_a_b and the indices (into `matches`) of
// the inliers. Only matches whose b keypoint has depth take part.
std::vector<int> PnpInliers(const KeyframeFeatures& a, const KeyframeFeatures& b,
                            const std::vector<Match>& matches, const VerifyOptions& options,
                            SE3d* T_a_b) {
  std::vector<cv::Point3f> p_b;
  std::vector<cv::Point2f> uv_a;
  std::vector<int> index;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (!b.HasDepth(matches[i].b)) continue;
    const Eigen::Vector3f& p = b.p_kf_m[matches[i].b];
    p_b.emplace_back(p.x(), p.y(), p.z());
    uv_a.emplace_back(a.uv_px[matches[i].a].x(), a.uv_px[matches[i].a].y());
    index.push_back(static_cast<int>(i));
  }
  if (static_cast<int>(p_b.size()) < options.min_inliers) return {};
  cv::Mat K;
  cv::eigen2cv(a.camera.K(), K);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  bool ok = false;
  try {
    ok = cv::solvePnPRansac(p_b, uv_a, K, cv::noArray(), rvec, tvec, false,
                            options.pnp_iterations,
                            static_cast<float>(options.pnp_reprojection_px),
                            options.pnp_confidence, inliers, cv::SOLVEPNP_SQPNP);
  } catch (const cv::Exception&) {
    // SQPnP asserts on degenerate point sets (OpenCV 4.6 sqpnp.cpp computeOmega: "more than 6
    // null vectors", seen live on a real sequence); such a pair is no place match.
    return {};
  }
  if (!ok) return {};
  *T_a_b = ToSE3(rvec, tvec);
  for (int& i : inliers) i = index[i];
  return inliers;
}

// Iterated Umeyama on the point pairs that agree within max_point_error_m under the current
// T_a_b. Returns the number of inliers and their RMS residual.
int AlignPoints(const Eigen::Matrix3Xd& p_a, const Eigen::Matrix3Xd& p_b,
                const VerifyOptions& options, SE3d* T_a_b, double* rms_m) {
  int count = 0;
  for (int it = 0; it < kAlignIterations; ++it) {
    std::vector<int> keep;
    for (int i = 0; i < p_a.cols(); ++i) {
      if ((p_a.col(i) - *T_a_b * p_b.col(i)).norm() <= options.max_point_error_m) keep.push_back(i);
    }
    if (keep.size() < 3) return 0;
    Eigen::Matrix3Xd src(3, keep.size()), dst(3, keep.size());
    for (size_t k = 0; k < keep.size(); ++k) {
      src.col(k) = p_b.col(keep[k]);
      dst.col(k) = p_a.col(keep[k]);
    }
    T_a_b->matrix() = Eigen::umeyama(src, dst, false);
    const bool stable = static_cast<int>(keep.size()) == count;
    count = static_cast<int>(keep.size());
    *rms_m = std::sqrt((dst - *T_a_b * src).colwise().squaredNorm().mean());
    if (stable) break;
  }
  return count;
}

// Share of the image covered by the box of the middle 90% of the pixels in u and in v.
double InlierArea(std::vector<Eigen::Vector2f> uv, const PinholeCamera& camera) {
  if (uv.size() < 2) return 0;
  std::vector<float> u, w;
  for (const Eigen::Vector2f& p : uv) {
    u.push_back(p.x());
    w.push_back(p.y());
  }
  std::sort(u.begin(), u.end());
  std::sort(w.begin(), w.end());
  const size_t lo = uv.size() / 20, hi = uv.size() - 1 - uv.size() / 20;
  return static_cast<double>(u[hi] - u[lo]) * (w[hi] - w[lo]) /
         (static_cast<double>(camera.width_px) * camera.height_px);
}

// The final estimate: Gauss-Newton on the pairs within max_point_error_m under v->T_a_b,
// weighted by depth-camera noise (point_alignment.h); also sets v->inlier_area.
void RefineWeighted(const KeyframeFeatures& a, const KeyframeFeatures& b,
                    const std::vector<Match>& pairs, const Eigen::Matrix3Xd& p_a,
                    const Eigen::Matrix3Xd& p_b, const VerifyOptions& options, Verification* v) {
  PointNoise noise_a, noise_b;
  noise_a.depth_sigma_m_per_m2 = noise_b.depth_sigma_m_per_m2 = options.depth_sigma_m_per_m2;
  noise_a.focal_px = a.camera.fx;
  noise_b.focal_px = b.camera.fx;
  std::vector<Eigen::Vector3d> in_a, in_b;
  std::vector<Eigen::Matrix3d> cov_a, cov_b;
  std::vector<Eigen::Vector2f> uv_a;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if ((p_a.col(k) - v->T_a_b * p_b.col(k)).norm() > options.max_point_error_m) continue;
    in_a.push_back(p_a.col(k));
    in_b.push_back(p_b.col(k));
    uv_a.push_back(a.uv_px[pairs[k].a]);
    const double sigma_a_px = a.PixelSigma(pairs[k].a, options.pixel_sigma_px);
    const double sigma_b_px = b.PixelSigma(pairs[k].b, options.pixel_sigma_px);
    cov_a.push_back(PointCovariance(in_a.back(), sigma_a_px, noise_a));
    cov_b.push_back(PointCovariance(in_b.back(), sigma_b_px, noise_b));
  }
  v->inlier_area = InlierArea(uv_a, a.camera);
  const AlignmentFit fit = RefineAlignment(in_a, in_b, cov_a, cov_b, kRefineIterations, &v->T_a_b);
  v->rotation_sigma_deg = fit.rotation_sigma_rad * 180.0 / M_PI;
  v->chi2_per_pair = fit.pairs > 0 ? fit.chi2 / fit.pairs : 0.0;
}

// The 3D-3D stage on the PnP inliers with depth in both keyframes: the Umeyama check (inlier
// count, RMS), then the weighted refinement.
void Check3d(const KeyframeFeatures& a, const KeyframeFeatures& b, const std::vector<Match>& m,
             const std::vector<int>& pnp_inliers, const VerifyOptions& options, Verification* v) {
  std::vector<Match> pairs;
  for (const int i : pnp_inliers) {
    if (a.HasDepth(m[i].a)) pairs.push_back(m[i]);
  }
  Eigen::Matrix3Xd p_a(3, pairs.size()), p_b(3, pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    p_a.col(k) = a.p_kf_m[pairs[k].a].cast<double>();
    p_b.col(k) = b.p_kf_m[pairs[k].b].cast<double>();
  }
  v->inliers = AlignPoints(p_a, p_b, options, &v->T_a_b, &v->rms_m);
  v->T_a_b_3d = v->T_a_b;
  if (v->inliers >= options.min_inliers) RefineWeighted(a, b, pairs, p_a, p_b, options, v);
}

}  // namespace

Verification VerifyPair(const KeyframeFeatures& a, const KeyframeFeatures& b,
                        const VerifyOptions& options) {
  Verification v;
  const std::vector<Match> matches = RatioMatches(a, b, options);
  v.matches = static_cast<int>(matches.size());
  const std::vector<int> pnp = PnpInliers(a, b, matches, options, &v.T_a_b);
  v.pnp_inliers = static_cast<int>(pnp.size());
  if (v.pnp_inliers < options.min_inliers) {
    v.reason = absl::StrCat("PnP inliers ", v.pnp_inliers, " < ", options.min_inliers, " (",
                            v.matches, " matches)");
    return v;
  }
  v.T_a_b_pnp = v.T_a_b;
  Check3d(a, b, matches, pnp, options, &v);
  if (v.inliers < options.min_inliers) {
    v.reason = absl::StrCat("3D inliers ", v.inliers, " < ", options.min_inliers);
  } else if (v.rms_m > options.max_rms_m) {
    v.reason = absl::StrCat("3D RMS ", v.rms_m, " m > ", options.max_rms_m, " m");
  } else if (v.inlier_area < options.min_inlier_area) {
    v.reason =
        absl::StrCat("inliers cover ", v.inlier_area, " of the image < ", options.min_inlier_area);
  } else {
    v.accepted = true;
  }
  return v;
}

}  // namespace loci::place

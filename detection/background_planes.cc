#include "detection/background_planes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

namespace loci::detection {

bool InverseDepthPlane::Fit3(const cv::Point3d& p, const cv::Point3d& q, const cv::Point3d& r) {
  const cv::Matx33d A(p.x, p.y, 1, q.x, q.y, 1, r.x, r.y, 1);
  const cv::Vec3d w(1.0 / p.z, 1.0 / q.z, 1.0 / r.z);
  cv::Vec3d x;
  if (std::abs(cv::determinant(A)) < 1e-6 || !cv::solve(A, w, x)) return false;
  a = x[0];
  b = x[1];
  c = x[2];
  return true;
}

bool InverseDepthPlane::Refit(const std::vector<cv::Point3d>& points) {
  if (points.size() < 3) return false;
  // Minimise sum (z^2 (a u + b v + c - 1/z))^2: a depth residual dz ~ z^2 d(1/z).
  cv::Matx33d AtA = cv::Matx33d::zeros();
  cv::Vec3d Atb(0, 0, 0);
  for (const cv::Point3d& p : points) {
    const double s = p.z * p.z, s2 = s * s;
    const cv::Vec3d row(p.x, p.y, 1.0);
    AtA += s2 * row * row.t();
    Atb += s2 * (1.0 / p.z) * row;
  }
  cv::Vec3d x;
  if (!cv::solve(AtA, Atb, x, cv::DECOMP_CHOLESKY)) return false;
  a = x[0];
  b = x[1];
  c = x[2];
  return true;
}

double InverseDepthPlane::DepthAt(double u, double v) const {
  const double w = a * u + b * v + c;
  return w > 0 ? 1.0 / w : -1.0;
}

double PlaneToleranceM(double z_m, const MaskOptions& o) {
  return std::max<double>(o.plane_tolerance_m, o.plane_tolerance_sigma * 0.0015 * z_m * z_m);
}

double ValidDepthM(const cv::Mat& depth, int u, int v, const MaskOptions& o) {
  const double z =
      depth.depth() == CV_16U ? depth.at<uint16_t>(v, u) / o.depth_scale : depth.at<float>(v, u);
  return z >= o.min_depth_m && z <= o.max_depth_m ? z : 0.0;
}

namespace {

bool OnPlane(const InverseDepthPlane& plane, double u, double v, double z, const MaskOptions& o) {
  const double zp = plane.DepthAt(u, v);
  return zp > 0 && std::abs(z - zp) < PlaneToleranceM(z, o);
}

// Fraction of the valid pixels in a ring just outside roi (a gap of a few pixels first, for a
// box that is a little loose) that lie on the plane (plane in roi pixel coordinates).
double FractionOutsideOnPlane(const cv::Mat& depth, const cv::Rect& roi,
                              const InverseDepthPlane& plane, const MaskOptions& o) {
  const int size = std::max(roi.width, roi.height);
  const int near_px = std::max(3, size / 20), far_px = std::max(8, size / 6);
  const cv::Rect image(0, 0, depth.cols, depth.rows);
  const cv::Rect outer =
      cv::Rect(roi.x - far_px, roi.y - far_px, roi.width + 2 * far_px, roi.height + 2 * far_px) &
      image;
  const cv::Rect inner(roi.x - near_px, roi.y - near_px, roi.width + 2 * near_px,
                       roi.height + 2 * near_px);
  const int step = std::max(1, size / 100);
  size_t valid = 0, on = 0;
  for (int v = outer.y; v < outer.br().y; v += step) {
    for (int u = outer.x; u < outer.br().x; u += step) {
      if (inner.contains(cv::Point(u, v))) continue;
      const double z = ValidDepthM(depth, u, v, o);
      if (z <= 0.0) continue;
      ++valid;
      on += OnPlane(plane, u - roi.x, v - roi.y, z, o);
    }
  }
  return valid >= 10 ? static_cast<double>(on) / valid : 0.0;
}

// Fraction of the valid pixels in the central 40 % x 40 % of the box that lie on the plane: a
// plane holding the box centre is the object's own face (or an object too thin to tell from
// its support), not background.
double FractionCentreOnPlane(const cv::Mat& depth_m, const InverseDepthPlane& plane,
                             const MaskOptions& o) {
  const int w = depth_m.cols, h = depth_m.rows;
  const cv::Rect centre(w * 3 / 10, h * 3 / 10, std::max(1, w * 4 / 10), std::max(1, h * 4 / 10));
  size_t valid = 0, on = 0;
  for (int v = centre.y; v < centre.br().y; ++v) {
    const float* d = depth_m.ptr<float>(v);
    for (int u = centre.x; u < centre.br().x; ++u) {
      if (!(d[u] > 0.f)) continue;
      ++valid;
      on += OnPlane(plane, u, v, d[u], o);
    }
  }
  return valid > 0 ? static_cast<double>(on) / valid : 0.0;
}

// Up to max_background_planes planes, by sequential RANSAC (each refitted by least squares on
// its inliers) over at most ~4000 sampled pixels of the box.
std::vector<InverseDepthPlane> FindPlanes(const cv::Mat& depth_m, int valid, const MaskOptions& o) {
  const int stride =
      std::max(1, static_cast<int>(std::floor(std::sqrt(static_cast<double>(valid) / 4000.0))));
  std::vector<cv::Point3d> remaining;
  for (int v = 0; v < depth_m.rows; v += stride) {
    const float* d = depth_m.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; u += stride) {
      if (d[u] > 0.f) remaining.emplace_back(u, v, d[u]);
    }
  }
  const size_t num_samples = remaining.size();
  std::mt19937 rng(12345);  // deterministic: the same frame gives the same mask
  std::vector<InverseDepthPlane> planes;
  while (static_cast<int>(planes.size()) < o.max_background_planes && remaining.size() >= 30) {
    std::uniform_int_distribution<size_t> pick(0, remaining.size() - 1);
    InverseDepthPlane best;
    size_t best_inliers = 0;
    for (int it = 0; it < 100; ++it) {
      InverseDepthPlane p;
      if (!p.Fit3(remaining[pick(rng)], remaining[pick(rng)], remaining[pick(rng)])) continue;
      size_t n = 0;
      for (const auto& q : remaining) n += OnPlane(p, q.x, q.y, q.z, o);
      if (n > best_inliers) {
        best_inliers = n;
        best = p;
      }
    }
    if (best_inliers < o.min_plane_support * num_samples) break;
    std::vector<cv::Point3d> inliers, outliers;
    for (int refit = 0; refit < 2; ++refit) {
      inliers.clear();
      outliers.clear();
      for (const auto& q : remaining) {
        (OnPlane(best, q.x, q.y, q.z, o) ? inliers : outliers).push_back(q);
      }
      InverseDepthPlane refined = best;
      if (!refined.Refit(inliers)) break;
      best = refined;
    }
    planes.push_back(best);
    remaining.swap(outliers);
  }
  return planes;
}

// Per pixel of the box: index of the first plane it lies on, -1 for none, -2 for no depth.
cv::Mat LabelPlanes(const cv::Mat& depth_m, const std::vector<InverseDepthPlane>& planes,
                    const MaskOptions& o) {
  cv::Mat labels(depth_m.size(), CV_32S, cv::Scalar(-2));
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* d = depth_m.ptr<float>(v);
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      if (!(d[u] > 0.f)) continue;
      l[u] = -1;
      for (size_t k = 0; k < planes.size(); ++k) {
        if (OnPlane(planes[k], u, v, d[u], o)) {
          l[u] = static_cast<int>(k);
          break;
        }
      }
    }
  }
  return labels;
}

// n with n . X = 1 for the camera-frame points X of the plane 1/z = a u' + b v' + c' in roi
// pixels (u = u' + roi.x): n = (a fx, b fy, a cx + b cy + c'').
Eigen::Vector3d CameraFrameNormal(const InverseDepthPlane& p, const cv::Rect& roi,
                                  const PinholeCamera& cam) {
  const double c_image = p.c - p.a * roi.x - p.b * roi.y;
  return {p.a * cam.fx, p.b * cam.fy, p.a * cam.cx + p.b * cam.cy + c_image};
}

struct Around {
  size_t below = 0, above = 0;
};

// Points more than margin_m below / above the plane n . X = 1, measured from the plane itself
// along its normal turned to `up`: a level table seen with a gravity a few degrees off still
// has all of its own points within the margin, however wide the box.
Around CountAroundPlane(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& n,
                        const Eigen::Vector3d& up, double margin_m) {
  Around out;
  const double norm = n.norm();
  if (!(norm > 0)) return out;
  const Eigen::Vector3d n_up = (n.dot(up) >= 0 ? 1.0 : -1.0) * n / norm;
  const double offset_up = (n.dot(up) >= 0 ? 1.0 : -1.0) / norm;  // n_up . X on the plane
  for (const Eigen::Vector3d& X : points) {
    const double h = n_up.dot(X) - offset_up;
    out.below += h < -margin_m;
    out.above += h > margin_m;
  }
  return out;
}

// Horizontal support planes (MaskOptions::horizontal_max_deg), and the height of the top of
// support furniture. Needs intrinsics and gravity.
struct Supports {
  std::vector<bool> support;         // per plane
  std::vector<bool> bare;            // per plane: level, goes on outside the box, nothing on it
  std::optional<double> top_height;  // support furniture: height of its top along up, m
};

Supports FindSupports(const cv::Rect& roi, const cv::Mat& depth_m, const cv::Mat& labels,
                      const std::vector<InverseDepthPlane>& planes,
                      const std::vector<bool>& continues, const MaskOptions& o,
                      const MaskContext& context) {
  Supports out;
  out.support.assign(planes.size(), false);
  out.bare.assign(planes.size(), false);
  std::vector<bool>& support = out.support;
  if (!context.camera || !context.gravity_cam || !context.gravity_cam->allFinite() ||
      context.gravity_cam->norm() < 0.5) {
    return out;
  }
  const PinholeCamera& cam = *context.camera;
  const Eigen::Vector3d up = -context.gravity_cam->normalized();
  const double cos_max = std::cos(o.horizontal_max_deg * M_PI / 180.0);
  // Every sampled valid pixel (camera frame), its height above the camera along `up`, and
  // each plane's mean height.
  const int stride = std::max(1, std::max(depth_m.cols, depth_m.rows) / 160);
  std::vector<Eigen::Vector3d> points;
  std::vector<double> heights;
  std::vector<double> plane_height_sum(planes.size(), 0.0);
  std::vector<int> plane_count(planes.size(), 0);
  for (int v = 0; v < depth_m.rows; v += stride) {
    const float* d = depth_m.ptr<float>(v);
    const int* l = labels.ptr<int>(v);
    for (int u = 0; u < depth_m.cols; u += stride) {
      if (!(d[u] > 0.f)) continue;
      points.push_back(cam.BackProject(u + roi.x, v + roi.y, d[u]));
      heights.push_back(up.dot(points.back()));
      if (l[u] >= 0) {
        plane_height_sum[l[u]] += heights.back();
        plane_count[l[u]]++;
      }
    }
  }
  if (heights.empty()) return out;
  std::vector<bool> horizontal(planes.size(), false);
  std::vector<double> plane_height(planes.size(), 0.0);
  std::vector<Eigen::Vector3d> normals(planes.size());
  for (size_t k = 0; k < planes.size(); ++k) {
    normals[k] = CameraFrameNormal(planes[k], roi, cam);
    horizontal[k] = normals[k].norm() > 0 &&
                    std::abs(normals[k].normalized().dot(up)) >= cos_max && plane_count[k] >= 10;
    if (plane_count[k] > 0) plane_height[k] = plane_height_sum[k] / plane_count[k];
  }
  const bool support_class = o.IsSupportClass(context.class_name);
  const double margin_m = 0.03;
  for (size_t k = 0; k < planes.size(); ++k) {
    if (!horizontal[k]) continue;
    if (support_class && plane_count[k] >= 0.1 * heights.size() &&
        (!out.top_height || plane_height[k] > *out.top_height)) {
      out.top_height = plane_height[k];
    }
    const Around around = CountAroundPlane(points, normals[k], up, margin_m);
    const size_t below = around.below, above = around.above;
    // Nothing of the box rises above a level surface that goes on outside it.
    out.bare[k] = !support_class && !o.IsThinClass(context.class_name) && continues[k] &&
                  above < 0.05 * heights.size();
    // Something of the box hangs below it: not the support, unless the plane continues outside
    // the box under an object that is not furniture (what lies below is then past the edge of
    // a desk: the floor, the desk's front).
    const bool past_edge = continues[k] && !support_class;
    if (below > 0.02 * heights.size() + 2 && !past_edge) continue;
    if (support_class) {
      // Keep the furniture's own top: remove only a plane with such a top well above it.
      for (size_t j = 0; j < planes.size(); ++j) {
        if (j != k && horizontal[j] && plane_height[j] > plane_height[k] + o.support_min_rise_m &&
            plane_count[j] >= 0.1 * heights.size()) {
          support[k] = true;
        }
      }
    } else {
      support[k] = above >= 0.05 * heights.size();  // the object rises above it
    }
  }
  return out;
}

// Whether the box shows only a bare support (BackgroundPlanes::bare_support): a level plane that
// goes on outside the box with nothing on it holds the box centre, where the plane's tolerance
// is fine enough for an object on it to stand out (MaskOptions::bare_support_max_tolerance_m).
bool BareSupport(const cv::Mat& depth_m, const std::vector<InverseDepthPlane>& planes,
                 const std::vector<bool>& bare, const std::vector<double>& centre,
                 const MaskOptions& o) {
  for (size_t k = 0; k < planes.size(); ++k) {
    if (!bare[k] || centre[k] < o.max_centre_fraction) continue;
    const double z_m = planes[k].DepthAt(0.5 * depth_m.cols, 0.5 * depth_m.rows);
    if (z_m > 0 && PlaneToleranceM(z_m, o) <= o.bare_support_max_tolerance_m) return true;
  }
  return false;
}

}  // namespace

BackgroundPlanes BackgroundPlaneMask(const cv::Mat& depth, const cv::Rect& roi,
                                     const cv::Mat& depth_m, const MaskOptions& o,
                                     const MaskContext& context) {
  BackgroundPlanes out;
  out.mask = cv::Mat::zeros(depth_m.size(), CV_8UC1);
  cv::Mat& background = out.mask;
  const int valid = cv::countNonZero(depth_m > 0.f);
  if (valid < std::max(o.min_pixels, 30)) return out;
  const std::vector<InverseDepthPlane> planes = FindPlanes(depth_m, valid, o);
  if (planes.empty()) return out;
  const cv::Mat labels = LabelPlanes(depth_m, planes, o);
  std::vector<double> outside(planes.size()), centre(planes.size());
  std::vector<bool> continues(planes.size());
  for (size_t k = 0; k < planes.size(); ++k) {
    outside[k] = FractionOutsideOnPlane(depth, roi, planes[k], o);
    centre[k] = FractionCentreOnPlane(depth_m, planes[k], o);
    continues[k] = outside[k] >= o.min_outside_fraction;
  }
  const Supports supports = FindSupports(roi, depth_m, labels, planes, continues, o, context);
  out.bare_support = BareSupport(depth_m, planes, supports.bare, centre, o);
  if (out.bare_support) return out;  // no mask at all: the background is not needed
  const std::vector<bool>& support = supports.support;
  const bool support_class = o.IsSupportClass(context.class_name);
  std::vector<bool> is_background(planes.size(), false);
  for (size_t k = 0; k < planes.size(); ++k) {
    // A plane holding the box centre is the object's own face, except a support: under
    // furniture (the floor seen between table legs), or under anything when the support also
    // continues outside the box (a loose box over a keyboard and the desk around it; a face
    // of the object itself would end at its edges, and a flat object thinner than the plane
    // tolerance is left whole by min_object_fraction).
    const bool holds_centre = centre[k] >= o.max_centre_fraction;
    is_background[k] = (support[k] && (support_class || continues[k] || !holds_centre)) ||
                       (continues[k] && !holds_centre);
  }
  // Furniture with a flat top: what stands on the top is other objects.
  std::optional<double> max_height;
  if (supports.top_height && o.IsFlatTopClass(context.class_name)) {
    max_height = *supports.top_height + o.flat_top_margin_m;
  }
  // (top_height is only set with camera and a valid gravity.)
  const Eigen::Vector3d up =
      max_height ? Eigen::Vector3d(-context.gravity_cam->normalized()) : Eigen::Vector3d::Zero();
  int removed = 0;
  for (int v = 0; v < depth_m.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const float* d = depth_m.ptr<float>(v);
    uint8_t* b = background.ptr<uint8_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      if ((l[u] >= 0 && is_background[l[u]]) ||
          (max_height && d[u] > 0.f &&
           up.dot(context.camera->BackProject(u + roi.x, v + roi.y, d[u])) > *max_height)) {
        b[u] = 255;
        ++removed;
      }
    }
  }
  if (valid - removed < std::max<double>(o.min_pixels, o.min_object_fraction * valid)) {
    background.setTo(0);
  }
  return out;
}

}  // namespace loci::detection

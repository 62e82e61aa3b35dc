#include "common/footprint.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loci {
namespace {

// z of (a - o) x (b - o): > 0 when o, a, b turn counter-clockwise.
double Cross(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// Where the segment p-q crosses the line through a and b (p and q on opposite sides).
Eigen::Vector2d Crossing(const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                         const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double dp = Cross(a, b, p), dq = Cross(a, b, q);
  return p + (q - p) * (dp / (dp - dq));
}

// Distance from p to the segment a-b.
double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

// Smallest distance from a vertex of `from` to an edge of `to`.
double VertexToEdges(const Footprint& from, const Footprint& to) {
  double d = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector2d& p : from) {
    for (size_t i = 0; i < to.size(); ++i) {
      d = std::min(d, SegmentDistance(p, to[i], to[(i + 1) % to.size()]));
    }
  }
  return d;
}

}  // namespace

Footprint ConvexHull(std::vector<Eigen::Vector2d> points) {
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  Footprint hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {  // lower chain
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);  // the last point is the first
  return hull;
}

double PolygonArea(const Footprint& polygon) {
  if (polygon.size() < 3) return 0.0;
  double twice = 0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d& p = polygon[i];
    const Eigen::Vector2d& q = polygon[(i + 1) % polygon.size()];
    twice += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * std::abs(twice);
}

double ConvexOverlapArea(const Footprint& a, const Footprint& b) {
  if (a.size() < 3 || b.size() < 3) return 0.0;
  // The query clips thousands of pairs per question: buffers that keep their capacity.
  thread_local Footprint clipped, in;
  clipped.assign(a.begin(), a.end());
  for (size_t i = 0; i < b.size() && !clipped.empty(); ++i) {
    const Eigen::Vector2d& e0 = b[i];
    const Eigen::Vector2d& e1 = b[(i + 1) % b.size()];
    in.swap(clipped);
    clipped.clear();
    for (size_t j = 0; j < in.size(); ++j) {
      const Eigen::Vector2d& p = in[j];
      const Eigen::Vector2d& q = in[(j + 1) % in.size()];
      const bool p_in = Cross(e0, e1, p) >= 0, q_in = Cross(e0, e1, q) >= 0;
      if (p_in != q_in) clipped.push_back(Crossing(p, q, e0, e1));
      if (q_in) clipped.push_back(q);
    }
  }
  return PolygonArea(clipped);
}

double ConvexDistanceM(const Footprint& a, const Footprint& b) {
  if (a.empty() || b.empty()) return std::numeric_limits<double>::infinity();
  if (ConvexOverlapArea(a, b) > 0) return 0.0;
  // Two convex polygons apart: their closest points include a vertex of one.
  return std::min(VertexToEdges(a, b), VertexToEdges(b, a));
}

Footprint OrientedFootprint(const MapObject& o, const Eigen::Matrix3d& R_g_map) {
  const Eigen::Vector3d h = o.obb_half_extent_m.cwiseAbs();
  if (!(h.maxCoeff() > 0) || !h.allFinite() || !o.R_map_box.allFinite()) return {};
  std::vector<Eigen::Vector2d> corners;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d q(corner & 1 ? h.x() : -h.x(), corner & 2 ? h.y() : -h.y(),
                            corner & 4 ? h.z() : -h.z());
    corners.push_back((R_g_map * (o.obb_center_m + o.R_map_box * q)).head<2>());
  }
  return ConvexHull(std::move(corners));
}

}  // namespace loci

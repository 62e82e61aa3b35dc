#include "synth/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "synth/depth_noise.h"

namespace loci::synth {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-6;

// A primitive placed for this frame: rays go into its frame, normals out to the world.
struct Posed {
  const Primitive* prim = nullptr;
  int64_t object_id = 0;
  Mat3d R_prim_cam;
  Vec3d t_prim_cam;  // camera centre in the primitive's frame
  Mat3d R_world_prim;
  cv::Rect rect;  // pixels whose rays may hit it
};

// Ray o + t d (t = z-depth since d_cam.z = 1); returns the nearest t > 0 or +inf.
double HitBox(const Vec3d& o, const Vec3d& d, const Vec3d& h) {
  double t0 = -kInf, t1 = kInf;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (std::abs(o[i]) > h[i]) return kInf;
      continue;
    }
    double a = (-h[i] - o[i]) / d[i], b = (h[i] - o[i]) / d[i];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return kInf;
  }
  return t0 > kEps ? t0 : kInf;
}

double HitCylinder(const Vec3d& o, const Vec3d& d, const Vec3d& h) {
  const double r2 = h.x() * h.x();
  double best = kInf;
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 1e-12) {
    const double b = 2 * (o.x() * d.x() + o.y() * d.y());
    const double c = o.x() * o.x() + o.y() * o.y() - r2;
    const double disc = b * b - 4 * a * c;
    if (disc >= 0) {
      const double t = (-b - std::sqrt(disc)) / (2 * a);
      if (t > kEps && std::abs(o.z() + t * d.z()) <= h.z()) best = t;
    }
  }
  if (std::abs(d.z()) > 1e-12) {
    for (double s : {-1.0, 1.0}) {
      const double t = (s * h.z() - o.z()) / d.z();
      if (t > kEps && t < best) {
        const double x = o.x() + t * d.x(), y = o.y() + t * d.y();
        if (x * x + y * y <= r2) best = t;
      }
    }
  }
  return best;
}

double HitSphere(const Vec3d& o, const Vec3d& d, double r) {
  const double a = d.squaredNorm(), b = 2 * o.dot(d), c = o.squaredNorm() - r * r;
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return kInf;
  const double t = (-b - std::sqrt(disc)) / (2 * a);
  return t > kEps ? t : kInf;
}

double Hit(const Posed& p, const Vec3d& d_loc) {
  switch (p.prim->shape) {
    case Shape::kBox:
      return HitBox(p.t_prim_cam, d_loc, p.prim->half_m);
    case Shape::kCylinder:
      return HitCylinder(p.t_prim_cam, d_loc, p.prim->half_m);
    case Shape::kSphere:
      return HitSphere(p.t_prim_cam, d_loc, p.prim->half_m.x());
  }
  return kInf;
}

// Outward normal and texture coordinates (m) of a point on a primitive, in its frame.
void SurfaceAt(const Primitive& prim, const Vec3d& p, Vec3d* n, double* u, double* v) {
  const Vec3d& h = prim.half_m;
  switch (prim.shape) {
    case Shape::kBox: {
      int k = 0;
      for (int i = 1; i < 3; ++i) {
        if (std::abs(p[i]) / h[i] > std::abs(p[k]) / h[k]) k = i;
      }
      const double s = p[k] >= 0 ? 1.0 : -1.0;
      *n = Vec3d::Zero();
      (*n)[k] = s;
      const int i = (k + 1) % 3, j = (k + 2) % 3;
      *u = p[i] + h[i] + 0.37 * k + (s > 0 ? 0.19 : 0.0);
      *v = h[j] - p[j] + 0.53 * k + (s > 0 ? 0.11 : 0.0);
      break;
    }
    case Shape::kCylinder: {
      const double rho = std::hypot(p.x(), p.y());
      if (std::abs(std::abs(p.z()) - h.z()) < std::abs(rho - h.x())) {
        *n = Vec3d(0, 0, p.z() >= 0 ? 1 : -1);
        *u = p.x() + h.x();
        *v = p.y() + h.x() + 0.31;
      } else {
        *n = Vec3d(p.x(), p.y(), 0) / std::max(rho, 1e-9);
        *u = (std::atan2(p.y(), p.x()) + M_PI) * h.x();
        *v = h.z() - p.z();
      }
      break;
    }
    case Shape::kSphere: {
      const double r = h.x();
      *n = p / r;
      *u = (std::atan2(p.y(), p.x()) + M_PI) * r;
      *v = std::acos(std::clamp(p.z() / r, -1.0, 1.0)) * r;
      break;
    }
  }
  *u += prim.uv_offset_m.x();
  *v += prim.uv_offset_m.y();
}

// Exit of a ray from inside the room box: depth, face (0 floor, 1 ceiling, 2..5 walls x-, x+,
// y-, y+) and the face's texture coordinates.
double HitRoom(const Scene& s, const Vec3d& o, const Vec3d& d, int* face) {
  double best = kInf;
  *face = -1;
  static const int kFaceOf[3][2] = {{2, 3}, {4, 5}, {0, 1}};  // [axis][positive direction]
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) continue;
    const bool pos = d[i] > 0;
    const double t = ((pos ? s.room_max_m[i] : s.room_min_m[i]) - o[i]) / d[i];
    if (t > kEps && t < best) {
      best = t;
      *face = kFaceOf[i][pos];
    }
  }
  return best;
}

void RoomSurface(const Scene& s, int face, const Vec3d& p, Vec3d* n, double* u, double* v) {
  const Vec3d& lo = s.room_min_m;
  const Vec3d& hi = s.room_max_m;
  // u runs left to right as seen from inside the room, v downwards on walls.
  switch (face) {
    case 0:
      *n = Vec3d(0, 0, 1), *u = p.x() - lo.x(), *v = hi.y() - p.y();
      break;
    case 1:
      *n = Vec3d(0, 0, -1), *u = p.x() - lo.x(), *v = p.y() - lo.y();
      break;
    case 2:
      *n = Vec3d(1, 0, 0), *u = p.y() - lo.y(), *v = hi.z() - p.z();
      break;
    case 3:
      *n = Vec3d(-1, 0, 0), *u = hi.y() - p.y(), *v = hi.z() - p.z();
      break;
    case 4:
      *n = Vec3d(0, 1, 0), *u = hi.x() - p.x(), *v = hi.z() - p.z();
      break;
    default:
      *n = Vec3d(0, -1, 0), *u = p.x() - lo.x(), *v = hi.z() - p.z();
      break;
  }
}

std::vector<Posed> PoseParts(const Scene& scene, const SE3d& T_world_cam, const PinholeCamera& cam,
                             int64_t t_ns) {
  std::vector<Posed> out;
  const SE3d T_cam_world = T_world_cam.inverse();
  const cv::Rect image(0, 0, cam.width_px, cam.height_px);
  for (const SceneObject& obj : scene.objects) {
    const SE3d T_world_obj = ObjectPoseAt(scene, obj, t_ns);
    for (const Primitive& prim : obj.parts) {
      const SE3d T_world_prim = T_world_obj * prim.T_obj_prim;
      const SE3d T_cam_prim = T_cam_world * T_world_prim;
      Posed p;
      p.prim = &prim;
      p.object_id = obj.id;
      p.R_prim_cam = T_cam_prim.linear().transpose();
      p.t_prim_cam = -p.R_prim_cam * T_cam_prim.translation();
      p.R_world_prim = T_world_prim.linear();
      // Screen rectangle of the primitive's bounding box; the whole image if it straddles the
      // camera plane, nothing if it is entirely behind.
      double u0 = kInf, v0 = kInf, u1 = -kInf, v1 = -kInf;
      int behind = 0;
      bool straddles = false;
      const Vec3d ext = prim.shape == Shape::kBox
                            ? prim.half_m
                            : Vec3d(prim.half_m.x(), prim.half_m.x(), prim.half_m.z());
      for (int c = 0; c < 8; ++c) {
        const Vec3d corner((c & 1 ? 1 : -1) * ext.x(), (c & 2 ? 1 : -1) * ext.y(),
                           (c & 4 ? 1 : -1) * ext.z());
        const Vec3d pc = T_cam_prim * corner;
        if (pc.z() <= 1e-3) {
          ++behind;
          straddles = true;
          continue;
        }
        const double u = cam.fx * pc.x() / pc.z() + cam.cx, v = cam.fy * pc.y() / pc.z() + cam.cy;
        u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
      }
      if (behind == 8) continue;
      if (straddles) {
        p.rect = image;
      } else {
        const int x0 = static_cast<int>(std::floor(std::max(u0, -2.0))) - 1;
        const int y0 = static_cast<int>(std::floor(std::max(v0, -2.0))) - 1;
        const int x1 = static_cast<int>(std::ceil(std::min(u1, cam.width_px + 2.0))) + 1;
        const int y1 = static_cast<int>(std::ceil(std::min(v1, cam.height_px + 2.0))) + 1;
        p.rect = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) & image;
      }
      if (p.rect.area() > 0) out.push_back(p);
    }
  }
  return out;
}

void RenderRows(const Scene& scene, const SE3d& T_world_cam, const PinholeCamera& cam,
                const std::vector<Posed>& posed, int first_row, int row_step, RenderedFrame* f) {
  const int w = cam.width_px;
  std::vector<double> zbuf(w);
  std::vector<int> who(w);  // index into posed, -1 = room
  std::vector<int> face(w);
  const Mat3d& R_wc = T_world_cam.linear();
  const Vec3d& o_w = T_world_cam.translation();
  for (int y = first_row; y < cam.height_px; y += row_step) {
    const double b = (y - cam.cy) / cam.fy;
    for (int x = 0; x < w; ++x) {
      const Vec3d d_cam((x - cam.cx) / cam.fx, b, 1.0);
      zbuf[x] = HitRoom(scene, o_w, R_wc * d_cam, &face[x]);
      who[x] = -1;
    }
    for (size_t k = 0; k < posed.size(); ++k) {
      const Posed& p = posed[k];
      if (y < p.rect.y || y >= p.rect.y + p.rect.height) continue;
      const Vec3d d_row = p.R_prim_cam.col(1) * b + p.R_prim_cam.col(2);
      for (int x = p.rect.x; x < p.rect.x + p.rect.width; ++x) {
        const Vec3d d_loc = p.R_prim_cam.col(0) * ((x - cam.cx) / cam.fx) + d_row;
        const double t = Hit(p, d_loc);
        if (t < zbuf[x]) {
          zbuf[x] = t;
          who[x] = static_cast<int>(k);
        }
      }
    }
    cv::Vec3b* bgr = f->bgr.ptr<cv::Vec3b>(y);
    float* depth = f->depth_m.ptr<float>(y);
    int32_t* inst = f->instance_id.ptr<int32_t>(y);
    for (int x = 0; x < w; ++x) {
      const double t = zbuf[x];
      if (!std::isfinite(t)) continue;  // only if the camera left the room
      const Vec3d d_cam((x - cam.cx) / cam.fx, b, 1.0);
      const Vec3d d_w = R_wc * d_cam;
      const Vec3d p_w = o_w + t * d_w;
      Vec3d n_w;
      double u = 0, v = 0;
      const Texture* tex;
      if (who[x] < 0) {
        RoomSurface(scene, face[x], p_w, &n_w, &u, &v);
        tex = &scene.textures[scene.room_texture[face[x]]];
        inst[x] = 0;
      } else {
        const Posed& p = posed[who[x]];
        Vec3d n_loc = Vec3d::Zero();
        SurfaceAt(*p.prim, p.t_prim_cam + t * (p.R_prim_cam * d_cam), &n_loc, &u, &v);
        n_w = p.R_world_prim * n_loc;
        tex = &scene.textures[p.prim->texture];
        inst[x] = static_cast<int32_t>(p.object_id);
      }
      const Vec3d to_light = (scene.light_world_m - p_w).normalized();
      const double diffuse = std::max(0.0, n_w.dot(to_light));
      const double head = std::max(0.0, -n_w.dot(d_w.normalized()));
      const float shade = static_cast<float>(0.25 + 0.6 * diffuse + 0.3 * head);
      const cv::Vec3f albedo = SampleTexture(*tex, u, v);
      for (int c = 0; c < 3; ++c) {
        bgr[x][c] = cv::saturate_cast<uint8_t>(albedo[c] * shade);
      }
      depth[x] = static_cast<float>(t);
    }
  }
}

}  // namespace

RenderedFrame Render(const Scene& scene, const SE3d& T_world_cam, const PinholeCamera& camera,
                     int64_t t_ns, int num_threads) {
  RenderedFrame f;
  f.t_ns = t_ns;
  f.T_world_cam = T_world_cam;
  if (!camera.Validate().ok()) return f;  // empty images
  const cv::Size size(camera.width_px, camera.height_px);
  f.bgr = cv::Mat(size, CV_8UC3, cv::Scalar(0, 0, 0));
  f.depth_m = cv::Mat(size, CV_32FC1, cv::Scalar(0));
  f.instance_id = cv::Mat(size, CV_32SC1, cv::Scalar(0));
  const std::vector<Posed> posed = PoseParts(scene, T_world_cam, camera, t_ns);

  if (num_threads <= 0) num_threads = scene.options.num_threads;
  if (num_threads <= 0) num_threads = static_cast<int>(std::thread::hardware_concurrency());
  num_threads = std::clamp(num_threads, 1, std::max(1, camera.height_px));
  if (num_threads == 1) {
    RenderRows(scene, T_world_cam, camera, posed, 0, 1, &f);
  } else {
    // Interleaved rows balance the load: the table region sits in the middle of the image.
    std::vector<std::thread> workers;
    for (int k = 0; k < num_threads; ++k) {
      workers.emplace_back(RenderRows, std::cref(scene), std::cref(T_world_cam), std::cref(camera),
                           std::cref(posed), k, num_threads, &f);
    }
    for (std::thread& t : workers) t.join();
  }

  const SceneOptions& o = scene.options;
  const cv::Mat depth =
      o.depth_noise ? ApplyKinectNoise(f.depth_m, Rng::Mix(o.seed, static_cast<uint64_t>(t_ns)))
                    : f.depth_m;
  f.depth_u16 = cv::Mat(size, CV_16UC1, cv::Scalar(0));
  for (int y = 0; y < size.height; ++y) {
    const float* z = depth.ptr<float>(y);
    uint16_t* d = f.depth_u16.ptr<uint16_t>(y);
    for (int x = 0; x < size.width; ++x) {
      if (z[x] >= o.min_depth_m && z[x] <= o.max_depth_m && z[x] > 0) {
        d[x] = static_cast<uint16_t>(std::min(65535.0, std::round(z[x] * o.depth_scale)));
      }
    }
  }
  return f;
}

}  // namespace loci::synth

#include "synth/object_catalog.h"

#include <algorithm>
#include <cmath>

namespace loci::synth {
namespace {

SE3d At(const Vec3d& t_m, const Mat3d& R = Mat3d::Identity()) {
  SE3d T = SE3d::Identity();
  T.linear() = R;
  T.translation() = t_m;
  return T;
}

// Box of full size `size_m` centred at `c_m`.
Primitive Box(const Vec3d& c_m, const Vec3d& size_m, const Mat3d& R = Mat3d::Identity()) {
  return {Shape::kBox, At(c_m, R), size_m / 2, 0, {0, 0}};
}
// Cylinder of radius r_m and height h_m, centred at c_m, axis z (rotated by R).
Primitive Cyl(const Vec3d& c_m, double r_m, double h_m, const Mat3d& R = Mat3d::Identity()) {
  return {Shape::kCylinder, At(c_m, R), Vec3d(r_m, r_m, h_m / 2), 0, {0, 0}};
}
Primitive Ball(const Vec3d& c_m, double r_m) {
  return {Shape::kSphere, At(c_m), Vec3d::Constant(r_m), 0, {0, 0}};
}
Mat3d RotX(double rad) { return Eigen::AngleAxisd(rad, Vec3d::UnitX()).toRotationMatrix(); }

std::vector<Primitive> Chair(double k) {
  const double seat = 0.45 * k, seat_h = 0.45 * k, leg = 0.035, back_h = 0.45 * k;
  std::vector<Primitive> p;
  p.push_back(Box({0, 0, seat_h - 0.02}, {seat, seat, 0.04}));
  for (int sx : {-1, 1}) {
    for (int sy : {-1, 1}) {
      const Vec3d c(sx * (seat - leg) / 2, sy * (seat - leg) / 2, (seat_h - 0.04) / 2);
      p.push_back(Box(c, {leg, leg, seat_h - 0.04}));
    }
  }
  p.push_back(Box({0, (seat - 0.03) / 2, seat_h + back_h / 2}, {seat, 0.03, back_h}));
  return p;
}

std::vector<Primitive> TeddyBear(double k) {
  const double r = 0.10 * k;
  return {Ball({0, 0, r}, r),
          Ball({0, 0, 2 * r + 0.55 * r}, 0.7 * r),
          Ball({-0.5 * r, 0, 2 * r + 1.15 * r}, 0.25 * r),
          Ball({0.5 * r, 0, 2 * r + 1.15 * r}, 0.25 * r),
          Ball({-0.95 * r, -0.2 * r, 1.2 * r}, 0.35 * r),
          Ball({0.95 * r, -0.2 * r, 1.2 * r}, 0.35 * r)};
}

std::vector<Primitive> Laptop(double k) {
  const double w = 0.34 * k, d = 0.24 * k, hb = 0.02, t = 0.008, tilt = 0.3;
  const Mat3d R = RotX(-tilt);  // leans back (+y) by `tilt`
  const Vec3d hinge(0, d / 2, hb);
  return {Box({0, 0, hb / 2}, {w, d, hb}),
          Box(hinge + R * Vec3d(0, -t / 2, 0.95 * d / 2), {w, t, 0.95 * d}, R)};
}

std::vector<Primitive> Tv(double k) {
  const double w = 0.70 * k, h = 0.44 * k, stand = 0.08;
  return {Box({0, 0, 0.01}, {0.26, 0.18, 0.02}),
          Box({0, 0.02, 0.02 + stand / 2}, {0.06, 0.04, stand}),
          Box({0, 0, 0.02 + stand + h / 2}, {w, 0.05, h})};
}

}  // namespace

const std::vector<ClassSpec>& CoreClasses() {
  static const std::vector<ClassSpec> kCore = {{"book", 73, kOnTable | kOnShelf},
                                               {"cup", 41, kOnTable | kOnShelf},
                                               {"keyboard", 66, kOnTable},
                                               {"mouse", 64, kOnTable},
                                               {"bottle", 39, kOnTable | kOnShelf},
                                               {"tv", 62, kOnTable | kOnShelf},
                                               {"laptop", 63, kOnTable},
                                               {"chair", 56, kOnFloor},
                                               {"teddy bear", 77, kOnTable | kOnShelf | kOnFloor}};
  return kCore;
}

const std::vector<ClassSpec>& ExtraClasses() {
  static const std::vector<ClassSpec> kExtra = {{"bowl", 45, kOnTable | kOnShelf},
                                                {"vase", 75, kOnTable | kOnShelf},
                                                {"potted plant", 58, kOnFloor | kOnShelf},
                                                {"cell phone", 67, kOnTable},
                                                {"remote", 65, kOnTable | kOnShelf},
                                                {"clock", 74, kOnTable | kOnShelf},
                                                {"backpack", 24, kOnFloor},
                                                {"suitcase", 28, kOnFloor}};
  return kExtra;
}

int CocoClassId(const std::string& name) {
  if (name == "person") return 0;
  if (name == "dining table") return 60;
  for (const auto* list : {&CoreClasses(), &ExtraClasses()}) {
    for (const ClassSpec& c : *list) {
      if (c.name == name) return c.coco_id;
    }
  }
  return -1;
}

std::vector<Primitive> BuildClassParts(const std::string& name, Rng& rng) {
  const double k = rng.Uniform(0.9, 1.1);  // instance size variation
  std::vector<Primitive> p;
  if (name == "book") {
    const double h = rng.Uniform(0.02, 0.05);
    p = {Box({0, 0, h / 2}, {0.17 * k, 0.24 * k, h})};
  } else if (name == "cup") {
    const double r = 0.04 * k, h = 0.10 * k;
    p = {Cyl({0, 0, h / 2}, r, h), Box({r + 0.008, 0, h / 2}, {0.02, 0.012, 0.06 * k})};
  } else if (name == "keyboard") {
    const double h = 0.03;
    p = {Box({0, 0, h / 2}, {0.44 * k, 0.14 * k, h})};
  } else if (name == "mouse") {
    p = {Box({0, 0, 0.0175}, {0.06 * k, 0.105 * k, 0.035})};
  } else if (name == "bottle") {
    const double r = 0.035 * k, h = 0.21 * k, neck = 0.06 * k;
    p = {Cyl({0, 0, h / 2}, r, h), Cyl({0, 0, h + neck / 2}, 0.014, neck),
         Cyl({0, 0, h + neck + 0.008}, 0.016, 0.016)};
  } else if (name == "tv") {
    p = Tv(k);
  } else if (name == "laptop") {
    p = Laptop(k);
  } else if (name == "chair") {
    p = Chair(k);
  } else if (name == "teddy bear") {
    p = TeddyBear(k);
  } else if (name == "bowl") {
    const double h = 0.06 * k;
    p = {Cyl({0, 0, h / 2}, 0.08 * k, h)};
  } else if (name == "vase") {
    const double h = 0.22 * k;
    p = {Cyl({0, 0, h / 2}, 0.06 * k, h), Cyl({0, 0, h + 0.03}, 0.035 * k, 0.06)};
  } else if (name == "potted plant") {
    const double r = 0.11 * k, h = 0.22 * k;
    p = {Cyl({0, 0, h / 2}, r, h), Ball({0, 0, h + 0.12 * k}, 0.14 * k),
         Ball({0.07 * k, 0.03, h + 0.24 * k}, 0.09 * k),
         Ball({-0.06 * k, -0.03, h + 0.22 * k}, 0.08 * k)};
  } else if (name == "cell phone") {
    p = {Box({0, 0, 0.004}, {0.072 * k, 0.148 * k, 0.008})};
  } else if (name == "remote") {
    p = {Box({0, 0, 0.011}, {0.048 * k, 0.19 * k, 0.022})};
  } else if (name == "clock") {
    const double r = 0.12 * k;
    p = {Cyl({0, 0, r}, r, 0.045, RotX(M_PI / 2))};
  } else if (name == "backpack") {
    p = {Box({0, 0, 0.21 * k}, {0.30 * k, 0.18 * k, 0.42 * k}),
         Box({0, -0.09 * k - 0.03, 0.14 * k}, {0.22 * k, 0.06, 0.2 * k})};
  } else if (name == "suitcase") {
    const double h = 0.60 * k;
    p = {Box({0, 0, h / 2}, {0.42 * k, 0.24 * k, h}), Box({0, 0, h + 0.02}, {0.14, 0.025, 0.04})};
  }
  return p;
}

std::vector<Primitive> BuildTable(const Vec3d& size_m) {
  const double top = 0.04, leg = 0.06, inset = 0.06;
  std::vector<Primitive> p = {Box({0, 0, size_m.z() - top / 2}, {size_m.x(), size_m.y(), top})};
  for (int sx : {-1, 1}) {
    for (int sy : {-1, 1}) {
      p.push_back(Box(
          {sx * (size_m.x() / 2 - inset), sy * (size_m.y() / 2 - inset), (size_m.z() - top) / 2},
          {leg, leg, size_m.z() - top}));
    }
  }
  return p;
}

std::vector<Primitive> BuildShelf(const Vec3d& size_m) {
  // A low cabinet: plinth, body and a top board overhanging by 2 cm, so objects stand on the top.
  const double plinth = 0.06, board = 0.03;
  const Vec3d body(size_m.x() - 0.04, size_m.y() - 0.02, size_m.z() - plinth - board);
  return {Box({0, 0.01, plinth / 2}, {body.x() - 0.06, body.y() - 0.04, plinth}),
          Box({0, 0.01, plinth + body.z() / 2}, body),
          Box({0, 0, size_m.z() - board / 2}, {size_m.x(), size_m.y(), board})};
}

std::vector<Primitive> BuildPerson(double height_m) {
  const double k = height_m / 1.75;
  const double leg_h = 0.85 * k, torso_h = 0.58 * k, head_r = 0.11 * k;
  return {Cyl({-0.1 * k, 0, leg_h / 2}, 0.07 * k, leg_h),
          Cyl({0.1 * k, 0, leg_h / 2}, 0.07 * k, leg_h),
          Box({0, 0, leg_h + torso_h / 2}, {0.40 * k, 0.24 * k, torso_h}),
          Cyl({-0.245 * k, 0, leg_h + torso_h - 0.3 * k}, 0.045 * k, 0.58 * k),
          Cyl({0.245 * k, 0, leg_h + torso_h - 0.3 * k}, 0.045 * k, 0.58 * k),
          Cyl({0, 0, leg_h + torso_h + 0.03 * k}, 0.05 * k, 0.06 * k),
          Ball({0, 0, leg_h + torso_h + 0.06 * k + head_r}, head_r)};
}

void PartsAabb(const std::vector<Primitive>& parts, const SE3d& T_world_obj, Vec3d* min_m,
               Vec3d* max_m) {
  *min_m = Vec3d::Constant(1e18);
  *max_m = Vec3d::Constant(-1e18);
  for (const Primitive& p : parts) {
    const SE3d T = T_world_obj * p.T_obj_prim;
    const Mat3d& R = T.linear();
    Vec3d half = Vec3d::Zero();
    for (int i = 0; i < 3; ++i) {
      switch (p.shape) {
        case Shape::kBox:
          half[i] = R.row(i).cwiseAbs().dot(p.half_m);
          break;
        case Shape::kCylinder: {
          const double a = std::clamp(std::abs(R(i, 2)), 0.0, 1.0);
          half[i] = a * p.half_m.z() + p.half_m.x() * std::sqrt(1.0 - a * a);
          break;
        }
        case Shape::kSphere:
          half[i] = p.half_m.x();
          break;
      }
    }
    *min_m = min_m->cwiseMin(T.translation() - half);
    *max_m = max_m->cwiseMax(T.translation() + half);
  }
}

}  // namespace loci::synth

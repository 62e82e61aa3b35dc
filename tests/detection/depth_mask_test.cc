// SegmentObjectDepth on hand-rendered depth images: objects in front of a wall and a floor,
// with depth noise and missing readings. (The `loci synth` scenes are used in synth_test.cc.)
#include "detection/depth_mask.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "detection/background_planes.h"

namespace loci::detection {
namespace {

double MaskIou(const cv::Mat& a, const cv::Mat& b) {
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? static_cast<double>(inter) / uni : 0.0;
}

// 640x480 fr1-like view: a floor plane (depth falls with the image row) below row 300 and a
// wall at wall_m above it; one object (ellipse or rectangle) at object_m. Kinect-like noise
// sigma = 0.0015 z^2, 2 % random dropouts, then quantised to the TUM PNG (5000 per metre).
struct Frame {
  cv::Mat depth_u16;
  cv::Mat object;  // CV_8UC1 full-image mask of the object
};

Frame Render(std::mt19937& rng, double wall_m, double object_m, bool ellipse, cv::Rect r) {
  Frame f;
  cv::Mat depth_m(480, 640, CV_32F);
  for (int v = 0; v < 480; ++v) {
    // Floor: z = h * fy / (v - cy) for a camera 0.8 m above it, capped by the wall.
    const double floor_m = v > 300 ? 0.8 * 516.5 / (v - 255.3) : 1e9;
    depth_m.row(v).setTo(std::min(wall_m, floor_m));
  }
  f.object = cv::Mat::zeros(480, 640, CV_8UC1);
  if (ellipse) {
    cv::ellipse(f.object, (r.tl() + r.br()) / 2, r.size() / 2, 0, 0, 360, 255, cv::FILLED);
  } else {
    cv::rectangle(f.object, r, 255, cv::FILLED);
  }
  // The object is a slightly curved surface: 3 cm deeper at its rim than at its centre.
  const cv::Point2f c((r.x + r.br().x) / 2.f, (r.y + r.br().y) / 2.f);
  for (int v = r.y; v < r.br().y; ++v) {
    for (int u = r.x; u < r.br().x; ++u) {
      if (!f.object.at<uint8_t>(v, u)) continue;
      const double d = std::hypot((u - c.x) / (r.width / 2.0), (v - c.y) / (r.height / 2.0));
      depth_m.at<float>(v, u) = static_cast<float>(object_m + 0.03 * std::min(1.0, d));
    }
  }
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  f.depth_u16 = cv::Mat(480, 640, CV_16U);
  for (int v = 0; v < 480; ++v) {
    for (int x = 0; x < 640; ++x) {
      const double z = depth_m.at<float>(v, x);
      const double noisy = z + 0.0015 * z * z * n(rng);
      f.depth_u16.at<uint16_t>(v, x) =
          u(rng) < 0.02 ? 0 : static_cast<uint16_t>(std::lround(noisy * 5000));
    }
  }
  return f;
}

TEST(SegmentObjectDepth, ObjectsInFrontOfWallAndFloor) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  MaskOptions o;
  double sum = 0.0, worst = 1.0;
  const int n = 40;
  for (int i = 0; i < n; ++i) {
    const double object_m = 0.6 + 1.6 * u(rng);
    const double wall_m = object_m + 0.25 + 1.5 * u(rng);
    const int w = 40 + static_cast<int>(160 * u(rng)), h = 40 + static_cast<int>(160 * u(rng));
    const cv::Rect r(static_cast<int>((640 - w) * u(rng)), static_cast<int>((480 - h) * u(rng)), w,
                     h);
    const Frame f = Render(rng, wall_m, object_m, i % 2 == 0, r);
    // A detector's box: the object's extent with a few pixels of error on each side.
    std::normal_distribution<float> e(0.f, 3.f);
    const cv::Rect2f box(r.x + e(rng), r.y + e(rng), r.width + e(rng), r.height + e(rng));
    const cv::Mat mask = SegmentObjectDepth(f.depth_u16, box, o);
    const cv::Rect roi = MaskRect(box, 640, 480);
    ASSERT_EQ(mask.size(), roi.size());
    ASSERT_EQ(mask.type(), CV_8UC1);
    const double iou = MaskIou(mask, f.object(roi));
    sum += iou;
    worst = std::min(worst, iou);
  }
  std::printf("hand-rendered boxes: mean mask IoU %.3f, worst %.3f (%d objects)\n", sum / n, worst,
              n);
  EXPECT_GE(sum / n, 0.9);
  EXPECT_GE(worst, 0.75);
}

TEST(SegmentObjectDepth, MetresInputAndEdgeCases) {
  cv::Mat depth_m(100, 100, CV_32F, cv::Scalar(3.0f));
  depth_m(cv::Rect(30, 30, 40, 40)).setTo(1.0f);
  MaskOptions o;
  cv::Mat m = SegmentObjectDepth(depth_m, cv::Rect2f(25, 25, 50, 50), o);
  ASSERT_EQ(m.size(), cv::Size(50, 50));
  EXPECT_EQ(cv::countNonZero(m), 40 * 40);
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(5, 5, 40, 40))), 40 * 40);
  // Box outside the image / unsupported depth type: empty Mat. No depth: all zeros.
  EXPECT_TRUE(SegmentObjectDepth(depth_m, cv::Rect2f(200, 200, 10, 10), o).empty());
  EXPECT_TRUE(SegmentObjectDepth(cv::Mat(10, 10, CV_8UC1), cv::Rect2f(0, 0, 5, 5), o).empty());
  EXPECT_TRUE(SegmentObjectDepth(cv::Mat(), cv::Rect2f(0, 0, 5, 5), o).empty());
  cv::Mat zeros(100, 100, CV_16U, cv::Scalar(0));
  cv::Mat z = SegmentObjectDepth(zeros, cv::Rect2f(10, 10, 20, 20), o);
  ASSERT_EQ(z.size(), cv::Size(20, 20));
  EXPECT_EQ(cv::countNonZero(z), 0);
  // Non-finite gravity (a bad accelerometer reading) is ignored, not trusted.
  const MaskContext bad_gravity{"cup", PinholeCamera::TumFr1(),
                                Eigen::Vector3d(std::nan(""), 0.0, 1.0)};
  EXPECT_EQ(
      cv::countNonZero(SegmentObjectDepth(depth_m, cv::Rect2f(25, 25, 50, 50), o, bad_gravity)),
      40 * 40);
  // AttachDepthMasks: masks only where depth says something; a mask already given is kept.
  std::vector<Detection2D> dets(3);
  dets[0].box_px = {25, 25, 50, 50};
  dets[1].box_px = {500, 500, 5, 5};
  dets[2].box_px = {25, 25, 50, 50};
  dets[2].mask = cv::Mat(50, 50, CV_8UC1, cv::Scalar(255));
  AttachDepthMasks(depth_m, &dets, o);
  EXPECT_EQ(cv::countNonZero(dets[0].mask), 40 * 40);
  EXPECT_TRUE(dets[1].mask.empty());
  EXPECT_EQ(cv::countNonZero(dets[2].mask), 50 * 50);
}

// A camera 0.6 m above a desk, pitched 40 deg down; the desk ends 0.35 m to the left of the
// camera and the floor, 0.75 m lower, shows past its edge. A 3 cm slab (a keyboard, 40 x 20
// cm) lies 0.8 m ahead and 0.15 m to the right. Metres; `keyboard` marks the slab's pixels.
struct DeskView {
  cv::Mat depth_m;
  cv::Mat keyboard;
  Eigen::Vector3d up;  // true up, camera frame
};

DeskView RenderDesk(const PinholeCamera& cam) {
  const double tilt = 40.0 * M_PI / 180.0;
  DeskView view;
  view.up = Eigen::Vector3d(0, -std::cos(tilt), -std::sin(tilt));  // cam: y down, z forward
  const Eigen::Vector3d right(1, 0, 0), fwd = view.up.cross(right);  // level, away from camera
  view.depth_m = cv::Mat(cam.height_px, cam.width_px, CV_32FC1, cv::Scalar(0.0f));
  view.keyboard = cv::Mat::zeros(view.depth_m.size(), CV_8UC1);
  for (int v = 0; v < cam.height_px; ++v) {
    for (int u = 0; u < cam.width_px; ++u) {
      const Eigen::Vector3d ray = cam.BackProject(u, v, 1.0);
      const double down = -view.up.dot(ray);  // > 0: the ray descends
      if (!(down > 0)) continue;
      const Eigen::Vector3d on_desk = (0.6 / down) * ray;
      double z = on_desk.z();
      if (on_desk.dot(right) < -0.35) {
        z = 1.35 / down * ray.z();  // past the desk's edge: the floor
      } else {
        const Eigen::Vector3d d = on_desk - (-0.6 * view.up + 0.8 * fwd + 0.15 * right);
        if (std::abs(d.dot(right)) < 0.2 && std::abs(d.dot(fwd)) < 0.1) {
          z = 0.57 / down * ray.z();  // the slab's top, 3 cm up
          view.keyboard.at<uint8_t>(v, u) = 255;
        }
      }
      view.depth_m.at<float>(v, u) = static_cast<float>(z);
    }
  }
  return view;
}

TEST(SegmentObjectDepth, LeavesOutADeskHoldingTheCentreOfALooseBox) {
  // A detector's loose box (a "laptop" over a keyboard and the desk around it): its centre lies
  // on the desk, the slab fills its right part and the floor its lower left corner. The desk
  // plane is the support (level, the slab above it, the desk continuing past the box), so it
  // is background although it holds the centre; what lies below it is past the desk's edge.
  const PinholeCamera cam = PinholeCamera::TumFr1();
  const DeskView view = RenderDesk(cam);
  const cv::Rect slab = cv::boundingRect(view.keyboard);
  ASSERT_GT(slab.area(), 2000);
  const cv::Rect2f box(60, slab.y - 60, slab.br().x + 12 - 60, slab.height + 90);
  const cv::Rect roi = MaskRect(box, cam.width_px, cam.height_px);
  cv::Mat floor_in_box = view.depth_m(roi) > 1.2f;
  ASSERT_GT(cv::countNonZero(floor_in_box), 0.03 * roi.area());  // the floor is in the box
  // Gravity 3 deg off the truth, as an accelerometer in motion gives it.
  const Eigen::Vector3d gravity =
      -(Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * view.up);
  MaskOptions o;
  const cv::Mat with = SegmentObjectDepth(view.depth_m, box, o, {"laptop", cam, gravity});
  const cv::Mat without = SegmentObjectDepth(view.depth_m, box, o, {"laptop", cam, {}});
  const double iou_with = MaskIou(with, view.keyboard(roi));
  const double iou_without = MaskIou(without, view.keyboard(roi));
  std::printf("keyboard in a loose box: IoU %.3f with gravity, %.3f without\n", iou_with,
              iou_without);
  EXPECT_GT(iou_with, 0.85);
  EXPECT_LT(iou_without, 0.5);  // without gravity the desk holding the centre is the object
}

// Sheets of paper lying on a desk, boxed as "book" (fr1_rpy): the
// box's centre lies on the desk, which goes on outside the box, and nothing in the box rises
// above it. The box shows only its support, so it gets no mask; a slab 3 cm thick does.
TEST(SegmentObjectDepth, ABoxOverTheBareDeskHasNoMask) {
  const PinholeCamera cam = PinholeCamera::TumFr1();
  DeskView view = RenderDesk(cam);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 1.f);
  // One generator, so one thread: cv::Mat::forEach runs in parallel (a race on rng).
  for (auto it = view.depth_m.begin<float>(); it != view.depth_m.end<float>(); ++it) {
    float& z = *it;
    if (z > 0.f) z += 0.0015f * z * z * noise(rng);  // Kinect axial noise
  }
  const Eigen::Vector3d gravity =
      -(Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * view.up);
  const Eigen::Vector3d right(1, 0, 0), fwd = view.up.cross(right);
  // Bare desk 0.2 m left of the camera and 0.75 m ahead: left of the slab, 0.15 m from the
  // desk's edge.
  const std::optional<Eigen::Vector2d> uv =
      cam.Project(-0.6 * view.up + 0.75 * fwd - 0.2 * right);
  ASSERT_TRUE(uv.has_value());
  const cv::Rect2f paper(uv->x() - 50, uv->y() - 40, 100, 80);
  ASSERT_EQ(cv::countNonZero(view.keyboard(MaskRect(paper, cam.width_px, cam.height_px))), 0);
  MaskOptions o;
  EXPECT_EQ(cv::countNonZero(SegmentObjectDepth(view.depth_m, paper, o, {"book", cam, gravity})),
            0);
  // A phone is thinner than the plane tolerance (thin_classes): the surface is its mask.
  EXPECT_GT(
      cv::countNonZero(SegmentObjectDepth(view.depth_m, paper, o, {"cell phone", cam, gravity})),
      0.5 * paper.area());
  // Without gravity nothing says the surface is level: the old mask, the desk in the box.
  EXPECT_GT(cv::countNonZero(SegmentObjectDepth(view.depth_m, paper, o, {"book", cam, {}})),
            0.5 * paper.area());
  // A tight box over the slab: its top stands 3 cm out of the desk, so it is an object.
  const cv::Rect slab = cv::boundingRect(view.keyboard);
  const cv::Rect2f tight(slab.x - 4, slab.y - 4, slab.width + 8, slab.height + 8);
  const cv::Mat slab_mask = SegmentObjectDepth(view.depth_m, tight, o, {"book", cam, gravity});
  const double iou = MaskIou(slab_mask, view.keyboard(MaskRect(tight, 640, 480)));
  std::printf("bare desk: no mask; slab in a tight box: IoU %.3f\n", iou);
  EXPECT_GT(iou, 0.8);
  o.bare_support_max_tolerance_m = 0.f;  // off
  EXPECT_GT(cv::countNonZero(SegmentObjectDepth(view.depth_m, paper, o, {"book", cam, gravity})),
            0.5 * paper.area());
}

TEST(InverseDepthPlane, FitsAnyPlaneWithoutIntrinsics) {
  // Floor 0.8 m below a camera tilted down by 20 deg, seen with fr1 intrinsics.
  const PinholeCamera cam = PinholeCamera::TumFr1();
  const double tilt = 20.0 * M_PI / 180.0;
  const Eigen::Vector3d up_cam(0, -std::cos(tilt), -std::sin(tilt));  // y down, z forward
  std::vector<cv::Point3d> points;
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (int v = 300; v < 480; v += 9) {
    for (int u = 0; u < 640; u += 13) {
      const Eigen::Vector3d ray = cam.BackProject(u, v, 1.0);
      const double z = -0.8 / up_cam.dot(ray);  // up . (z ray) = -0.8
      if (z > 0) points.emplace_back(u, v, z + noise(rng));
    }
  }
  ASSERT_GE(points.size(), 200u);
  InverseDepthPlane p;
  ASSERT_TRUE(p.Fit3(points[0], points[points.size() / 2], points.back()));
  ASSERT_TRUE(p.Refit(points));
  const Eigen::Vector3d ray = cam.BackProject(400, 420, 1.0);
  EXPECT_NEAR(p.DepthAt(400, 420), -0.8 / up_cam.dot(ray), 0.003);
  EXPECT_FALSE(p.Fit3({0, 0, 1}, {1, 1, 1}, {2, 2, 1}));  // collinear pixels
  EXPECT_LE(p.DepthAt(320, 0), 0.0);                      // above the horizon: no floor
}

TEST(MaskOptions, YamlAndValidation) {
  auto o = MaskOptions::FromYaml(YAML::Load("{depth_scale: 1000, bin_width_rel: 0.03}"));
  ASSERT_TRUE(o.ok()) << o.status();
  EXPECT_FLOAT_EQ(o->depth_scale, 1000.f);
  EXPECT_FALSE(MaskOptions::FromYaml(YAML::Load("{depth_scale: 0}")).ok());
  EXPECT_FALSE(MaskOptions::FromYaml(YAML::Load("{min_depth_m: 5, max_depth_m: 1}")).ok());
  EXPECT_FALSE(MaskOptions::FromYaml(YAML::Load("{min_outside_fraction: 0}")).ok());
  EXPECT_FALSE(MaskOptions::FromYaml(YAML::Load("{horizontal_max_deg: 95}")).ok());
  auto c = MaskOptions::FromYaml(YAML::Load("{support_classes: [bed], flat_top_classes: [bed]}"));
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_TRUE(c->IsFlatTopClass("bed"));
  EXPECT_FALSE(c->IsSupportClass("dining table"));
  auto t = MaskOptions::FromYaml(YAML::Load("{thin_classes: [book]}"));
  ASSERT_TRUE(t.ok()) << t.status();
  EXPECT_TRUE(t->IsThinClass("book"));
  EXPECT_FALSE(t->IsThinClass("cell phone"));
  EXPECT_FALSE(MaskOptions::FromYaml(YAML::Load("{bare_support_max_tolerance_m: -1}")).ok());
}

}  // namespace
}  // namespace loci::detection

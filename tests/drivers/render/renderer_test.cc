// Renderer: depth against analytic geometry and the face-by-face reference, labels, empty pixels, determinism and
// noise, frame sizes, bad input and the no-allocation-per-frame guarantee.
#include "drivers/render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "tests/drivers/render/reference_raycast.h"
#include "tests/support/allocation_counter.h"

namespace qsg::render {
namespace {

using messages::CameraIntrinsics;
using messages::RgbdFrame;
using testing::look_at;
using testing::make_intrinsics;
using testing::pixel_direction;
using testing::reference_raycast;
namespace sem = semantics;

constexpr double kPi = 3.14159265358979323846;

world::Material mat(semantics::Label label, world::Texture texture = world::Texture::kPlain,
                    std::array<std::uint8_t, 3> color = {{180, 160, 140}}) {
  world::Material m;
  m.label = label;
  m.texture = texture;
  m.color = color;
  m.texture_scale_m = 0.3f;
  return m;
}

world::BoxShape box(const Eigen::Vector3d& center, const Eigen::Vector3d& half,
                    const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  world::BoxShape b;
  b.center_m = center;
  b.half_extents_m = half;
  b.world_R_box = q;
  return b;
}

world::PrismShape prism(std::vector<Eigen::Vector2d> polygon, double z_min, double z_max) {
  world::PrismShape p;
  p.polygon_m = std::move(polygon);
  p.z_min_m = z_min;
  p.z_max_m = z_max;
  return p;
}

void add_floor(world::World& w) {
  world::PlaneShape plane;
  w.add_plane(plane, mat(sem::kFloor, world::Texture::kChecker));
}

std::unique_ptr<RgbdFrame> make_frame() {
  auto frame = std::make_unique<RgbdFrame>();
  frame->depth_m.fill(-7.0f);
  frame->labels.fill(0xBEEF);
  frame->rgb.fill(77);
  return frame;
}

struct Comparison {
  int pixels = 0;
  int hits = 0;               // pixels where the reference sees a surface within range
  int status_mismatches = 0;  // hit in one, nothing in the other
  int label_mismatches = 0;
  double max_depth_error_m = 0.0;
  std::string first_problem;
};

// Compares every pixel of a rendered frame with the reference ray caster.
Comparison compare_with_reference(const world::World& world, const Renderer::Config& config, const RgbdFrame& frame,
                                  const Eigen::Isometry3d& pose) {
  Comparison c;
  const CameraIntrinsics& k = frame.intrinsics;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const int idx = v * k.width + u;
      ++c.pixels;
      const testing::ReferenceHit ref =
          reference_raycast(world, pose.translation(), pixel_direction(pose, k, u, v), 1e-6, config.max_range_m);
      const bool ref_hit = ref.shape >= 0;
      const double expected_depth = ref_hit && ref.t >= config.min_range_m ? ref.t : 0.0;
      const float depth = frame.depth_m[idx];
      if ((expected_depth > 0.0) != (depth > 0.0f)) {
        ++c.status_mismatches;
        if (c.first_problem.empty())
          c.first_problem = "pixel (" + std::to_string(u) + ", " + std::to_string(v) + "): rendered " +
                            std::to_string(depth) + ", reference " + std::to_string(expected_depth);
        continue;
      }
      if (expected_depth > 0.0) {
        ++c.hits;
        c.max_depth_error_m = std::max(c.max_depth_error_m, std::fabs(depth - expected_depth));
      }
      // Labels are compared where the nearest surface is unambiguous (not where two surfaces meet).
      if (ref.second_t - ref.t > 1e-4 || !ref_hit) {
        const semantics::Label expected =
            ref_hit ? world.shapes[static_cast<std::size_t>(ref.shape)].material.label : semantics::Label{sem::kVoid};
        if (frame.labels[idx] != expected) {
          ++c.label_mismatches;
          if (c.first_problem.empty())
            c.first_problem = "pixel (" + std::to_string(u) + ", " + std::to_string(v) + "): label " +
                              std::to_string(frame.labels[idx]) + ", reference " + std::to_string(expected);
        }
      }
    }
  }
  return c;
}

void expect_matches_reference(const world::World& world, const Eigen::Isometry3d& pose, const CameraIntrinsics& k,
                              double min_hit_fraction, const Renderer::Config& config = {}) {
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init(config, world, &error)) << error;
  auto frame = make_frame();
  ASSERT_TRUE(renderer.render(pose, k, 1, *frame, &error)) << error;
  const Comparison c = compare_with_reference(world, config, *frame, pose);
  EXPECT_EQ(c.status_mismatches, 0) << c.first_problem;
  EXPECT_EQ(c.label_mismatches, 0) << c.first_problem;
  EXPECT_LE(c.max_depth_error_m, 1e-3);
  // The view must actually contain geometry, or the comparison proves nothing.
  EXPECT_GE(c.hits, static_cast<int>(min_hit_fraction * c.pixels));
}

TEST(Renderer, PlaneDepthIsAnalyticZDepth) {
  world::World w;
  add_floor(w);
  const Eigen::Vector3d eye(0.3, -0.2, 1.3);
  const Eigen::Isometry3d pose = look_at(eye, Eigen::Vector3d(3.0, 0.5, 0.0));
  const CameraIntrinsics k = make_intrinsics(160, 120);
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  ASSERT_TRUE(renderer.render(pose, k, 0, *frame, &error)) << error;
  int hits = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      // Ray-plane intersection by hand; the camera-frame ray has unit z, so its parameter is the z-depth.
      const Eigen::Vector3d d = pose.linear() * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const double t = d.z() < 0.0 ? -eye.z() / d.z() : -1.0;
      const bool visible = t >= 0.1 && t <= 10.0;
      const int idx = v * k.width + u;
      if (visible) {
        ++hits;
        ASSERT_NEAR(frame->depth_m[idx], t, 1e-3) << "pixel " << u << ", " << v;
        ASSERT_EQ(frame->labels[idx], sem::kFloor);
      } else {
        ASSERT_EQ(frame->depth_m[idx], 0.0f) << "pixel " << u << ", " << v;
        ASSERT_EQ(frame->labels[idx], sem::kVoid);
      }
    }
  }
  EXPECT_GT(hits, k.width * k.height / 3);
  EXPECT_LT(hits, k.width * k.height);  // the horizon is in view
  EXPECT_TRUE(frame->has_labels);
  EXPECT_EQ(frame->sequence, 0u);
}

TEST(Renderer, DepthIsAlongOpticalAxisNotRayLength) {
  // A wall facing the camera at 4 m: every pixel has z-depth 4 although corner rays are longer.
  world::World w;
  w.add_box(box({4.5, 0.0, 0.0}, {0.5, 20.0, 20.0}), mat(sem::kWall));
  const Eigen::Isometry3d pose = look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  const CameraIntrinsics k = make_intrinsics(64, 48, 90.0);
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  ASSERT_TRUE(renderer.render(pose, k, 0, *frame, &error)) << error;
  for (int i = 0; i < k.width * k.height; ++i) ASSERT_NEAR(frame->depth_m[i], 4.0f, 1e-5f) << i;
}

TEST(Renderer, AxisAlignedBoxesMatchReference) {
  world::World w;
  add_floor(w);
  w.add_box(box({3.1, 0.37, 0.45}, {0.4, 0.55, 0.45}), mat(sem::kCabinet));
  w.add_box(box({4.7, -1.13, 0.8}, {0.3, 0.3, 0.8}), mat(sem::kChestOfDrawers));
  w.add_box(box({2.2, -0.9, 1.31}, {0.21, 0.33, 0.07}), mat(sem::kTvMonitor));  // floating
  expect_matches_reference(w, look_at({0.2, 0.1, 1.1}, {4.0, -0.2, 0.4}), make_intrinsics(160, 120), 0.5);
}

TEST(Renderer, RotatedBoxesMatchReference) {
  world::World w;
  add_floor(w);
  w.add_box(box({3.0, 0.2, 1.0}, {0.5, 0.3, 0.4},
                Eigen::Quaterniond(Eigen::AngleAxisd(0.6, Eigen::Vector3d(0.3, 0.5, 0.8).normalized()))),
            mat(sem::kSofa));
  w.add_box(
      box({2.4, -1.0, 0.35}, {0.6, 0.25, 0.35}, Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()))),
      mat(sem::kTable));
  // A 90-degree yaw takes the axis-aligned fast path with swapped extents.
  w.add_box(
      box({4.0, 1.3, 0.5}, {0.8, 0.2, 0.5}, Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()))),
      mat(sem::kCabinet));
  expect_matches_reference(w, look_at({0.1, 0.0, 1.4}, {3.0, 0.0, 0.6}), make_intrinsics(160, 120), 0.5);
  expect_matches_reference(w, look_at({5.3, 2.1, 2.2}, {2.6, -0.4, 0.4}), make_intrinsics(120, 90), 0.5);
}

TEST(Renderer, RotatedBoxDepthAtCentrePixelIsAnalytic) {
  // A cube yawed 45 degrees shows its vertical edge to the camera: the centre ray meets it at d - h * sqrt(2).
  world::World w;
  w.add_box(
      box({5.0, 0.0, 0.0}, {0.5, 0.5, 0.5}, Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 4, Eigen::Vector3d::UnitZ()))),
      mat(sem::kCabinet));
  const CameraIntrinsics k = make_intrinsics(41, 31);  // odd sizes: the centre pixel looks exactly along +x
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  ASSERT_TRUE(renderer.render(look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()), k, 0, *frame, &error));
  EXPECT_NEAR(frame->depth_m[15 * 41 + 20], 5.0 - 0.5 * std::sqrt(2.0), 1e-4);
  EXPECT_EQ(frame->labels[15 * 41 + 20], sem::kCabinet);
}

TEST(Renderer, CylinderHitsWhereGeometrySays) {
  world::World w;
  add_floor(w);
  world::CylinderShape c;
  c.base_center_m = {3.0, 0.0, 0.0};
  c.radius_m = 0.5;
  c.height_m = 1.2;
  w.add_cylinder(c, mat(sem::kPlant, world::Texture::kNoise));
  const CameraIntrinsics k = make_intrinsics(161, 121);
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  // Side view: the centre ray (along +x at 0.73 m) meets the front of the cylinder at x = 2.5.
  const Eigen::Isometry3d side = look_at({0.0, 0.0, 0.73}, {1.0, 0.0, 0.73});
  ASSERT_TRUE(renderer.render(side, k, 0, *frame, &error)) << error;
  const int centre = 60 * 161 + 80;
  EXPECT_NEAR(frame->depth_m[centre], 2.5, 1e-4);
  EXPECT_EQ(frame->labels[centre], sem::kPlant);
  // Silhouette on the centre row: a pixel ray hits iff its angle to +x is below asin(r / d).
  const double half_angle = std::asin(0.5 / 3.0);
  for (int u = 0; u < k.width; ++u) {
    const double angle = std::atan(std::fabs(u - k.cx) / k.fx);
    if (std::fabs(angle - half_angle) < 1e-3) continue;  // on the silhouette itself
    EXPECT_EQ(frame->labels[60 * 161 + u] == sem::kPlant, angle < half_angle) << "column " << u;
  }
  // Top view: straight down from 3 m onto the cap at 1.2 m.
  const Eigen::Isometry3d top = look_at({3.0, 0.0, 3.0}, {3.0, 0.0, 0.0}, Eigen::Vector3d::UnitX());
  ASSERT_TRUE(renderer.render(top, k, 1, *frame, &error)) << error;
  EXPECT_NEAR(frame->depth_m[centre], 1.8, 1e-4);
  // Full comparisons from both views and an oblique one.
  expect_matches_reference(w, side, k, 0.3);
  expect_matches_reference(w, top, k, 0.9);
  expect_matches_reference(w, look_at({1.2, 1.7, 2.1}, {3.0, 0.0, 0.6}), make_intrinsics(120, 90), 0.5);
}

// An L-shaped counter: x in [1, 3] x y in [-1, -0.4], plus x in [1, 1.6] x y in [-1, 1]; 0.9 m high.
std::vector<Eigen::Vector2d> l_shape() {
  return {{1.0, -1.0}, {3.0, -1.0}, {3.0, -0.4}, {1.6, -0.4}, {1.6, 1.0}, {1.0, 1.0}};
}
bool inside_l(double x, double y) {
  return (x > 1.0 && x < 3.0 && y > -1.0 && y < -0.4) || (x > 1.0 && x < 1.6 && y > -1.0 && y < 1.0);
}

TEST(Renderer, ConcaveLPrismSeenFromAboveShowsTheNotch) {
  world::World w;
  add_floor(w);
  w.add_prism(prism(l_shape(), 0.0, 0.9), mat(sem::kCounter));
  const CameraIntrinsics k = make_intrinsics(120, 120, 60.0);
  // Straight down from 4 m above the notch: z-depth is 4 - z of whatever is hit.
  const Eigen::Isometry3d pose = look_at({2.0, 0.0, 4.0}, {2.0, 0.0, 0.0}, Eigen::Vector3d::UnitX());
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  ASSERT_TRUE(renderer.render(pose, k, 0, *frame, &error)) << error;
  int top = 0, notch_floor = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d d = pixel_direction(pose, k, u, v);
      const Eigen::Vector3d p_top = pose.translation() + (0.9 - 4.0) / d.z() * d;
      const Eigen::Vector3d p_floor = pose.translation() + (0.0 - 4.0) / d.z() * d;
      const int idx = v * k.width + u;
      if (inside_l(p_top.x(), p_top.y())) {
        ++top;
        ASSERT_NEAR(frame->depth_m[idx], 3.1, 1e-3) << u << ", " << v;
        ASSERT_EQ(frame->labels[idx], sem::kCounter);
        continue;
      }
      // The floor is seen where the whole segment from the top plane down to the floor stays outside the L.
      bool clear = true;
      for (int s = 0; s <= 200 && clear; ++s) {
        const Eigen::Vector3d q = p_top + (p_floor - p_top) * (s / 200.0);
        clear = !inside_l(q.x(), q.y());
      }
      if (clear) {
        if (std::fabs(p_floor.x() - 1.6) > 1e-2 && std::fabs(p_floor.y() + 0.4) > 1e-2 && p_floor.x() > 1.0 &&
            p_floor.y() > -1.0 && p_floor.x() < 3.0 && p_floor.y() < 1.0)
          ++notch_floor;  // floor seen inside the L's bounding box: a convex-hull renderer would fail here
        ASSERT_NEAR(frame->depth_m[idx], 4.0, 1e-3) << u << ", " << v;
        ASSERT_EQ(frame->labels[idx], sem::kFloor);
      } else {
        ASSERT_GT(frame->depth_m[idx], 3.1 - 1e-3) << u << ", " << v;  // a side wall below the top
        ASSERT_LT(frame->depth_m[idx], 4.0 + 1e-3) << u << ", " << v;
        ASSERT_EQ(frame->labels[idx], sem::kCounter) << u << ", " << v << " depth " << frame->depth_m[idx] << " top "
                                                     << p_top.transpose() << " floor " << p_floor.transpose();
      }
    }
  }
  EXPECT_GT(top, 1000);
  EXPECT_GT(notch_floor, 1000);
}

TEST(Renderer, PrismsMatchReference) {
  world::World w;
  add_floor(w);
  w.add_prism(prism(l_shape(), 0.0, 0.9), mat(sem::kCounter));
  // A convex hexagon and a U shape (two notches), one of them floating.
  std::vector<Eigen::Vector2d> hexagon;
  for (int i = 0; i < 6; ++i)
    hexagon.emplace_back(4.0 + 0.45 * std::cos(i * kPi / 3 + 0.1), 1.2 + 0.45 * std::sin(i * kPi / 3 + 0.1));
  w.add_prism(prism(hexagon, 0.0, 1.7), mat(sem::kColumn));
  w.add_prism(
      prism({{3.5, -2.0}, {4.7, -2.0}, {4.7, -0.8}, {4.4, -0.8}, {4.4, -1.7}, {3.8, -1.7}, {3.8, -0.8}, {3.5, -0.8}},
            0.3, 1.1),
      mat(sem::kShelving));
  // Clockwise outline: accepted and reversed.
  w.add_prism(prism({{5.5, 0.0}, {5.5, 0.5}, {6.0, 0.5}, {6.0, 0.0}}, 0.0, 0.6), mat(sem::kStool));
  const CameraIntrinsics k = make_intrinsics(140, 105);
  expect_matches_reference(w, look_at({-0.3, 0.2, 1.5}, {3.0, -0.5, 0.3}), k, 0.5);
  expect_matches_reference(w, look_at({6.5, 2.5, 2.0}, {2.5, -0.5, 0.3}), k, 0.5);
  expect_matches_reference(w, look_at({3.2, -3.2, 0.6}, {4.1, -1.0, 0.6}), k, 0.5);
}

world::World mixed_world() {
  world::World w;
  add_floor(w);
  world::PlaneShape wall;
  wall.point_m = {8.0, 0.0, 0.0};
  wall.normal = {-1.0, 0.2, 0.0};
  w.add_plane(wall, mat(sem::kWall, world::Texture::kStripes));
  w.add_box(box({3.0, 0.9, 0.5}, {0.5, 0.4, 0.5}), mat(sem::kCabinet, world::Texture::kChecker));
  w.add_box(box({4.2, -0.8, 0.9}, {0.3, 0.5, 0.2},
                Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()))),
            mat(sem::kTable));
  world::CylinderShape c;
  c.base_center_m = {2.2, -0.6, 0.0};
  c.radius_m = 0.3;
  c.height_m = 1.4;
  w.add_cylinder(c, mat(sem::kPlant, world::Texture::kNoise));
  w.add_prism(prism({{5.0, 1.0}, {6.0, 1.0}, {6.0, 1.4}, {5.4, 1.4}, {5.4, 2.2}, {5.0, 2.2}}, 0.0, 2.0),
              mat(sem::kCounter));
  w.add_prism(prism({{5.5, -1.5}, {6.5, -1.2}, {6.2, -0.4}, {5.6, -0.6}}, 0.0, 0.8), mat(sem::kBed));
  return w;
}

TEST(Renderer, LabelsAndDepthMatchReferenceInMixedScene) {
  const world::World w = mixed_world();
  const CameraIntrinsics k = make_intrinsics(160, 120);
  expect_matches_reference(w, look_at({0.0, 0.0, 1.2}, {5.0, 0.0, 0.5}), k, 0.6);
  expect_matches_reference(w, look_at({7.0, 2.9, 1.8}, {3.5, -0.5, 0.4}), k, 0.6);
  expect_matches_reference(w, look_at({3.6, 0.1, 0.5}, {1.0, 1.0, 0.7}), k, 0.5);
}

TEST(Renderer, PixelsThatSeeNothingAreZero) {
  world::World w;
  w.add_box(box({-3.0, 0.0, 0.0}, {0.5, 0.5, 0.5}), mat(sem::kCabinet));  // behind the camera
  w.add_box(box({12.0, 0.0, 0.0}, {0.5, 0.5, 0.5}), mat(sem::kCabinet));  // beyond max range
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  const CameraIntrinsics k = make_intrinsics(40, 30, 40.0);
  ASSERT_TRUE(renderer.render(look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()), k, 3, *frame, &error));
  for (int i = 0; i < k.width * k.height; ++i) {
    ASSERT_EQ(frame->depth_m[i], 0.0f) << i;
    ASSERT_EQ(frame->labels[i], sem::kVoid) << i;
    ASSERT_EQ(frame->rgb[3 * i], 0) << i;
  }
  EXPECT_EQ(renderer.counters().hits, 0u);
  EXPECT_EQ(renderer.counters().rays, static_cast<std::uint64_t>(k.width * k.height));
}

TEST(Renderer, SurfacesNearerThanMinRangeBlankDepthButStillOcclude) {
  world::World w;
  w.add_box(box({0.05, 0.0, 0.0}, {0.01, 5.0, 5.0}), mat(sem::kDoor));  // 4 cm in front of the camera
  w.add_box(box({2.0, 0.0, 0.0}, {0.5, 5.0, 5.0}), mat(sem::kWall));    // would be seen through it otherwise
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  const CameraIntrinsics k = make_intrinsics(20, 15, 40.0);
  ASSERT_TRUE(renderer.render(look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()), k, 0, *frame, &error));
  for (int i = 0; i < k.width * k.height; ++i) {
    ASSERT_EQ(frame->depth_m[i], 0.0f) << i;
    ASSERT_EQ(frame->labels[i], sem::kDoor) << i;
  }
  EXPECT_EQ(renderer.counters().too_near, static_cast<std::uint64_t>(k.width * k.height));
}

TEST(Renderer, ColourCarriesTextureAndShading) {
  world::World w;
  w.add_box(box({3.0, 0.0, 0.0}, {0.05, 4.0, 4.0}), mat(sem::kWall, world::Texture::kChecker, {{200, 100, 50}}));
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  const CameraIntrinsics k = make_intrinsics(80, 60);
  ASSERT_TRUE(renderer.render(look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()), k, 0, *frame, &error));
  // Checker: two brightness levels of the same hue, never brighter than the material colour.
  int dark = 0, light = 0;
  for (int i = 0; i < k.width * k.height; ++i) {
    const int r = frame->rgb[3 * i], g = frame->rgb[3 * i + 1];
    ASSERT_LE(r, 200);
    ASSERT_NEAR(r, 2 * g, 2);
    (r < 100 ? dark : light) += 1;
  }
  EXPECT_GT(dark, k.width * k.height / 5);
  EXPECT_GT(light, k.width * k.height / 5);
}

void render_noisy(std::uint64_t seed, bool noise, RgbdFrame& frame, std::uint64_t sequence = 5) {
  Renderer::Config config;
  config.seed = seed;
  config.noise.enabled = noise;
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init(config, mixed_world(), &error)) << error;
  ASSERT_TRUE(
      renderer.render(look_at({0.0, 0.0, 1.2}, {5.0, 0.0, 0.5}), make_intrinsics(96, 72), sequence, frame, &error))
      << error;
}

int count_depth_differences(const RgbdFrame& a, const RgbdFrame& b) {
  int n = 0;
  for (int i = 0; i < a.pixels(); ++i) n += a.depth_m[i] != b.depth_m[i];
  return n;
}

TEST(Renderer, SameSeedGivesBitIdenticalFrames) {
  auto a = make_frame();
  auto b = make_frame();
  render_noisy(42, true, *a);
  render_noisy(42, true, *b);
  const std::size_t n = static_cast<std::size_t>(a->pixels());
  EXPECT_EQ(std::memcmp(a->depth_m.data(), b->depth_m.data(), n * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(a->rgb.data(), b->rgb.data(), n * 3), 0);
  EXPECT_EQ(std::memcmp(a->labels.data(), b->labels.data(), n * sizeof(std::uint16_t)), 0);
}

TEST(Renderer, NoiseDependsOnSeedAndFrameButNotOnColourOrLabels) {
  auto exact = make_frame();
  auto a = make_frame();
  auto b = make_frame();
  auto c = make_frame();
  render_noisy(42, false, *exact);
  render_noisy(42, true, *a);
  render_noisy(43, true, *b);
  render_noisy(42, true, *c, 6);  // next frame of the same run
  const int n = a->pixels();
  EXPECT_GT(count_depth_differences(*a, *b), n / 2);
  EXPECT_GT(count_depth_differences(*a, *c), n / 2);
  EXPECT_GT(count_depth_differences(*a, *exact), n / 2);
  EXPECT_EQ(std::memcmp(a->rgb.data(), b->rgb.data(), static_cast<std::size_t>(n) * 3), 0);
  EXPECT_EQ(std::memcmp(a->labels.data(), b->labels.data(), static_cast<std::size_t>(n) * 2), 0);
  // Without noise the seed does not matter at all.
  auto exact2 = make_frame();
  render_noisy(99, false, *exact2);
  EXPECT_EQ(count_depth_differences(*exact, *exact2), 0);
}

TEST(Renderer, NoisyDepthFollowsTheModel) {
  // A wall square to the optical axis at 3 m: every pixel has true z-depth 3.
  world::World w;
  w.add_box(box({3.5, 0.0, 0.0}, {0.5, 10.0, 10.0}), mat(sem::kWall));
  Renderer::Config config;
  config.noise.enabled = true;
  config.noise.quantize = false;
  config.seed = 11;
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init(config, w, &error)) << error;
  auto frame = make_frame();
  const CameraIntrinsics k = make_intrinsics(160, 120, 50.0);
  ASSERT_TRUE(renderer.render(look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()), k, 0, *frame, &error));
  double sum = 0.0, sum_sq = 0.0;
  int valid = 0;
  for (int i = 0; i < frame->pixels(); ++i) {
    if (frame->depth_m[i] == 0.0f) continue;
    const double e = frame->depth_m[i] - 3.0;
    sum += e;
    sum_sq += e * e;
    ++valid;
  }
  const double sigma = 0.0012 + 0.0019 * 9.0;
  ASSERT_EQ(valid, frame->pixels());  // square-on surface, no random dropouts configured
  const double mean = sum / valid;
  const double std_dev = std::sqrt(sum_sq / valid - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4.0 * sigma / std::sqrt(valid));
  EXPECT_NEAR(std_dev, sigma, 0.05 * sigma);

  // Quantised output lands on multiples of the frame's depth unit.
  config.noise.quantize = true;
  ASSERT_TRUE(renderer.init(config, w, &error)) << error;
  frame->depth_scale_m = 0.002f;
  ASSERT_TRUE(renderer.render(look_at(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()), k, 0, *frame, &error));
  for (int i = 0; i < frame->pixels(); ++i) {
    const double units = frame->depth_m[i] / 0.002;
    ASSERT_NEAR(units, std::round(units), 1e-3) << i;
  }
}

TEST(Renderer, GrazingSurfacesDropOut) {
  world::World w;
  add_floor(w);
  Renderer::Config config;
  config.noise.enabled = true;
  config.noise.sigma_base_m = 0.0;
  config.noise.sigma_quadratic_per_m = 0.0;
  config.max_range_m = 50.0;
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init(config, w, &error)) << error;
  auto frame = make_frame();
  const CameraIntrinsics k = make_intrinsics(80, 60);
  const Eigen::Isometry3d pose = look_at({0.0, 0.0, 0.4}, {1.0, 0.0, 0.25});
  ASSERT_TRUE(renderer.render(pose, k, 0, *frame, &error));
  int steep = 0, grazing = 0, dropped_between = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d d = pixel_direction(pose, k, u, v);
      if (d.z() >= 0.0) continue;
      if (-0.4 / d.z() > config.max_range_m) continue;
      const double angle_deg = std::acos(std::fabs(d.normalized().z())) * 180.0 / kPi;
      const float depth = frame->depth_m[v * k.width + u];
      if (angle_deg < 74.9) {
        ++steep;
        ASSERT_GT(depth, 0.0f) << "angle " << angle_deg;
      } else if (angle_deg > 88.1) {
        ++grazing;
        ASSERT_EQ(depth, 0.0f) << "angle " << angle_deg;
      } else {
        dropped_between += depth == 0.0f;
      }
    }
  }
  EXPECT_GT(steep, 100);
  EXPECT_GT(grazing, 20);
  EXPECT_GT(dropped_between, 0);
  EXPECT_GT(renderer.counters().dropouts, 0u);
}

TEST(Renderer, RendersEverySizeUpTo640x480) {
  world::World w;
  add_floor(w);
  w.add_box(box({3.0, 0.0, 0.6}, {0.4, 0.4, 0.6}), mat(sem::kCabinet));
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;
  auto frame = make_frame();
  const Eigen::Isometry3d pose = look_at({0.0, 0.0, 1.0}, {3.0, 0.0, 0.3});
  const int sizes[][2] = {{1, 1}, {2, 3}, {7, 5}, {160, 120}, {320, 240}, {640, 480}};
  for (const auto& size : sizes) {
    frame->depth_m.fill(-7.0f);
    const CameraIntrinsics k = make_intrinsics(size[0], size[1]);
    ASSERT_TRUE(renderer.render(pose, k, 9, *frame, &error)) << error;
    EXPECT_EQ(frame->width(), size[0]);
    EXPECT_EQ(frame->height(), size[1]);
    const int n = size[0] * size[1];
    int valid = 0;
    for (int i = 0; i < n; ++i) {
      ASSERT_GE(frame->depth_m[i], 0.0f);
      valid += frame->depth_m[i] > 0.0f;
    }
    EXPECT_GT(valid, 0) << size[0] << "x" << size[1];
    if (n < messages::kMaxFramePixels) {
      EXPECT_EQ(frame->depth_m[n], -7.0f) << "wrote past the frame";
    }
    // The centre pixel always sees the box front at x = 2.6 (or its top, from this height): depth below 3.
    if (size[0] % 2 == 1 && size[1] % 2 == 1) {
      EXPECT_LT(frame->depth_m[(size[1] / 2) * size[0] + size[0] / 2], 3.0f);
    }
  }
}

TEST(Renderer, RejectsInvalidIntrinsicsAndPoses) {
  world::World w;
  add_floor(w);
  Renderer renderer;
  std::string error;
  auto frame = make_frame();
  const Eigen::Isometry3d pose = look_at({0.0, 0.0, 1.0}, {3.0, 0.0, 0.3});
  EXPECT_FALSE(renderer.render(pose, make_intrinsics(16, 12), 0, *frame, &error));
  EXPECT_NE(error.find("init"), std::string::npos) << error;
  ASSERT_TRUE(renderer.init({}, w, &error)) << error;

  struct Case {
    const char* field;
    CameraIntrinsics k;
  };
  std::vector<Case> cases;
  CameraIntrinsics k = make_intrinsics(16, 12);
  cases.push_back({"intrinsics.width", k});
  cases.back().k.width = 0;
  cases.push_back({"intrinsics.width", k});
  cases.back().k.width = 641;
  cases.push_back({"intrinsics.height", k});
  cases.back().k.height = -3;
  cases.push_back({"intrinsics.height", k});
  cases.back().k.height = 481;
  cases.push_back({"intrinsics.fx", k});
  cases.back().k.fx = 0.0;
  cases.push_back({"intrinsics.fx", k});
  cases.back().k.fx = -100.0;
  cases.push_back({"intrinsics.fy", k});
  cases.back().k.fy = std::nan("");
  cases.push_back({"intrinsics.cx", k});
  cases.back().k.cx = INFINITY;
  cases.push_back({"intrinsics.cy", k});
  cases.back().k.cy = std::nan("");
  for (const Case& c : cases) {
    error.clear();
    EXPECT_FALSE(renderer.render(pose, c.k, 0, *frame, &error)) << c.field;
    EXPECT_NE(error.find(c.field), std::string::npos) << error;
    EXPECT_EQ(frame->depth_m[0], -7.0f) << "frame touched on error";
  }
  Eigen::Isometry3d bad = pose;
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(renderer.render(bad, k, 0, *frame, &error));
  EXPECT_NE(error.find("world_T_camera"), std::string::npos) << error;
  bad = pose;
  bad.linear() *= 2.0;
  EXPECT_FALSE(renderer.render(bad, k, 0, *frame, &error));
  bad = pose;
  bad.linear().col(0) *= -1.0;  // a reflection
  EXPECT_FALSE(renderer.render(bad, k, 0, *frame, &error));
  EXPECT_EQ(renderer.counters().rejected_frames, cases.size() + 3);
  EXPECT_EQ(frame->depth_m[0], -7.0f);
  EXPECT_TRUE(renderer.render(pose, k, 0, *frame, &error)) << error;
}

TEST(Renderer, InitRejectsBadConfigAndWorlds) {
  Renderer renderer;
  std::string error;
  world::World good;
  add_floor(good);
  Renderer::Config config;
  config.max_range_m = 0.05;
  EXPECT_FALSE(renderer.init(config, good, &error));
  EXPECT_NE(error.find("max_range_m"), std::string::npos) << error;
  config = {};
  config.noise.enabled = true;
  config.noise.sigma_base_m = -1.0;
  EXPECT_FALSE(renderer.init(config, good, &error));
  EXPECT_NE(error.find("sigma_base_m"), std::string::npos) << error;
  config.noise.sigma_base_m = 0.001;
  config.noise.grazing_start_deg = 89.0;
  config.noise.grazing_full_deg = 80.0;
  EXPECT_FALSE(renderer.init(config, good, &error));
  EXPECT_NE(error.find("grazing"), std::string::npos) << error;

  struct Case {
    const char* expect;
    world::World world;
  };
  std::vector<Case> cases;
  auto add_case = [&](const char* expect) -> world::World& {
    cases.push_back({expect, world::World{}});
    cases.back().world.name = "bad";
    add_floor(cases.back().world);
    return cases.back().world;
  };
  add_case("shapes[1] (prism 0): polygon_m").add_prism(prism({{0.0, 0.0}, {1.0, 0.0}}, 0.0, 1.0), mat(sem::kWall));
  add_case("not simple")
      .add_prism(prism({{0.0, 0.0}, {1.0, 1.0}, {1.0, 0.0}, {0.0, 1.5}}, 0.0, 1.0), mat(sem::kWall));  // bow tie
  add_case("zero area").add_prism(prism({{0.0, 0.0}, {1.0, 1.0}, {2.0, 2.0}}, 0.0, 1.0), mat(sem::kWall));
  add_case("z_min_m").add_prism(prism({{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}}, 1.0, 1.0), mat(sem::kWall));
  add_case("not finite").add_prism(prism({{0.0, 0.0}, {1.0, NAN}, {1.0, 1.0}}, 0.0, 1.0), mat(sem::kWall));
  add_case("radius_m").add_cylinder(world::CylinderShape{{0.0, 0.0, 0.0}, -0.2, 1.0}, mat(sem::kPlant));
  add_case("height_m").add_cylinder(world::CylinderShape{{0.0, 0.0, 0.0}, 0.2, 0.0}, mat(sem::kPlant));
  add_case("half_extents_m").add_box(box({0.0, 0.0, 0.0}, {0.5, 0.0, 0.5}), mat(sem::kTable));
  add_case("world_R_box")
      .add_box(box({0.0, 0.0, 0.0}, {0.5, 0.5, 0.5}, Eigen::Quaterniond(0, 0, 0, 0)), mat(sem::kTable));
  add_case("center_m").add_box(box({0.0, INFINITY, 0.0}, {0.5, 0.5, 0.5}), mat(sem::kTable));
  add_case("texture_scale_m").add_box(box({0.0, 0.0, 0.0}, {0.5, 0.5, 0.5}), [] {
    world::Material m = mat(sem::kTable, world::Texture::kNoise);
    m.texture_scale_m = 0.0f;
    return m;
  }());
  add_case("normal").add_plane(world::PlaneShape{{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}}, mat(sem::kFloor));
  {
    world::World& w = add_case("index out of range");
    w.add_box(box({0.0, 0.0, 0.0}, {0.5, 0.5, 0.5}), mat(sem::kTable));
    w.shapes.back().index = 5;
  }
  for (const Case& c : cases) {
    error.clear();
    EXPECT_FALSE(renderer.init({}, c.world, &error)) << c.expect;
    EXPECT_NE(error.find(c.expect), std::string::npos) << error;
    EXPECT_NE(error.find("world 'bad'"), std::string::npos) << error;
    EXPECT_FALSE(renderer.render(Eigen::Isometry3d::Identity(), make_intrinsics(4, 3), 0, *make_frame(), &error));
  }
}

TEST(Renderer, NoHeapAllocationPerFrameAfterTheFirst) {
  // A few rooms' worth of every primitive kind, with noise on (the costliest path).
  world::World w = mixed_world();
  for (int i = 0; i < 30; ++i)
    w.add_box(box({1.0 + 0.3 * i, -2.5 + 0.1 * i, 0.3}, {0.1, 0.1, 0.3},
                  Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ()))),
              mat(sem::kChair, world::Texture::kNoise));
  Renderer::Config config;
  config.noise.enabled = true;
  config.noise.dropout_probability = 0.01;
  Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init(config, w, &error)) << error;
  auto frame = make_frame();
  const CameraIntrinsics k = make_intrinsics(160, 120);
  const Eigen::Isometry3d pose = look_at({0.0, 0.0, 1.2}, {5.0, 0.0, 0.5});
  ASSERT_TRUE(renderer.render(pose, k, 0, *frame, &error)) << error;
  bool ok = false;
  EXPECT_NO_ALLOCATIONS(ok = renderer.render(pose, k, 1, *frame, &error));
  EXPECT_TRUE(ok) << error;
  const Eigen::Isometry3d other = look_at({6.5, 2.5, 1.0}, {2.0, -1.0, 0.3});
  EXPECT_NO_ALLOCATIONS(ok = renderer.render(other, make_intrinsics(64, 48), 2, *frame, &error));
  EXPECT_TRUE(ok) << error;
}

}  // namespace
}  // namespace qsg::render

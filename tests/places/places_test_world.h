// Synthetic inputs for the places tests: box-room worlds with known geometry, rendered by the simulated camera
// from a few poses and integrated into a small semantic TSDF.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/reconstruction/semantic_tsdf.h"
#include "drivers/render/renderer.h"
#include "drivers/sim/exploration.h"
#include "drivers/world/world.h"

namespace qsg::places::testing {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHeight = 2.5;  // floor at z = 0, ceiling at 2.5
constexpr double kWall = 0.1;

inline void add_box(world::World* w, const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m,
                    semantics::Label label = semantics::kWall) {
  world::BoxShape b;
  b.center_m = 0.5 * (min_m + max_m);
  b.half_extents_m = 0.5 * (max_m - min_m);
  world::Material m;
  m.label = label;
  w->add_box(b, m);
}

// Rooms side by side along x, each interior [x0, x0 + width] x [0, depth] x [0, kHeight], separated by walls of
// thickness kWall; with a door (0.9 m wide, 2 m high) in each separating wall when `doors`.
inline world::World rooms_world(const std::vector<double>& widths, double depth, bool doors) {
  world::World w;
  w.name = "rooms";
  double total = 0.0;
  for (double width : widths) total += width;
  total += kWall * static_cast<double>(widths.size() - 1);
  add_box(&w, {-kWall, -kWall, -kWall}, {total + kWall, depth + kWall, 0.0}, semantics::kFloor);
  add_box(&w, {-kWall, -kWall, kHeight}, {total + kWall, depth + kWall, kHeight + kWall}, semantics::kCeiling);
  add_box(&w, {-kWall, -kWall, 0.0}, {0.0, depth + kWall, kHeight});
  add_box(&w, {total, -kWall, 0.0}, {total + kWall, depth + kWall, kHeight});
  add_box(&w, {0.0, -kWall, 0.0}, {total, 0.0, kHeight});
  add_box(&w, {0.0, depth, 0.0}, {total, depth + kWall, kHeight});
  double x = 0.0;
  for (std::size_t i = 0; i + 1 < widths.size(); ++i) {
    x += widths[i];
    if (doors) {
      const double y0 = 0.5 * depth - 0.45, y1 = 0.5 * depth + 0.45;
      add_box(&w, {x, 0.0, 0.0}, {x + kWall, y0, kHeight});
      add_box(&w, {x, y1, 0.0}, {x + kWall, depth, kHeight});
      add_box(&w, {x, y0, 2.0}, {x + kWall, y1, kHeight});
    } else {
      add_box(&w, {x, 0.0, 0.0}, {x + kWall, depth, kHeight});
    }
    x += kWall;
  }
  return w;
}

inline Eigen::Isometry3d camera_pose(const Eigen::Vector3d& p, double yaw, double pitch) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix() *
               sim::body_R_optical();
  T.translation() = p;
  return T;
}

inline reconstruction::Capacities small_tsdf_capacities() {
  reconstruction::Capacities caps;
  caps.max_blocks = 768;
  caps.mesh_vertices = 1 << 17;
  caps.mesh_triangles = 1 << 18;
  caps.archive_vertices = 1 << 12;
  caps.archive_triangles = 1 << 13;
  return caps;
}

// Renders a spin (8 yaws x 3 pitches, 160 x 120, 77 x 62 degrees: the whole sphere but the poles) at a
// viewpoint and integrates it.
class Scanner {
 public:
  // `render` sets the renderer (depth noise and its seed; exact depth by default).
  bool init(const world::World& w, double max_weight, std::string* error,
            const render::Renderer::Config& render = render::Renderer::Config{}) {
    render_config_ = render;
    if (!set_world(w, error)) return false;
    reconstruction::Config config;
    config.max_weight = max_weight;
    config.integrate_labels = false;
    const reconstruction::Capacities caps = small_tsdf_capacities();
    tsdf_ = std::make_unique<reconstruction::SemanticTsdf>();
    if (!tsdf_->init(config, caps, reconstruction::SemanticTsdf::plan(caps).total_bytes(), error)) return false;
    frame_ = std::make_unique<messages::RgbdFrame>();
    frame_->depth_scale_m = 0.0f;
    return true;
  }
  // Re-renders with another world (same TSDF): a changed scene.
  bool set_world(const world::World& w, std::string* error) {
    renderer_ = std::make_unique<render::Renderer>();
    return renderer_->init(render_config_, w, error);
  }
  // after_frame(camera position) runs after each integrated frame (the places update of a keyframe).
  using Hook = std::function<void(const Eigen::Vector3d&)>;
  bool spin(const Eigen::Vector3d& position_m, int yaws = 8, const Hook& after_frame = Hook()) {
    return spin_at_pitches(position_m, yaws, {-1.0, 0.0, 1.0}, after_frame);
  }
  // The same at the given pitches only (e.g. {0.0}: a level camera that never sees the floor beneath it or the
  // ceiling above it).
  bool spin_at_pitches(const Eigen::Vector3d& position_m, int yaws, const std::vector<double>& pitches,
                       const Hook& after_frame = Hook()) {
    const messages::CameraIntrinsics camera{160, 120, 100.0, 100.0, 79.5, 59.5};
    std::string error;
    for (double pitch : pitches)
      for (int k = 0; k < yaws; ++k) {
        const Eigen::Isometry3d T = camera_pose(position_m, 2 * kPi * k / yaws, pitch);
        if (!renderer_->render(T, camera, seq_++, *frame_, &error)) return false;
        Eigen::Isometry3d estimate = T;
        estimate.translation() += pose_error_m_;
        if (!tsdf_->process(*frame_, estimate)) return false;
        if (after_frame) after_frame(position_m + pose_error_m_);
      }
    return true;
  }
  // Frames are rendered at the true pose and integrated at the true pose plus this offset (an odometry error).
  void set_pose_error(const Eigen::Vector3d& error_m) { pose_error_m_ = error_m; }
  reconstruction::SemanticTsdf& tsdf() { return *tsdf_; }
  messages::RgbdFrame& frame() { return *frame_; }

 private:
  render::Renderer::Config render_config_;
  std::unique_ptr<render::Renderer> renderer_;
  std::unique_ptr<reconstruction::SemanticTsdf> tsdf_;
  std::unique_ptr<messages::RgbdFrame> frame_;
  std::uint64_t seq_ = 0;
  Eigen::Vector3d pose_error_m_ = Eigen::Vector3d::Zero();
};

}  // namespace qsg::places::testing

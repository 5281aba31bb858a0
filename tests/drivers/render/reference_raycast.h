// Slow, obviously-correct ray casting used as the renderer's test oracle: every shape is tested face by face in
// world coordinates (planes plus point-in-face checks, the prism on its original outline), no BVH, no convex
// splitting, no tricks shared with drivers/render.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>

#include "core/messages/sensor_types.h"
#include "drivers/world/world.h"

namespace qsg::render::testing {

struct ReferenceHit {
  double t = std::numeric_limits<double>::infinity();
  int shape = -1;                                             // index into World::shapes, -1 = none
  double second_t = std::numeric_limits<double>::infinity();  // nearest crossing of any other shape
};

// Nearest crossing with t in [t_min, t_max] over all shapes of the world.
ReferenceHit reference_raycast(const world::World& world, const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& direction, double t_min, double t_max);

// Nearest crossing of one shape with t >= t_min (infinity when none).
double reference_shape_t(const world::World& world, std::size_t shape, const Eigen::Vector3d& origin,
                         const Eigen::Vector3d& direction, double t_min);

// Direction of pixel (u, v) in the world with unit optical-axis component (so t is the z-depth).
Eigen::Vector3d pixel_direction(const Eigen::Isometry3d& world_T_camera, const messages::CameraIntrinsics& k, int u,
                                int v);

// Camera at `position_m` looking along `forward` (not vertical unless up_hint says otherwise), optical frame.
Eigen::Isometry3d look_at(const Eigen::Vector3d& position_m, const Eigen::Vector3d& target_m,
                          const Eigen::Vector3d& up_hint = Eigen::Vector3d::UnitZ());

messages::CameraIntrinsics make_intrinsics(int width, int height, double fov_x_deg = 70.0);

}  // namespace qsg::render::testing

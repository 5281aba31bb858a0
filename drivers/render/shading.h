// Colour of a surface point: the material colour times a world-space texture pattern (so images carry visual
// features) times simple Lambertian shading. Pure functions of the point, normal and view, hence deterministic.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "drivers/world/world.h"

namespace qsg::render {

// Pattern brightness in [0.45, 1] at a surface point, in the surface's two tangent coordinates (the world axes
// other than the normal's dominant one) at a period of scale_m. kPlain gives 1.
float texture_factor(world::Texture texture, float scale_m, const Eigen::Vector3d& point_m,
                     const Eigen::Vector3d& normal);

// Light in [0.25, 1]: ambient, a fixed "sun" direction and a head light, two-sided.
float lambert_factor(const Eigen::Vector3d& normal, const Eigen::Vector3d& view_dir_unit);

void shade(const world::Material& material, const Eigen::Vector3d& point_m, const Eigen::Vector3d& normal,
           const Eigen::Vector3d& view_dir_unit, std::uint8_t rgb[3]);

}  // namespace qsg::render

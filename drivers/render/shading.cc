// Procedural textures and Lambertian shading (see shading.h).
#include "drivers/render/shading.h"

#include <algorithm>
#include <cmath>

namespace qsg::render {
namespace {

// Lattice value in [0, 1) for integer cell (i, j) on the tangent plane of `axis`.
// A cheap 32-bit integer hash is plenty for a texture (four of these per octave per pixel).
float lattice(std::int64_t i, std::int64_t j, int axis) {
  std::uint32_t h = static_cast<std::uint32_t>(i) * 0x8DA6B343u ^ static_cast<std::uint32_t>(j) * 0xD8163841u ^
                    static_cast<std::uint32_t>(axis + 1) * 0xCB1AB31Fu;
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return static_cast<float>(h >> 8) * (1.0f / 16777216.0f);
}

// Smoothly interpolated value noise in [0, 1).
float value_noise(double u, double v, int axis) {
  const double fu = std::floor(u), fv = std::floor(v);
  const auto i = static_cast<std::int64_t>(fu);
  const auto j = static_cast<std::int64_t>(fv);
  float su = static_cast<float>(u - fu), sv = static_cast<float>(v - fv);
  su = su * su * (3.0f - 2.0f * su);
  sv = sv * sv * (3.0f - 2.0f * sv);
  const float a = lattice(i, j, axis), b = lattice(i + 1, j, axis);
  const float c = lattice(i, j + 1, axis), d = lattice(i + 1, j + 1, axis);
  const float top = a + (b - a) * su;
  const float bottom = c + (d - c) * su;
  return top + (bottom - top) * sv;
}

}  // namespace

float texture_factor(world::Texture texture, float scale_m, const Eigen::Vector3d& point_m,
                     const Eigen::Vector3d& normal) {
  if (texture == world::Texture::kPlain) return 1.0f;
  // Tangent coordinates: drop the dominant normal axis so the pattern does not flicker with the hit point's
  // rounding across the surface plane.
  const Eigen::Vector3d an = normal.cwiseAbs();
  const int axis = an.x() >= an.y() ? (an.x() >= an.z() ? 0 : 2) : (an.y() >= an.z() ? 1 : 2);
  const double inv_scale = 1.0 / static_cast<double>(scale_m);
  // Walls (normal x or y) use (horizontal, z); floors use (x, y).
  const double u = point_m[axis == 0 ? 1 : 0] * inv_scale;
  const double v = point_m[axis == 2 ? 1 : 2] * inv_scale;
  switch (texture) {
    case world::Texture::kChecker: {
      // A cell is half a period wide, so one period holds a light and a dark cell.
      const auto cu = static_cast<std::int64_t>(std::floor(2.0 * u));
      const auto cv = static_cast<std::int64_t>(std::floor(2.0 * v));
      return ((cu + cv) & 1) ? 0.5f : 1.0f;
    }
    case world::Texture::kStripes: {
      const auto cu = static_cast<std::int64_t>(std::floor(2.0 * u));
      return (cu & 1) ? 0.55f : 1.0f;
    }
    case world::Texture::kNoise: {
      // Two octaves of value noise: blotches at the texture period with finer grain on top.
      const float n = 0.65f * value_noise(u, v, axis) + 0.35f * value_noise(3.0 * u + 17.0, 3.0 * v + 29.0, axis);
      return 0.45f + 0.55f * n;
    }
    case world::Texture::kPlain:
      break;
  }
  return 1.0f;
}

float lambert_factor(const Eigen::Vector3d& normal, const Eigen::Vector3d& view_dir_unit) {
  // Fixed sun direction (unit): from above, slightly oblique so walls facing different ways differ.
  static const Eigen::Vector3d kSun = Eigen::Vector3d(0.35, 0.55, 0.76).normalized();
  const double sun = std::fabs(normal.dot(kSun));
  const double head = std::fabs(normal.dot(view_dir_unit));
  return static_cast<float>(0.25 + 0.45 * sun + 0.30 * head);
}

void shade(const world::Material& material, const Eigen::Vector3d& point_m, const Eigen::Vector3d& normal,
           const Eigen::Vector3d& view_dir_unit, std::uint8_t rgb[3]) {
  const float f = texture_factor(material.texture, material.texture_scale_m, point_m, normal) *
                  lambert_factor(normal, view_dir_unit);
  for (int c = 0; c < 3; ++c) {
    const float v = static_cast<float>(material.color[c]) * f + 0.5f;
    rgb[c] = static_cast<std::uint8_t>(std::min(255.0f, std::max(0.0f, v)));
  }
}

}  // namespace qsg::render

// Geometry helpers for building worlds: interval and rectangle subtraction, box constructors, walls with door gaps.
#include "drivers/world/world_geometry.h"

#include <algorithm>
#include <cmath>

namespace qsg::world {

std::vector<Interval> subtract_intervals(const Interval& base, std::vector<Interval> gaps, double min_length_m) {
  std::sort(gaps.begin(), gaps.end(), [](const Interval& a, const Interval& b) { return a.lo < b.lo; });
  std::vector<Interval> out;
  double cursor = base.lo;
  for (const Interval& g : gaps) {
    if (g.hi <= cursor || g.lo >= base.hi) continue;
    if (g.lo > cursor && g.lo - cursor > min_length_m) out.push_back({cursor, std::min(g.lo, base.hi)});
    cursor = std::max(cursor, g.hi);
    if (cursor >= base.hi) break;
  }
  if (base.hi - cursor > min_length_m) out.push_back({cursor, base.hi});
  return out;
}

std::vector<Rect> subtract_rect(const Rect& r, const Rect& hole) {
  const Rect h{std::max(r.x0, hole.x0), std::max(r.y0, hole.y0), std::min(r.x1, hole.x1), std::min(r.y1, hole.y1)};
  if (h.x0 >= h.x1 || h.y0 >= h.y1) return {r};
  std::vector<Rect> out;
  if (h.y0 > r.y0) out.push_back({r.x0, r.y0, r.x1, h.y0});
  if (h.y1 < r.y1) out.push_back({r.x0, h.y1, r.x1, r.y1});
  if (h.x0 > r.x0) out.push_back({r.x0, h.y0, h.x0, h.y1});
  if (h.x1 < r.x1) out.push_back({h.x1, h.y0, r.x1, h.y1});
  return out;
}

Eigen::Vector3d rotate(const Eigen::Matrix3d& R, const Eigen::Vector3d& v) {
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) out(i) = (R(i, 0) * v.x() + R(i, 1) * v.y()) + R(i, 2) * v.z();
  return out;
}

Eigen::Vector2d rotate_yaw(double yaw_rad, const Eigen::Vector2d& v) {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  return Eigen::Vector2d(c * v.x() - s * v.y(), s * v.x() + c * v.y());
}

BoxShape axis_box(double x0, double y0, double z0, double x1, double y1, double z1) {
  BoxShape b;
  b.center_m = Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1));
  b.half_extents_m = Eigen::Vector3d(0.5 * std::abs(x1 - x0), 0.5 * std::abs(y1 - y0), 0.5 * std::abs(z1 - z0));
  return b;
}

Eigen::Quaterniond yaw_rotation(double yaw_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
}

BoxShape yaw_box(const Eigen::Vector3d& center_m, const Eigen::Vector3d& size_m, double yaw_rad) {
  BoxShape b;
  b.center_m = center_m;
  b.half_extents_m = 0.5 * size_m;
  b.world_R_box = yaw_rotation(yaw_rad);
  return b;
}

void add_wall_with_gaps(World& world, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double thickness_m,
                        double offset_m, double z0_m, double z1_m, const std::vector<Interval>& gaps,
                        double gap_top_z_m, const Material& material, std::int32_t room_id) {
  const double length = (to - from).norm();
  if (length <= 1e-9 || thickness_m <= 0.0 || z1_m <= z0_m) return;
  const Eigen::Vector2d dir = (to - from) / length;
  const Eigen::Vector2d left(-dir.y(), dir.x());
  const bool along_x = dir.y() == 0.0, along_y = dir.x() == 0.0;
  auto emit = [&](double s0, double s1, double za, double zb) {
    if (s1 - s0 <= 1e-6 || zb - za <= 1e-6) return;
    const Eigen::Vector2d a = from + dir * s0 + left * offset_m, b = from + dir * s1 + left * offset_m;
    const double ht = 0.5 * thickness_m;
    // Axis-aligned walls keep an identity rotation so they stay exactly axis-aligned downstream.
    if (along_x) {
      world.add_box(axis_box(std::min(a.x(), b.x()), a.y() - ht, za, std::max(a.x(), b.x()), a.y() + ht, zb), material,
                    -1, room_id);
    } else if (along_y) {
      world.add_box(axis_box(a.x() - ht, std::min(a.y(), b.y()), za, a.x() + ht, std::max(a.y(), b.y()), zb), material,
                    -1, room_id);
    } else {
      const Eigen::Vector2d c = 0.5 * (a + b);
      world.add_box(yaw_box(Eigen::Vector3d(c.x(), c.y(), 0.5 * (za + zb)),
                            Eigen::Vector3d(s1 - s0, thickness_m, zb - za), std::atan2(dir.y(), dir.x())),
                    material, -1, room_id);
    }
  };
  std::vector<Interval> clipped;
  for (const Interval& g : gaps) {
    const Interval c{std::max(g.lo, 0.0), std::min(g.hi, length)};
    if (c.hi > c.lo) clipped.push_back(c);
  }
  for (const Interval& piece : subtract_intervals({0.0, length}, clipped)) emit(piece.lo, piece.hi, z0_m, z1_m);
  if (gap_top_z_m < z1_m)
    for (const Interval& g : clipped) emit(g.lo, g.hi, std::max(gap_top_z_m, z0_m), z1_m);
}

}  // namespace qsg::world

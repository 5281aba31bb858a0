// Small building blocks shared by the world sources: a portable seeded random generator, axis-aligned rectangles
// and intervals, and a wall builder that leaves gaps (with lintels) where doors are.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "drivers/world/world.h"

namespace qsg::world {

// SplitMix64: the same sequence on every compiler and platform (std:: distributions are implementation-defined).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int uniform_int(int lo, int hi) {  // inclusive
    return hi <= lo ? lo : lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }
  // A child generator whose sequence does not depend on how many draws the parent makes later.
  Rng fork(std::uint64_t salt) { return Rng(next() ^ (salt * 0xD1B54A32D192ED03ull)); }

 private:
  std::uint64_t state_;
};

struct Interval {
  double lo = 0.0, hi = 0.0;
  double length() const { return hi - lo; }
};

// base minus the union of gaps, as sorted pieces longer than min_length_m.
std::vector<Interval> subtract_intervals(const Interval& base, std::vector<Interval> gaps, double min_length_m = 1e-6);

struct Rect {
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
  double width() const { return x1 - x0; }
  double height() const { return y1 - y0; }
  bool contains(const Eigen::Vector2d& p, double margin = 0.0) const {
    return p.x() >= x0 + margin && p.x() <= x1 - margin && p.y() >= y0 + margin && p.y() <= y1 - margin;
  }
  Polygon2 polygon() const { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }  // counter-clockwise
};

// r minus hole as up to four rectangles (strips below, above, left, right of the hole).
std::vector<Rect> subtract_rect(const Rect& r, const Rect& hole);

// Rotations written out in scalar code with a fixed summation order. Eigen's products differ in the last bit
// between versions (3.3 vs 3.4) and between SIMD back ends (NEON fuses multiply-adds), and a last-bit difference
// can flip a placement test, so the world generator uses these to build the same world on every platform.
Eigen::Vector3d rotate(const Eigen::Matrix3d& R, const Eigen::Vector3d& v);
Eigen::Vector2d rotate_yaw(double yaw_rad, const Eigen::Vector2d& v);

BoxShape axis_box(double x0, double y0, double z0, double x1, double y1, double z1);
BoxShape yaw_box(const Eigen::Vector3d& center_m, const Eigen::Vector3d& size_m, double yaw_rad);
Eigen::Quaterniond yaw_rotation(double yaw_rad);

// A straight wall from `from` to `to` (x-y), `thickness_m` thick, its centre line shifted sideways by offset_m
// (positive to the left of from->to), spanning [z0, z1]. gaps are intervals of distance along the wall; over a gap
// the wall is replaced by a lintel from gap_top_z_m to z1 (none when gap_top_z_m >= z1).
void add_wall_with_gaps(World& world, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double thickness_m,
                        double offset_m, double z0_m, double z1_m, const std::vector<Interval>& gaps,
                        double gap_top_z_m, const Material& material, std::int32_t room_id);

}  // namespace qsg::world

// Geometric questions about a World that the simulation asks often: bounds, which room a point is in, distance to
// the nearest shape, and a uniform-grid index that answers "is this point free with clearance r" millions of times.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "drivers/world/world.h"

namespace qsg::world {

// Axis-aligned bounds; empty (min > max) until something is added.
struct Aabb {
  Eigen::Vector3d min_m = Eigen::Vector3d::Constant(1e300);
  Eigen::Vector3d max_m = Eigen::Vector3d::Constant(-1e300);

  bool empty() const { return (min_m.array() > max_m.array()).any(); }
  void extend(const Eigen::Vector3d& p) {
    min_m = min_m.cwiseMin(p);
    max_m = max_m.cwiseMax(p);
  }
  void extend(const Aabb& other) {
    if (other.empty()) return;
    extend(other.min_m);
    extend(other.max_m);
  }
  Eigen::Vector3d size_m() const { return empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(max_m - min_m); }
};

// Bounds of one shape; empty for planes (they are infinite).
Aabb shape_bounds(const World& world, const Shape& shape);
// Bounds of every finite shape, room (footprint and height) and door of the world.
Aabb world_bounds(const World& world);

// Even-odd point-in-polygon test in the x-y plane (boundary points may go either way).
bool point_in_polygon(const Polygon2& polygon, const Eigen::Vector2d& p);
// Signed area (positive when counter-clockwise).
double polygon_signed_area(const Polygon2& polygon);

// Id of the room whose footprint contains (x, y) and whose [floor_z, floor_z + height) contains z; -1 when none.
std::int32_t room_at(const World& world, double x_m, double y_m, double z_m);

// Euclidean distance from p to the solid of a shape (0 inside). A plane is the solid half-space behind its
// normal, so a ground plane makes everything below it occupied.
double distance_to_shape(const World& world, const Shape& shape, const Eigen::Vector3d& p_m);

// True when two oriented boxes overlap (separating-axis test); margin_m inflates both boxes.
bool boxes_overlap(const BoxShape& a, const BoxShape& b, double margin_m = 0.0);

// The corners of a box's footprint (x-y) when the box only rotates about z; counter-clockwise.
std::vector<Eigen::Vector2d> box_footprint(const BoxShape& box);

// Uniform grid over the world's shapes: each cell lists the shapes whose bounds, grown by max_clearance_m, touch
// it, so a query with clearance up to max_clearance_m reads one cell. Copies the geometry it needs; the World may
// be destroyed afterwards.
class FreeSpaceIndex {
 public:
  struct Config {
    double cell_size_m = 0.5;
    double max_clearance_m = 0.5;      // queries with larger clearance scan several cells (slower, still correct)
    std::size_t max_cells = 8u << 20;  // cells are enlarged until the grid fits
    void print(std::FILE* out) const;
  };

  FreeSpaceIndex() = default;
  explicit FreeSpaceIndex(const World& world) : FreeSpaceIndex(world, Config()) {}
  FreeSpaceIndex(const World& world, const Config& config);

  // True when no shape's solid comes closer than clearance_m to p (points outside every shape's grown bounds are
  // free unless a plane says otherwise).
  bool is_free(const Eigen::Vector3d& p_m, double clearance_m) const;
  // Distance from p to the nearest shape solid, capped at max_m (returns max_m when nothing is that close).
  double clearance(const Eigen::Vector3d& p_m, double max_m) const;

  const Config& config() const { return config_; }
  const Aabb& grid_bounds() const { return bounds_; }
  Eigen::Vector3i grid_dims() const { return dims_; }
  std::size_t num_entries() const { return entries_.size(); }
  std::size_t num_shapes() const { return solids_.size(); }

 private:
  struct Solid {
    ShapeKind kind = ShapeKind::kBox;
    Eigen::Vector3d center_m = Eigen::Vector3d::Zero();  // box centre, cylinder base, plane point
    Eigen::Matrix3d box_R_world = Eigen::Matrix3d::Identity();
    Eigen::Vector3d half_m = Eigen::Vector3d::Zero();  // box half extents; cylinder (radius, -, height)
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    double z_min_m = 0.0, z_max_m = 0.0;                // prism
    std::uint32_t polygon_begin = 0, polygon_size = 0;  // prism vertices in polygon_m_
  };

  double distance_sq(const Solid& s, const Eigen::Vector3d& p) const;
  bool cell_of(const Eigen::Vector3d& p, Eigen::Vector3i* cell) const;
  std::size_t cell_index(const Eigen::Vector3i& c) const {
    return (static_cast<std::size_t>(c.z()) * dims_.y() + c.y()) * dims_.x() + c.x();
  }

  Config config_;
  Aabb bounds_;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double cell_m_ = 0.5;
  std::vector<Solid> solids_;
  std::vector<Eigen::Vector2d> polygon_m_;
  std::vector<std::uint32_t> planes_;      // solids checked by every query
  std::vector<std::uint32_t> cell_begin_;  // CSR offsets, one more than the number of cells
  std::vector<std::uint32_t> entries_;
};

}  // namespace qsg::world

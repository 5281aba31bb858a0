// World queries: bounds, room lookup, point-to-shape distances and the free-space grid index.
#include "drivers/world/world_query.h"

#include <algorithm>
#include <cmath>

namespace qsg::world {
namespace {

// Scalar arithmetic in a fixed order (no Eigen products): placement decisions built on these tests must come out
// the same with every Eigen version and SIMD back end.
Eigen::Matrix3d rotation_of(const BoxShape& box) {
  const Eigen::Quaterniond& q = box.world_R_box;
  const double n2 = ((q.w() * q.w() + q.x() * q.x()) + q.y() * q.y()) + q.z() * q.z();
  if (std::abs(n2 - 1.0) < 1e-9) return q.toRotationMatrix();
  const double n = std::sqrt(n2);
  return Eigen::Quaterniond(q.w() / n, q.x() / n, q.y() / n, q.z() / n).toRotationMatrix();
}

Aabb box_bounds(const BoxShape& box) {
  const Eigen::Matrix3d R = rotation_of(box);
  const Eigen::Vector3d reach = R.cwiseAbs() * box.half_extents_m;
  Aabb b;
  b.extend(Eigen::Vector3d(box.center_m - reach));
  b.extend(Eigen::Vector3d(box.center_m + reach));
  return b;
}

double segment_distance_sq(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  const Eigen::Vector2d ab = b - a;
  const double len_sq = ab.squaredNorm();
  double t = len_sq > 0.0 ? (p - a).dot(ab) / len_sq : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (a + t * ab - p).squaredNorm();
}

bool point_in_ring(const Eigen::Vector2d* v, std::size_t n, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const bool crosses = (v[i].y() > p.y()) != (v[j].y() > p.y());
    if (crosses && p.x() < (v[j].x() - v[i].x()) * (p.y() - v[i].y()) / (v[j].y() - v[i].y()) + v[i].x())
      inside = !inside;
  }
  return inside;
}

// 2D distance squared from p to a polygon's area (0 inside).
double polygon_distance_sq(const Eigen::Vector2d* v, std::size_t n, const Eigen::Vector2d& p) {
  if (n == 0) return 1e300;
  if (n >= 3 && point_in_ring(v, n, p)) return 0.0;
  double best = 1e300;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) best = std::min(best, segment_distance_sq(v[j], v[i], p));
  return best;
}

}  // namespace

Aabb shape_bounds(const World& world, const Shape& shape) {
  Aabb b;
  switch (shape.kind) {
    case ShapeKind::kBox:
      if (shape.index < world.boxes.size()) return box_bounds(world.boxes[shape.index]);
      break;
    case ShapeKind::kCylinder:
      if (shape.index < world.cylinders.size()) {
        const CylinderShape& c = world.cylinders[shape.index];
        b.extend(c.base_center_m - Eigen::Vector3d(c.radius_m, c.radius_m, 0.0));
        b.extend(c.base_center_m + Eigen::Vector3d(c.radius_m, c.radius_m, c.height_m));
      }
      break;
    case ShapeKind::kPrism:
      if (shape.index < world.prisms.size()) {
        const PrismShape& p = world.prisms[shape.index];
        for (const Eigen::Vector2d& v : p.polygon_m) {
          b.extend(Eigen::Vector3d(v.x(), v.y(), p.z_min_m));
          b.extend(Eigen::Vector3d(v.x(), v.y(), p.z_max_m));
        }
      }
      break;
    case ShapeKind::kPlane: break;
  }
  return b;
}

Aabb world_bounds(const World& world) {
  Aabb b;
  for (const Shape& s : world.shapes) b.extend(shape_bounds(world, s));
  for (const Room& r : world.rooms)
    for (const Polygon2& poly : r.footprint_m)
      for (const Eigen::Vector2d& v : poly) {
        b.extend(Eigen::Vector3d(v.x(), v.y(), r.floor_z_m));
        b.extend(Eigen::Vector3d(v.x(), v.y(), r.floor_z_m + r.height_m));
      }
  for (const Door& d : world.doors) {
    b.extend(Eigen::Vector3d(d.a_m.x(), d.a_m.y(), d.floor_z_m));
    b.extend(Eigen::Vector3d(d.b_m.x(), d.b_m.y(), d.floor_z_m + d.height_m));
  }
  return b;
}

bool point_in_polygon(const Polygon2& polygon, const Eigen::Vector2d& p) {
  return polygon.size() >= 3 && point_in_ring(polygon.data(), polygon.size(), p);
}

double polygon_signed_area(const Polygon2& polygon) {
  double twice = 0.0;
  for (std::size_t i = 0, j = polygon.size() ? polygon.size() - 1 : 0; i < polygon.size(); j = i++)
    twice += polygon[j].x() * polygon[i].y() - polygon[i].x() * polygon[j].y();
  return 0.5 * twice;
}

std::int32_t room_at(const World& world, double x_m, double y_m, double z_m) {
  const Eigen::Vector2d p(x_m, y_m);
  for (const Room& r : world.rooms) {
    if (z_m < r.floor_z_m || z_m >= r.floor_z_m + r.height_m) continue;
    for (const Polygon2& poly : r.footprint_m)
      if (point_in_polygon(poly, p)) return r.id;
  }
  return -1;
}

double distance_to_shape(const World& world, const Shape& shape, const Eigen::Vector3d& p) {
  switch (shape.kind) {
    case ShapeKind::kBox: {
      if (shape.index >= world.boxes.size()) break;
      const BoxShape& b = world.boxes[shape.index];
      const Eigen::Vector3d q = rotation_of(b).transpose() * (p - b.center_m);
      return (q.cwiseAbs() - b.half_extents_m).cwiseMax(0.0).norm();
    }
    case ShapeKind::kCylinder: {
      if (shape.index >= world.cylinders.size()) break;
      const CylinderShape& c = world.cylinders[shape.index];
      const double dr = std::max((p - c.base_center_m).head<2>().norm() - c.radius_m, 0.0);
      const double dz = std::max({c.base_center_m.z() - p.z(), p.z() - c.base_center_m.z() - c.height_m, 0.0});
      return std::hypot(dr, dz);
    }
    case ShapeKind::kPrism: {
      if (shape.index >= world.prisms.size()) break;
      const PrismShape& pr = world.prisms[shape.index];
      const double d2 = polygon_distance_sq(pr.polygon_m.data(), pr.polygon_m.size(), p.head<2>());
      const double dz = std::max({pr.z_min_m - p.z(), p.z() - pr.z_max_m, 0.0});
      return std::sqrt(d2 + dz * dz);
    }
    case ShapeKind::kPlane: {
      if (shape.index >= world.planes.size()) break;
      const PlaneShape& pl = world.planes[shape.index];
      return std::max((p - pl.point_m).dot(pl.normal.normalized()), 0.0);
    }
  }
  return 1e300;
}

bool boxes_overlap(const BoxShape& a, const BoxShape& b, double margin_m) {
  const Eigen::Matrix3d Ra = rotation_of(a), Rb = rotation_of(b);
  double ha[3], hb[3], t[3], R[3][3], absR[3][3];
  for (int i = 0; i < 3; ++i) {
    ha[i] = a.half_extents_m(i) + margin_m;
    hb[i] = b.half_extents_m(i) + margin_m;
  }
  const double d[3] = {b.center_m.x() - a.center_m.x(), b.center_m.y() - a.center_m.y(),
                       b.center_m.z() - a.center_m.z()};
  // R: b's axes in a's frame; t: b's centre in a's frame. The epsilon keeps parallel edges from false axes.
  for (int i = 0; i < 3; ++i) {
    t[i] = (Ra(0, i) * d[0] + Ra(1, i) * d[1]) + Ra(2, i) * d[2];
    for (int j = 0; j < 3; ++j) {
      R[i][j] = (Ra(0, i) * Rb(0, j) + Ra(1, i) * Rb(1, j)) + Ra(2, i) * Rb(2, j);
      absR[i][j] = std::abs(R[i][j]) + 1e-12;
    }
  }
  for (int i = 0; i < 3; ++i)
    if (std::abs(t[i]) > ha[i] + ((absR[i][0] * hb[0] + absR[i][1] * hb[1]) + absR[i][2] * hb[2])) return false;
  for (int j = 0; j < 3; ++j) {
    const double tj = (t[0] * R[0][j] + t[1] * R[1][j]) + t[2] * R[2][j];
    if (std::abs(tj) > ((absR[0][j] * ha[0] + absR[1][j] * ha[1]) + absR[2][j] * ha[2]) + hb[j]) return false;
  }
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double ra = ha[i1] * absR[i2][j] + ha[i2] * absR[i1][j];
      const double rb = hb[j1] * absR[i][j2] + hb[j2] * absR[i][j1];
      if (std::abs(t[i2] * R[i1][j] - t[i1] * R[i2][j]) > ra + rb) return false;
    }
  }
  return true;
}

std::vector<Eigen::Vector2d> box_footprint(const BoxShape& box) {
  const Eigen::Matrix3d R = rotation_of(box);
  const Eigen::Vector2d ax = R.col(0).head<2>() * box.half_extents_m.x();
  const Eigen::Vector2d ay = R.col(1).head<2>() * box.half_extents_m.y();
  const Eigen::Vector2d c = box.center_m.head<2>();
  return {c - ax - ay, c + ax - ay, c + ax + ay, c - ax + ay};
}

// ---- FreeSpaceIndex ----

void FreeSpaceIndex::Config::print(std::FILE* out) const {
  std::fprintf(out, "FreeSpaceIndex: cell_size_m=%.3f max_clearance_m=%.3f max_cells=%zu\n", cell_size_m,
               max_clearance_m, max_cells);
}

FreeSpaceIndex::FreeSpaceIndex(const World& world, const Config& config) : config_(config) {
  config_.cell_size_m = std::max(config_.cell_size_m, 0.01);
  config_.max_clearance_m = std::max(config_.max_clearance_m, 0.0);
  std::vector<Aabb> shape_box;
  for (const Shape& shape : world.shapes) {
    Solid s;
    s.kind = shape.kind;
    bool valid = false;
    switch (shape.kind) {
      case ShapeKind::kBox:
        if (shape.index < world.boxes.size()) {
          const BoxShape& b = world.boxes[shape.index];
          s.center_m = b.center_m;
          s.box_R_world = rotation_of(b).transpose();
          s.half_m = b.half_extents_m;
          valid = true;
        }
        break;
      case ShapeKind::kCylinder:
        if (shape.index < world.cylinders.size()) {
          const CylinderShape& c = world.cylinders[shape.index];
          s.center_m = c.base_center_m;
          s.half_m = Eigen::Vector3d(c.radius_m, 0.0, c.height_m);
          valid = true;
        }
        break;
      case ShapeKind::kPrism:
        if (shape.index < world.prisms.size()) {
          const PrismShape& p = world.prisms[shape.index];
          s.z_min_m = p.z_min_m;
          s.z_max_m = p.z_max_m;
          s.polygon_begin = static_cast<std::uint32_t>(polygon_m_.size());
          s.polygon_size = static_cast<std::uint32_t>(p.polygon_m.size());
          polygon_m_.insert(polygon_m_.end(), p.polygon_m.begin(), p.polygon_m.end());
          valid = true;
        }
        break;
      case ShapeKind::kPlane:
        if (shape.index < world.planes.size()) {
          const PlaneShape& p = world.planes[shape.index];
          s.center_m = p.point_m;
          s.normal = p.normal.normalized();
          planes_.push_back(static_cast<std::uint32_t>(solids_.size()));
          valid = true;
        }
        break;
    }
    if (!valid) continue;
    solids_.push_back(s);
    shape_box.push_back(shape_bounds(world, shape));
  }

  for (const Aabb& b : shape_box) bounds_.extend(b);
  if (bounds_.empty()) return;
  bounds_.min_m.array() -= config_.max_clearance_m + 1e-6;
  bounds_.max_m.array() += config_.max_clearance_m + 1e-6;
  cell_m_ = config_.cell_size_m;
  for (;;) {
    const Eigen::Vector3d n = (bounds_.size_m() / cell_m_).array().ceil().cwiseMax(1.0);
    if (n.prod() <= static_cast<double>(std::max<std::size_t>(config_.max_cells, 1))) {
      dims_ = n.cast<int>();
      break;
    }
    cell_m_ *= 1.25;
  }

  // Two passes (count, then fill) give a compact CSR layout.
  const std::size_t num_cells = static_cast<std::size_t>(dims_.prod());
  cell_begin_.assign(num_cells + 1, 0);
  auto for_each_cell = [&](const Aabb& b, auto&& fn) {
    const Eigen::Vector3d lo = (b.min_m.array() - config_.max_clearance_m - bounds_.min_m.array()) / cell_m_;
    const Eigen::Vector3d hi = (b.max_m.array() + config_.max_clearance_m - bounds_.min_m.array()) / cell_m_;
    Eigen::Vector3i c0, c1;
    for (int k = 0; k < 3; ++k) {
      c0(k) = std::clamp(static_cast<int>(std::floor(lo(k))), 0, dims_(k) - 1);
      c1(k) = std::clamp(static_cast<int>(std::floor(hi(k))), 0, dims_(k) - 1);
    }
    for (int z = c0.z(); z <= c1.z(); ++z)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int x = c0.x(); x <= c1.x(); ++x) fn(cell_index(Eigen::Vector3i(x, y, z)));
  };
  for (std::size_t i = 0; i < solids_.size(); ++i)
    if (solids_[i].kind != ShapeKind::kPlane) for_each_cell(shape_box[i], [&](std::size_t c) { ++cell_begin_[c + 1]; });
  for (std::size_t c = 0; c < num_cells; ++c) cell_begin_[c + 1] += cell_begin_[c];
  entries_.assign(cell_begin_[num_cells], 0);
  std::vector<std::uint32_t> fill(cell_begin_.begin(), cell_begin_.end() - 1);
  for (std::size_t i = 0; i < solids_.size(); ++i)
    if (solids_[i].kind != ShapeKind::kPlane)
      for_each_cell(shape_box[i], [&](std::size_t c) { entries_[fill[c]++] = static_cast<std::uint32_t>(i); });
}

double FreeSpaceIndex::distance_sq(const Solid& s, const Eigen::Vector3d& p) const {
  switch (s.kind) {
    case ShapeKind::kBox: {
      const Eigen::Vector3d q = s.box_R_world * (p - s.center_m);
      return (q.cwiseAbs() - s.half_m).cwiseMax(0.0).squaredNorm();
    }
    case ShapeKind::kCylinder: {
      const double dr = std::max((p - s.center_m).head<2>().norm() - s.half_m.x(), 0.0);
      const double dz = std::max({s.center_m.z() - p.z(), p.z() - s.center_m.z() - s.half_m.z(), 0.0});
      return dr * dr + dz * dz;
    }
    case ShapeKind::kPrism: {
      const double dz = std::max({s.z_min_m - p.z(), p.z() - s.z_max_m, 0.0});
      return polygon_distance_sq(polygon_m_.data() + s.polygon_begin, s.polygon_size, p.head<2>()) + dz * dz;
    }
    case ShapeKind::kPlane: {
      const double d = std::max((p - s.center_m).dot(s.normal), 0.0);
      return d * d;
    }
  }
  return 1e300;
}

bool FreeSpaceIndex::cell_of(const Eigen::Vector3d& p, Eigen::Vector3i* cell) const {
  if (dims_.x() == 0) return false;
  for (int k = 0; k < 3; ++k) {
    const double f = std::floor((p(k) - bounds_.min_m(k)) / cell_m_);
    if (!(f >= 0.0 && f < dims_(k))) return false;
    (*cell)(k) = static_cast<int>(f);
  }
  return true;
}

bool FreeSpaceIndex::is_free(const Eigen::Vector3d& p, double clearance_m) const {
  const double r_sq = clearance_m > 0.0 ? clearance_m * clearance_m : 0.0;
  // Inside a solid the distance is exactly 0, so a zero clearance still rejects it.
  auto blocked = [&](const Solid& s) {
    const double d = distance_sq(s, p);
    return clearance_m > 0.0 ? d < r_sq : d <= 0.0;
  };
  for (std::uint32_t i : planes_)
    if (blocked(solids_[i])) return false;
  if (clearance_m <= config_.max_clearance_m) {
    Eigen::Vector3i c;
    if (!cell_of(p, &c)) return true;
    const std::size_t ci = cell_index(c);
    for (std::uint32_t k = cell_begin_[ci]; k < cell_begin_[ci + 1]; ++k)
      if (blocked(solids_[entries_[k]])) return false;
    return true;
  }
  // Larger clearances than the grid was built for: scan every cell the query sphere touches.
  if (dims_.x() == 0) return true;
  Eigen::Vector3i c0, c1;
  for (int k = 0; k < 3; ++k) {
    c0(k) =
        std::clamp(static_cast<int>(std::floor((p(k) - clearance_m - bounds_.min_m(k)) / cell_m_)), 0, dims_(k) - 1);
    c1(k) =
        std::clamp(static_cast<int>(std::floor((p(k) + clearance_m - bounds_.min_m(k)) / cell_m_)), 0, dims_(k) - 1);
  }
  for (int z = c0.z(); z <= c1.z(); ++z)
    for (int y = c0.y(); y <= c1.y(); ++y)
      for (int x = c0.x(); x <= c1.x(); ++x) {
        const std::size_t ci = cell_index(Eigen::Vector3i(x, y, z));
        for (std::uint32_t k = cell_begin_[ci]; k < cell_begin_[ci + 1]; ++k)
          if (blocked(solids_[entries_[k]])) return false;
      }
  return true;
}

double FreeSpaceIndex::clearance(const Eigen::Vector3d& p, double max_m) const {
  double best_sq = max_m * max_m;
  for (std::uint32_t i : planes_) best_sq = std::min(best_sq, distance_sq(solids_[i], p));
  if (dims_.x() > 0) {
    const double reach = std::max(max_m, 0.0);
    Eigen::Vector3i c0, c1;
    for (int k = 0; k < 3; ++k) {
      // Within max_clearance_m one cell suffices; beyond that scan the neighbourhood.
      const double r = reach <= config_.max_clearance_m ? 0.0 : reach;
      c0(k) = static_cast<int>(std::floor((p(k) - r - bounds_.min_m(k)) / cell_m_));
      c1(k) = static_cast<int>(std::floor((p(k) + r - bounds_.min_m(k)) / cell_m_));
      c0(k) = std::max(c0(k), 0);
      c1(k) = std::min(c1(k), dims_(k) - 1);
    }
    for (int z = c0.z(); z <= c1.z(); ++z)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int x = c0.x(); x <= c1.x(); ++x) {
          const std::size_t ci = cell_index(Eigen::Vector3i(x, y, z));
          for (std::uint32_t k = cell_begin_[ci]; k < cell_begin_[ci + 1]; ++k)
            best_sq = std::min(best_sq, distance_sq(solids_[entries_[k]], p));
        }
  }
  return std::sqrt(best_sq);
}

}  // namespace qsg::world

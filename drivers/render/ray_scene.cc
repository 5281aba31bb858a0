// Compiling a World into convex primitives under a BVH, and the exact ray-primitive tests (see ray_scene.h).
#include "drivers/render/ray_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <limits>

#include "drivers/render/convex_decomposition.h"

namespace qsg::render {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  char buffer[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof(buffer), fmt, args);
  va_end(args);
  return buffer;
}

const char* kind_name(world::ShapeKind kind) {
  switch (kind) {
    case world::ShapeKind::kBox:
      return "box";
    case world::ShapeKind::kCylinder:
      return "cylinder";
    case world::ShapeKind::kPrism:
      return "prism";
    case world::ShapeKind::kPlane:
      return "plane";
  }
  return "unknown";
}

// Pads a float box outwards so that float rounding in the traversal never culls a primitive the exact
// double-precision test would hit.
Aabb padded(const double lo[3], const double hi[3]) {
  Aabb box;
  for (int k = 0; k < 3; ++k) {
    const double pad = 1e-5 * std::max({1.0, std::fabs(lo[k]), std::fabs(hi[k])});
    box.min_m[k] = static_cast<float>(lo[k] - pad);
    box.max_m[k] = static_cast<float>(hi[k] + pad);
  }
  return box;
}

}  // namespace

struct RayScene::PrimitiveRay {
  double o[3];
  double d[3];
  double inv[3];
};

void RaySceneStats::print(std::FILE* out) const {
  std::fprintf(out, "ray_scene: shapes=%zu primitives=%zu planes=%zu bvh_nodes=%zu bvh_leaves=%d bvh_depth=%d\n",
               num_shapes, num_primitives, num_planes, num_bvh_nodes, num_bvh_leaves, bvh_depth);
}

bool RayScene::build(const world::World& world, std::string* error) {
  primitives_.clear();
  edges_.clear();
  planes_.clear();
  materials_.clear();
  stats_ = RaySceneStats{};
  built_ = false;

  std::vector<Primitive> prims;
  std::vector<Aabb> boxes;
  std::vector<Polygon2d> pieces;
  std::string why;
  auto fail = [&](std::size_t i, const world::Shape& s, const std::string& what) {
    if (error)
      *error = format("world '%s': shapes[%zu] (%s %u): %s", world.name.c_str(), i, kind_name(s.kind), s.index,
                      what.c_str());
    primitives_.clear();
    edges_.clear();
    planes_.clear();
    materials_.clear();
    return false;
  };

  // A shape's bounds become the BVH's float boxes: beyond kMaxAbsCoordinate_m they overflow or lose the precision
  // the traversal needs (1e308 m made the build divide infinities).
  auto add_bounds = [&](std::size_t i, const world::Shape& s, const double lo[3], const double hi[3]) {
    for (int k = 0; k < 3; ++k)
      if (!(std::fabs(lo[k]) <= kMaxAbsCoordinate_m && std::fabs(hi[k]) <= kMaxAbsCoordinate_m))
        return fail(i, s, format("bounds [%g, %g] m on axis %d exceed the ray scene's limit of +-%g m", lo[k], hi[k], k,
                                 kMaxAbsCoordinate_m));
    boxes.push_back(padded(lo, hi));
    return true;
  };
  for (std::size_t i = 0; i < world.shapes.size(); ++i) {
    const world::Shape& s = world.shapes[i];
    const std::uint32_t shape_id = static_cast<std::uint32_t>(i);
    const world::Material& mat = s.material;
    if (mat.texture != world::Texture::kPlain && !(std::isfinite(mat.texture_scale_m) && mat.texture_scale_m > 0.0f))
      return fail(i, s,
                  format("material.texture_scale_m must be positive and finite (got %g)",
                         static_cast<double>(mat.texture_scale_m)));
    switch (s.kind) {
      case world::ShapeKind::kBox: {
        if (s.index >= world.boxes.size())
          return fail(i, s, format("index out of range (World::boxes has %zu)", world.boxes.size()));
        const world::BoxShape& box = world.boxes[s.index];
        if (!box.center_m.allFinite()) return fail(i, s, "center_m is not finite");
        if (!box.half_extents_m.allFinite() || box.half_extents_m.minCoeff() <= 0.0)
          return fail(i, s,
                      format("half_extents_m must be positive and finite (got %g %g %g)", box.half_extents_m.x(),
                             box.half_extents_m.y(), box.half_extents_m.z()));
        const double qn = box.world_R_box.coeffs().norm();
        if (!std::isfinite(qn) || qn < 1e-9) return fail(i, s, "world_R_box is not a valid quaternion");
        const Eigen::Matrix3d world_R_box = Eigen::Quaterniond(box.world_R_box.coeffs() / qn).toRotationMatrix();
        const Eigen::Vector3d half = world_R_box.cwiseAbs() * box.half_extents_m;
        Primitive p;
        p.shape = shape_id;
        // Boxes whose axes are world axes (in any order) take the cheaper slab test.
        bool axis_aligned = true;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            const double v = std::fabs(world_R_box(r, c));
            if (v > 1e-12 && std::fabs(v - 1.0) > 1e-12) axis_aligned = false;
          }
        if (axis_aligned) {
          p.kind = Kind::kAabb;
          for (int k = 0; k < 3; ++k) {
            p.a[k] = box.center_m[k] - half[k];
            p.b[k] = box.center_m[k] + half[k];
          }
        } else {
          p.kind = Kind::kOrientedBox;
          for (int k = 0; k < 3; ++k) {
            p.a[k] = box.center_m[k];
            p.b[k] = box.half_extents_m[k];
          }
          // Rows of box_R_world = columns of world_R_box.
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) p.m[3 * r + c] = world_R_box(c, r);
        }
        double lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
          lo[k] = box.center_m[k] - half[k];
          hi[k] = box.center_m[k] + half[k];
        }
        prims.push_back(p);
        if (!add_bounds(i, s, lo, hi)) return false;
        break;
      }
      case world::ShapeKind::kCylinder: {
        if (s.index >= world.cylinders.size())
          return fail(i, s, format("index out of range (World::cylinders has %zu)", world.cylinders.size()));
        const world::CylinderShape& c = world.cylinders[s.index];
        if (!c.base_center_m.allFinite()) return fail(i, s, "base_center_m is not finite");
        if (!(std::isfinite(c.radius_m) && c.radius_m > 0.0))
          return fail(i, s, format("radius_m must be positive and finite (got %g)", c.radius_m));
        if (!(std::isfinite(c.height_m) && c.height_m > 0.0))
          return fail(i, s, format("height_m must be positive and finite (got %g)", c.height_m));
        Primitive p;
        p.kind = Kind::kCylinder;
        p.shape = shape_id;
        p.a[0] = c.base_center_m.x();
        p.a[1] = c.base_center_m.y();
        p.a[2] = c.base_center_m.z();
        p.b[0] = c.radius_m;
        p.b[1] = c.radius_m * c.radius_m;
        p.b[2] = c.base_center_m.z() + c.height_m;
        const double lo[3] = {p.a[0] - c.radius_m, p.a[1] - c.radius_m, p.a[2]};
        const double hi[3] = {p.a[0] + c.radius_m, p.a[1] + c.radius_m, p.b[2]};
        prims.push_back(p);
        if (!add_bounds(i, s, lo, hi)) return false;
        break;
      }
      case world::ShapeKind::kPrism: {
        if (s.index >= world.prisms.size())
          return fail(i, s, format("index out of range (World::prisms has %zu)", world.prisms.size()));
        const world::PrismShape& prism = world.prisms[s.index];
        if (!(std::isfinite(prism.z_min_m) && std::isfinite(prism.z_max_m) && prism.z_max_m > prism.z_min_m))
          return fail(i, s, format("needs finite z_min_m < z_max_m (got %g, %g)", prism.z_min_m, prism.z_max_m));
        if (!decompose_convex(prism.polygon_m, &pieces, &why)) return fail(i, s, "polygon_m: " + why);
        // Seams between pieces are pushed out a hair so the pieces overlap: a ray running exactly along a seam
        // (symmetric views do this) would otherwise be judged outside both pieces by rounding and see through.
        double extent = 1.0;
        for (const auto& v : prism.polygon_m) extent = std::max(extent, v.cwiseAbs().maxCoeff());
        const double seam_overlap_m = 1e-9 * extent;
        auto on_outline = [&](const Eigen::Vector2d& q) {
          const std::size_t n = prism.polygon_m.size();
          for (std::size_t k = 0; k < n; ++k) {
            const Eigen::Vector2d& a = prism.polygon_m[k];
            const Eigen::Vector2d& b = prism.polygon_m[(k + 1) % n];
            const Eigen::Vector2d ab = b - a;
            const double len2 = ab.squaredNorm();
            const double f = len2 > 0.0 ? std::max(0.0, std::min(1.0, (q - a).dot(ab) / len2)) : 0.0;
            if ((a + f * ab - q).norm() <= seam_overlap_m) return true;
          }
          return false;
        };
        for (const Polygon2d& piece : pieces) {
          Primitive p;
          p.kind = Kind::kConvexPrism;
          p.shape = shape_id;
          p.first_edge = static_cast<std::uint32_t>(edges_.size());
          p.num_edges = static_cast<std::uint32_t>(piece.size());
          p.a[2] = prism.z_min_m;
          p.b[2] = prism.z_max_m;
          double lo[3] = {kInf, kInf, prism.z_min_m}, hi[3] = {-kInf, -kInf, prism.z_max_m};
          for (std::size_t k = 0; k < piece.size(); ++k) {
            const Eigen::Vector2d& v0 = piece[k];
            const Eigen::Vector2d& v1 = piece[(k + 1) % piece.size()];
            const Eigen::Vector2d e = (v1 - v0).normalized();
            const Eigen::Vector2d n(e.y(), -e.x());  // outward for a counter-clockwise outline
            const bool seam = pieces.size() > 1 && !on_outline(0.5 * (v0 + v1));
            edges_.push_back(Edge{n.x(), n.y(), n.dot(v0) + (seam ? seam_overlap_m : 0.0)});
            for (int c = 0; c < 2; ++c) {
              lo[c] = std::min(lo[c], v0[c]);
              hi[c] = std::max(hi[c], v0[c]);
            }
          }
          prims.push_back(p);
          if (!add_bounds(i, s, lo, hi)) return false;
        }
        break;
      }
      case world::ShapeKind::kPlane: {
        if (s.index >= world.planes.size())
          return fail(i, s, format("index out of range (World::planes has %zu)", world.planes.size()));
        const world::PlaneShape& plane = world.planes[s.index];
        const double norm = plane.normal.norm();
        if (!plane.point_m.allFinite()) return fail(i, s, "point_m is not finite");
        if (!std::isfinite(norm) || norm < 1e-9) return fail(i, s, "normal must be finite and non-zero");
        const Eigen::Vector3d n = plane.normal / norm;
        planes_.push_back(Plane{{n.x(), n.y(), n.z()}, n.dot(plane.point_m), shape_id});
        break;
      }
    }
    materials_.push_back(mat);
  }

  Bvh::Config bvh_config;
  bvh_.build(boxes, bvh_config);
  primitives_.reserve(prims.size());
  for (std::uint32_t id : bvh_.item_order()) primitives_.push_back(prims[id]);

  stats_.num_shapes = world.shapes.size();
  stats_.num_primitives = primitives_.size();
  stats_.num_planes = planes_.size();
  stats_.num_bvh_nodes = bvh_.wide_nodes().size();
  stats_.bvh_depth = bvh_.depth();
  stats_.num_bvh_leaves = bvh_.num_leaves();
  built_ = true;
  return true;
}

// Every primitive is convex, so a ray crosses it in one interval [t_enter, t_exit]; the visible crossing is the
// entry, or the exit when the ray starts inside. Faces: boxes 2 * axis + (1 on the + side); cylinders 0 side,
// 1 bottom, 2 top; prisms 0 bottom, 1 top, 2 + edge.
bool RayScene::intersect_primitive(const Primitive& p, const PrimitiveRay& r, double t_min, double t_max, double* t,
                                   int* face) const {
  double t_enter = -kInf, t_exit = kInf;
  int face_enter = -1, face_exit = -1;
  switch (p.kind) {
    case Kind::kAabb: {
      // The most common primitive: reject branch-free first, find the faces only for a hit.
      double t_lo[3], t_hi[3];
      for (int k = 0; k < 3; ++k) {
        const double t0 = (p.a[k] - r.o[k]) * r.inv[k];
        const double t1 = (p.b[k] - r.o[k]) * r.inv[k];
        t_lo[k] = std::min(t0, t1);
        t_hi[k] = std::max(t0, t1);
      }
      t_enter = std::max(std::max(t_lo[0], t_lo[1]), t_lo[2]);
      t_exit = std::min(std::min(t_hi[0], t_hi[1]), t_hi[2]);
      if (t_enter > t_exit || t_exit < t_min || t_enter > t_max) return false;
      const int k_enter = t_lo[0] >= t_lo[1] ? (t_lo[0] >= t_lo[2] ? 0 : 2) : (t_lo[1] >= t_lo[2] ? 1 : 2);
      const int k_exit = t_hi[0] <= t_hi[1] ? (t_hi[0] <= t_hi[2] ? 0 : 2) : (t_hi[1] <= t_hi[2] ? 1 : 2);
      face_enter = 2 * k_enter + (r.inv[k_enter] >= 0.0 ? 0 : 1);
      face_exit = 2 * k_exit + (r.inv[k_exit] >= 0.0 ? 1 : 0);
      break;
    }
    case Kind::kOrientedBox: {
      const double rel[3] = {r.o[0] - p.a[0], r.o[1] - p.a[1], r.o[2] - p.a[2]};
      for (int k = 0; k < 3; ++k) {
        const double* row = p.m + 3 * k;
        const double o = row[0] * rel[0] + row[1] * rel[1] + row[2] * rel[2];
        const double d = row[0] * r.d[0] + row[1] * r.d[1] + row[2] * r.d[2];
        const double h = p.b[k];
        if (d == 0.0) {
          if (o < -h || o > h) return false;
          continue;
        }
        const double inv = 1.0 / d;
        const double t0 = (-h - o) * inv;
        const double t1 = (h - o) * inv;
        const bool forward = d > 0.0;
        const double near = forward ? t0 : t1;
        const double far = forward ? t1 : t0;
        if (near > t_enter) {
          t_enter = near;
          face_enter = 2 * k + (forward ? 0 : 1);
        }
        if (far < t_exit) {
          t_exit = far;
          face_exit = 2 * k + (forward ? 1 : 0);
        }
      }
      break;
    }
    case Kind::kCylinder: {
      const double ox = r.o[0] - p.a[0], oy = r.o[1] - p.a[1];
      const double a = r.d[0] * r.d[0] + r.d[1] * r.d[1];
      const double b = ox * r.d[0] + oy * r.d[1];
      const double c = ox * ox + oy * oy - p.b[1];
      if (a > 0.0) {
        const double disc = b * b - a * c;
        if (disc < 0.0) return false;
        // Numerically stable roots of a t^2 + 2 b t + c = 0.
        const double q = -(b + std::copysign(std::sqrt(disc), b));
        double t0 = q / a;
        double t1 = q != 0.0 ? c / q : t0;
        if (t0 > t1) std::swap(t0, t1);
        t_enter = t0;
        t_exit = t1;
        face_enter = face_exit = 0;
      } else if (c > 0.0) {
        return false;  // vertical ray outside the circle
      }
      if (r.d[2] != 0.0) {
        const double inv = r.inv[2];
        const double tb = (p.a[2] - r.o[2]) * inv;
        const double tt = (p.b[2] - r.o[2]) * inv;
        const bool up = r.d[2] > 0.0;
        const double near = up ? tb : tt;
        const double far = up ? tt : tb;
        if (near > t_enter) {
          t_enter = near;
          face_enter = up ? 1 : 2;
        }
        if (far < t_exit) {
          t_exit = far;
          face_exit = up ? 2 : 1;
        }
      } else if (r.o[2] < p.a[2] || r.o[2] > p.b[2]) {
        return false;
      }
      break;
    }
    case Kind::kConvexPrism: {
      if (r.d[2] != 0.0) {
        const double inv = r.inv[2];
        const double tb = (p.a[2] - r.o[2]) * inv;
        const double tt = (p.b[2] - r.o[2]) * inv;
        const bool up = r.d[2] > 0.0;
        t_enter = up ? tb : tt;
        t_exit = up ? tt : tb;
        face_enter = up ? 0 : 1;
        face_exit = up ? 1 : 0;
      } else if (r.o[2] < p.a[2] || r.o[2] > p.b[2]) {
        return false;
      }
      const Edge* edges = edges_.data() + p.first_edge;
      for (std::uint32_t k = 0; k < p.num_edges; ++k) {
        const Edge& e = edges[k];
        const double inside = e.offset - (e.nx * r.o[0] + e.ny * r.o[1]);  // >= 0 when the origin is inside
        const double rate = e.nx * r.d[0] + e.ny * r.d[1];
        if (rate == 0.0) {
          if (inside < 0.0) return false;
          continue;
        }
        const double te = inside / rate;
        if (rate < 0.0) {
          if (te > t_enter) {
            t_enter = te;
            face_enter = 2 + static_cast<int>(k);
          }
        } else if (te < t_exit) {
          t_exit = te;
          face_exit = 2 + static_cast<int>(k);
        }
        if (t_enter > t_exit) return false;
      }
      break;
    }
  }
  if (t_enter > t_exit) return false;
  if (t_enter >= t_min) {
    if (t_enter > t_max) return false;
    *t = t_enter;
    *face = face_enter;
    return true;
  }
  if (t_exit >= t_min && t_exit <= t_max) {
    *t = t_exit;
    *face = face_exit;
    return true;
  }
  return false;
}

Eigen::Vector3d RayScene::normal_at(const Primitive& p, int face, const Eigen::Vector3d& point) const {
  switch (p.kind) {
    case Kind::kAabb: {
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[face / 2] = (face & 1) ? 1.0 : -1.0;
      return n;
    }
    case Kind::kOrientedBox: {
      const double* row = p.m + 3 * (face / 2);
      const double s = (face & 1) ? 1.0 : -1.0;
      return Eigen::Vector3d(s * row[0], s * row[1], s * row[2]);
    }
    case Kind::kCylinder: {
      if (face == 1) return -Eigen::Vector3d::UnitZ();
      if (face == 2) return Eigen::Vector3d::UnitZ();
      Eigen::Vector3d n(point.x() - p.a[0], point.y() - p.a[1], 0.0);
      const double len = n.norm();
      return len > 0.0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d(Eigen::Vector3d::UnitX());
    }
    case Kind::kConvexPrism: {
      if (face == 0) return -Eigen::Vector3d::UnitZ();
      if (face == 1) return Eigen::Vector3d::UnitZ();
      const Edge& e = edges_[p.first_edge + static_cast<std::uint32_t>(face - 2)];
      return Eigen::Vector3d(e.nx, e.ny, 0.0);
    }
  }
  return Eigen::Vector3d::UnitZ();
}

bool RayScene::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                         RayHit* hit, std::uint32_t hint_primitive) const {
  PrimitiveRay r;
  for (int k = 0; k < 3; ++k) {
    r.o[k] = origin[k];
    r.d[k] = direction[k];
    // A tiny stand-in for a zero component keeps (bound - origin) * inv finite (never 0 * inf).
    const double d = direction[k] != 0.0 ? direction[k] : 1e-300;
    r.inv[k] = 1.0 / d;
  }
  double best_t = t_max;
  bool found = false;
  std::uint32_t best_shape = 0;
  int best_face = -1;
  const Primitive* best_prim = nullptr;
  const Plane* best_plane = nullptr;

  // Planes first: a near plane hit (the ground) shortens the BVH search.
  for (const Plane& pl : planes_) {
    const double rate = pl.n[0] * r.d[0] + pl.n[1] * r.d[1] + pl.n[2] * r.d[2];
    if (rate == 0.0) continue;
    const double t = (pl.offset - (pl.n[0] * r.o[0] + pl.n[1] * r.o[1] + pl.n[2] * r.o[2])) / rate;
    if (t >= t_min && t <= best_t) {
      best_t = t;
      best_plane = &pl;
      best_shape = pl.shape;
      found = true;
    }
  }

  if (hint_primitive < primitives_.size()) {
    double t = 0.0;
    int face = -1;
    const Primitive& p = primitives_[hint_primitive];
    if (intersect_primitive(p, r, t_min, best_t, &t, &face) && t <= best_t) {
      best_t = t;
      best_face = face;
      best_prim = &p;
      best_plane = nullptr;
      best_shape = p.shape;
      found = true;
    }
  }

  if (!bvh_.empty()) {
    const BvhRay bray = Bvh::make_ray(r.o, r.d);
    // Rounding best_t down to float could cull a box the exact hit lies in; widen it a little.
    float t_max_f = static_cast<float>(best_t) * (1.0f + 1e-6f) + 1e-6f;
    bvh_.traverse(bray, static_cast<float>(t_min) - 1e-6f, t_max_f,
                  [&](std::uint32_t first, std::uint32_t count, float& t_limit) {
                    for (std::uint32_t i = first; i < first + count; ++i) {
                      if (i == hint_primitive) continue;  // already tested
                      double t = 0.0;
                      int face = -1;
                      if (intersect_primitive(primitives_[i], r, t_min, best_t, &t, &face) && t <= best_t) {
                        best_t = t;
                        best_face = face;
                        best_prim = &primitives_[i];
                        best_plane = nullptr;
                        best_shape = primitives_[i].shape;
                        found = true;
                        t_limit = static_cast<float>(t) * (1.0f + 1e-6f) + 1e-6f;
                      }
                    }
                  });
  }
  if (!found) return false;
  hit->t = best_t;
  hit->shape = best_shape;
  hit->primitive = best_prim != nullptr && best_plane == nullptr
                       ? static_cast<std::uint32_t>(best_prim - primitives_.data())
                       : kNoPrimitive;
  if (best_plane != nullptr) {
    hit->normal = Eigen::Vector3d(best_plane->n[0], best_plane->n[1], best_plane->n[2]);
  } else {
    hit->normal = normal_at(*best_prim, best_face, origin + best_t * direction);
  }
  return true;
}

}  // namespace qsg::render

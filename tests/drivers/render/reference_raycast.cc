// Face-by-face reference ray casting (see reference_raycast.h).
#include "tests/drivers/render/reference_raycast.h"

#include <algorithm>
#include <cmath>

namespace qsg::render::testing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kFaceTolerance = 1e-9;

// Crossing of the plane n . x = offset, or infinity.
double plane_t(const Eigen::Vector3d& n, double offset, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const double rate = n.dot(d);
  if (rate == 0.0) return kInf;
  return (offset - n.dot(o)) / rate;
}

double box_t(const world::BoxShape& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min) {
  const Eigen::Matrix3d R = box.world_R_box.normalized().toRotationMatrix();
  double best = kInf;
  for (int axis = 0; axis < 3; ++axis) {
    for (double side : {-1.0, 1.0}) {
      const Eigen::Vector3d n = side * R.col(axis);
      const Eigen::Vector3d face_center = box.center_m + side * box.half_extents_m[axis] * R.col(axis);
      const double t = plane_t(n, n.dot(face_center), o, d);
      if (!(t >= t_min) || t >= best) continue;
      const Eigen::Vector3d local = R.transpose() * (o + t * d - box.center_m);
      bool inside = true;
      for (int other = 0; other < 3; ++other)
        if (other != axis && std::fabs(local[other]) > box.half_extents_m[other] + kFaceTolerance) inside = false;
      if (inside) best = t;
    }
  }
  return best;
}

double cylinder_t(const world::CylinderShape& c, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min) {
  double best = kInf;
  const double z0 = c.base_center_m.z(), z1 = c.base_center_m.z() + c.height_m;
  // Side: |p_xy - c_xy| = r, solved with the textbook quadratic formula.
  const Eigen::Vector2d oc(o.x() - c.base_center_m.x(), o.y() - c.base_center_m.y());
  const Eigen::Vector2d dxy(d.x(), d.y());
  const double a = dxy.squaredNorm(), b = 2.0 * oc.dot(dxy), cc = oc.squaredNorm() - c.radius_m * c.radius_m;
  const double disc = b * b - 4.0 * a * cc;
  if (a > 0.0 && disc >= 0.0) {
    for (double sign : {-1.0, 1.0}) {
      const double t = (-b + sign * std::sqrt(disc)) / (2.0 * a);
      const double z = o.z() + t * d.z();
      if (t >= t_min && t < best && z >= z0 - kFaceTolerance && z <= z1 + kFaceTolerance) best = t;
    }
  }
  // Caps.
  for (double z : {z0, z1}) {
    const double t = plane_t(Eigen::Vector3d::UnitZ(), z, o, d);
    if (!(t >= t_min) || t >= best) continue;
    const Eigen::Vector3d p = o + t * d;
    if (std::hypot(p.x() - c.base_center_m.x(), p.y() - c.base_center_m.y()) <= c.radius_m + kFaceTolerance) best = t;
  }
  return best;
}

// Crossing-number point-in-polygon test.
bool inside_polygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (p.x() < x) inside = !inside;
    }
  }
  return inside;
}

double prism_t(const world::PrismShape& prism, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min) {
  double best = kInf;
  const std::size_t n = prism.polygon_m.size();
  // Side walls: solve o_xy + t d_xy = a + s (b - a) for (t, s).
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = prism.polygon_m[i];
    const Eigen::Vector2d& b = prism.polygon_m[(i + 1) % n];
    Eigen::Matrix2d m;
    m.col(0) = Eigen::Vector2d(d.x(), d.y());
    m.col(1) = a - b;
    const double det = m.determinant();
    if (std::fabs(det) < 1e-15) continue;
    const Eigen::Vector2d ts = m.inverse() * (a - Eigen::Vector2d(o.x(), o.y()));
    const double t = ts[0], s = ts[1];
    const double z = o.z() + t * d.z();
    if (t >= t_min && t < best && s >= -kFaceTolerance && s <= 1.0 + kFaceTolerance &&
        z >= prism.z_min_m - kFaceTolerance && z <= prism.z_max_m + kFaceTolerance)
      best = t;
  }
  for (double z : {prism.z_min_m, prism.z_max_m}) {
    const double t = plane_t(Eigen::Vector3d::UnitZ(), z, o, d);
    if (!(t >= t_min) || t >= best) continue;
    const Eigen::Vector3d p = o + t * d;
    if (inside_polygon(prism.polygon_m, Eigen::Vector2d(p.x(), p.y()))) best = t;
  }
  return best;
}

}  // namespace

double reference_shape_t(const world::World& world, std::size_t shape, const Eigen::Vector3d& o,
                         const Eigen::Vector3d& d, double t_min) {
  const world::Shape& s = world.shapes[shape];
  switch (s.kind) {
    case world::ShapeKind::kBox:
      return box_t(world.boxes[s.index], o, d, t_min);
    case world::ShapeKind::kCylinder:
      return cylinder_t(world.cylinders[s.index], o, d, t_min);
    case world::ShapeKind::kPrism:
      return prism_t(world.prisms[s.index], o, d, t_min);
    case world::ShapeKind::kPlane: {
      const world::PlaneShape& p = world.planes[s.index];
      const Eigen::Vector3d n = p.normal.normalized();
      const double t = plane_t(n, n.dot(p.point_m), o, d);
      return t >= t_min ? t : kInf;
    }
  }
  return kInf;
}

ReferenceHit reference_raycast(const world::World& world, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                               double t_min, double t_max) {
  ReferenceHit hit;
  for (std::size_t i = 0; i < world.shapes.size(); ++i) {
    const double t = reference_shape_t(world, i, o, d, t_min);
    if (!(t <= t_max)) continue;
    if (t < hit.t) {
      hit.second_t = hit.t;
      hit.t = t;
      hit.shape = static_cast<int>(i);
    } else if (t < hit.second_t) {
      hit.second_t = t;
    }
  }
  if (hit.shape < 0) hit.t = kInf;
  return hit;
}

Eigen::Vector3d pixel_direction(const Eigen::Isometry3d& world_T_camera, const messages::CameraIntrinsics& k, int u,
                                int v) {
  const Eigen::Vector3d d_camera((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  return world_T_camera.linear() * d_camera;
}

Eigen::Isometry3d look_at(const Eigen::Vector3d& position_m, const Eigen::Vector3d& target_m,
                          const Eigen::Vector3d& up_hint) {
  const Eigen::Vector3d z = (target_m - position_m).normalized();
  const Eigen::Vector3d x = z.cross(up_hint).normalized();  // right
  const Eigen::Vector3d y = z.cross(x);                     // down
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = position_m;
  return T;
}

messages::CameraIntrinsics make_intrinsics(int width, int height, double fov_x_deg) {
  messages::CameraIntrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * fov_x_deg * 3.14159265358979323846 / 180.0);
  k.cx = 0.5 * width - 0.5;
  k.cy = 0.5 * height - 0.5;
  return k;
}

}  // namespace qsg::render::testing

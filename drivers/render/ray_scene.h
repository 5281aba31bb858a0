// A World compiled for ray casting: its finite shapes as convex primitives (boxes, vertical cylinders, convex
// prisms; concave prisms are split into convex pieces) under one BVH, infinite planes beside it, and each shape's
// material. Built once, then queried read-only (safe from several threads) without allocating.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/render/bvh.h"
#include "drivers/world/world.h"

namespace qsg::render {

inline constexpr std::uint32_t kNoPrimitive = 0xFFFFFFFFu;

struct RayHit {
  double t = 0.0;                                     // ray parameter: point = origin + t * direction
  std::uint32_t shape = 0;                            // index into World::shapes
  std::uint32_t primitive = kNoPrimitive;             // internal primitive id (kNoPrimitive for planes), a hint
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit outward normal of the surface that was hit
};

struct RaySceneStats {
  std::size_t num_shapes = 0;
  std::size_t num_primitives = 0;  // finite shapes after concave prisms were split
  std::size_t num_planes = 0;
  std::size_t num_bvh_nodes = 0;  // 4-wide traversal nodes
  int bvh_depth = 0;
  int num_bvh_leaves = 0;
  void print(std::FILE* out) const;
};

class RayScene {
 public:
  // Every finite shape lies within +-this of the origin: the BVH keeps float boxes (a metre's precision is lost
  // past about 1e7 m). World files are bounded tighter by their reader (drivers/world/world_file.h).
  static constexpr double kMaxAbsCoordinate_m = 1e6;

  // Validates every shape (errors name the shape index, kind and field) and builds the BVH; the World may be
  // destroyed afterwards. On failure the scene is left empty.
  bool build(const world::World& world, std::string* error);

  // Nearest surface crossing with t in [t_min, t_max] along origin + t * direction (direction need not be unit).
  // Solids are closed: a ray starting inside one hits its inside surface.
  // hint_primitive: the primitive a neighbouring ray hit (RayHit::primitive); testing it first bounds the search
  // early, which makes coherent rays (an image row) much cheaper. Any value is safe, kNoPrimitive = no hint.
  bool intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                 RayHit* hit, std::uint32_t hint_primitive = kNoPrimitive) const;

  const world::Material& material(std::uint32_t shape) const { return materials_[shape]; }
  const RaySceneStats& stats() const { return stats_; }
  bool built() const { return built_; }

 private:
  enum class Kind : std::uint8_t { kAabb, kOrientedBox, kCylinder, kConvexPrism };
  // One convex primitive; the meaning of a, b, m depends on the kind (see ray_scene.cc).
  struct Primitive {
    Kind kind = Kind::kAabb;
    std::uint32_t shape = 0;
    std::uint32_t first_edge = 0;
    std::uint32_t num_edges = 0;
    double a[3] = {0.0, 0.0, 0.0};
    double b[3] = {0.0, 0.0, 0.0};
    double m[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  };
  // Side of a convex prism: inside where nx * x + ny * y <= offset.
  struct Edge {
    double nx, ny, offset;
  };
  struct Plane {
    double n[3];
    double offset;  // n . x = offset on the plane
    std::uint32_t shape;
  };
  struct PrimitiveRay;

  bool intersect_primitive(const Primitive& p, const PrimitiveRay& r, double t_min, double t_max, double* t,
                           int* face) const;
  Eigen::Vector3d normal_at(const Primitive& p, int face, const Eigen::Vector3d& point) const;

  std::vector<Primitive> primitives_;  // in BVH leaf order
  std::vector<Edge> edges_;
  std::vector<Plane> planes_;
  std::vector<world::Material> materials_;
  Bvh bvh_;
  RaySceneStats stats_;
  bool built_ = false;
};

}  // namespace qsg::render

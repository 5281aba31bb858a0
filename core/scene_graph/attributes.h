// Typed node and edge attributes of the scene graph, field for field what Spark-DSG stores for each layer.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>

#include "core/memory/bounded_array.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/pool.h"

namespace qsg::scene_graph {

struct BoundingBox {
  enum class Type : std::uint8_t { kInvalid, kAabb, kObb, kRaabb };
  Type type = Type::kInvalid;
  Eigen::Vector3d min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d world_P_center_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond world_R_center = Eigen::Quaterniond::Identity();

  static BoundingBox aabb(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m) {
    BoundingBox b;
    b.type = Type::kAabb;
    b.min_m = min_m;
    b.max_m = max_m;
    b.world_P_center_m = 0.5 * (min_m + max_m);
    return b;
  }
  bool contains(const Eigen::Vector3d& p) const {
    return type != Type::kInvalid && (p.array() >= min_m.array()).all() && (p.array() <= max_m.array()).all();
  }
};

// Spark-DSG's NodeAttributes plus SemanticNodeAttributes: what objects, places, rooms and buildings share.
struct SemanticAttributes {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  std::uint64_t last_update_time_ns = 0;
  bool is_active = false;
  memory::InlineString<32> name;
  std::array<std::uint8_t, 3> color{{0, 0, 0}};
  BoundingBox bounding_box;
  std::uint32_t semantic_label = 0;
};

// A chain of chunks in the graph's shared mesh-connection pool (an object's mesh-vertex references).
struct MeshConnectionList {
  std::uint32_t head = memory::kInvalidHandle;
  std::uint32_t tail = memory::kInvalidHandle;
  std::uint32_t size = 0;
};

struct ObjectAttributes : SemanticAttributes {
  bool registered = false;
  Eigen::Quaterniond world_R_object = Eigen::Quaterniond::Identity();
  MeshConnectionList mesh_connections;  // managed by SceneGraph: append_mesh_connection() / mesh_connections()
};

// A basis point of a place: the mesh vertex (in its voxel block) nearest to the place's GVD voxel.
struct PlaceMeshConnection {
  memory::Index3 block;
  std::uint32_t vertex = 0;
  Eigen::Vector3d voxel_pos_m = Eigen::Vector3d::Zero();
  friend bool operator==(const PlaceMeshConnection& a, const PlaceMeshConnection& b) {
    return a.block == b.block && a.vertex == b.vertex && a.voxel_pos_m == b.voxel_pos_m;
  }
};

inline constexpr std::size_t kMaxPlaceConnections = 4;  // Spark-DSG places keep up to 4 basis points

// A place's is_active is written through SceneGraph::place(id) (the writable access), which keeps the graph's open
// places (SceneGraph::for_each_open_place) a superset of the active ones.
struct PlaceAttributes : SemanticAttributes {
  double distance_m = 0.0;  // clearance: distance to the nearest obstacle
  std::uint32_t num_basis_points = 0;
  memory::BoundedArray<PlaceMeshConnection, kMaxPlaceConnections> mesh_connections;  // "voxblox_mesh_connections"
  memory::BoundedArray<std::uint64_t, kMaxPlaceConnections> deformation_connections;
  memory::BoundedArray<std::uint32_t, kMaxPlaceConnections> mesh_vertex_labels;
  memory::BoundedArray<std::uint64_t, kMaxPlaceConnections> pcl_mesh_connections;
};

struct LabelProbability {
  std::uint32_t label = 0;
  float probability = 0.0f;
  friend bool operator==(const LabelProbability& a, const LabelProbability& b) {
    return a.label == b.label && a.probability == b.probability;
  }
};
inline constexpr std::size_t kMaxRoomClasses = 16;

struct RoomAttributes : SemanticAttributes {
  memory::BoundedArray<LabelProbability, kMaxRoomClasses> class_probabilities;  // from the room classifier
};

struct BuildingAttributes : SemanticAttributes {};

// A keyframe of a robot's trajectory.
struct AgentAttributes {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  std::uint64_t last_update_time_ns = 0;
  bool is_active = false;
  std::uint64_t timestamp_ns = 0;
  Eigen::Quaterniond world_R_body = Eigen::Quaterniond::Identity();
  std::uint64_t external_key = 0;
};

struct EdgeAttributes {
  double weight = 1.0;
  bool weighted = false;
};

}  // namespace qsg::scene_graph

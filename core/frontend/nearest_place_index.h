// A k-d tree over the active place nodes' positions (fixed capacity, carved once; rebuilds and queries never
// allocate), and the inter-layer step that makes each object's and agent's nearest place its parent.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/memory/arena.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/node_id.h"

namespace qsg::scene_graph {
class SceneGraph;
}

namespace qsg::frontend {

struct NearestPlaceCapacities {
  std::size_t places = 0;  // points the tree can hold
};
// The scene graph's place-node capacity of the board this build targets.
NearestPlaceCapacities nearest_place_capacities_from_budget();

struct PlaceNeighbor {
  scene_graph::NodeId id = scene_graph::kNoNode;
  double distance_m = 0.0;
};

class NearestPlaceIndex {
 public:
  static constexpr std::size_t kMaxK = 16;

  NearestPlaceIndex() = default;
  NearestPlaceIndex(const NearestPlaceIndex&) = delete;
  NearestPlaceIndex& operator=(const NearestPlaceIndex&) = delete;
  ~NearestPlaceIndex() = default;

  static memory::ArenaPlan plan(const NearestPlaceCapacities& capacities);
  bool init(const NearestPlaceCapacities& capacities, std::size_t budget_bytes, std::string* error);

  // Rebuilds over the graph's place nodes (only active ones unless active_only is false). Places beyond the
  // capacity are left out (counted). Returns the number indexed.
  std::size_t rebuild(const scene_graph::SceneGraph& graph, bool active_only = true);
  // Rebuilds over given points (ids may be null: then the id of point i is i).
  std::size_t rebuild(const Eigen::Vector3d* points, const scene_graph::NodeId* ids, std::size_t n);

  // A rebuild point by point (no staging copy): clear_points(), add_point() for each (false and counted under
  // dropped when full, or refused when not finite), then build_tree(). Returns the number indexed.
  void clear_points() { size_ = 0; }
  bool add_point(scene_graph::NodeId id, const Eigen::Vector3d& p);
  std::size_t build_tree();

  // The k (<= kMaxK) nearest points to q, nearest first; returns how many were written.
  std::size_t nearest(const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out) const;

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  std::uint64_t dropped() const { return dropped_; }  // points left out of rebuilds for lack of capacity
  // Capacity, points held, their high-water mark and the points dropped, under this name (telemetry).
  void set_name(const char* name) { name_ = name; }
  memory::ResourceStats stats() const { return {name_, "points", capacity_, size_, high_water_, dropped_}; }

  struct Point {
    double p[3];
    scene_graph::NodeId id;
  };

 private:
  void build(std::uint32_t lo, std::uint32_t hi);
  struct Best;
  void search(std::uint32_t lo, std::uint32_t hi, const double* q, Best& best) const;

  memory::Arena arena_;
  Point* points_ = nullptr;          // in tree order after build (the median of [lo, hi) sits at (lo + hi) / 2)
  std::uint8_t* split_dim_ = nullptr;
  std::size_t capacity_ = 0;
  std::size_t size_ = 0;
  std::size_t high_water_ = 0;
  std::uint64_t dropped_ = 0;
  const char* name_ = "frontend.place_index";
};

struct ConnectStats {
  std::size_t connected = 0;  // parent edge added or moved
  std::size_t unchanged = 0;  // nearest place already the parent
  std::size_t no_place = 0;   // index empty, or the node is missing or not an object/agent
  std::size_t failed = 0;     // the graph's edge stores are full (counted, nothing changed)
};

// For each node (object or agent), makes its nearest indexed place its parent: an edge to a different previous
// parent place is removed, the new edge added. Never allocates; full edge stores are counted, not fatal.
// "Nearest" is by the gap to the place's free-space sphere (distance minus the place's clearance) among the
// kParentCandidates nearest places: the spheres are free space, so they stop at walls, while the plain nearest
// place of an object by a wall is often the one just behind the wall, in the next room.
constexpr std::size_t kParentCandidates = 8;
ConnectStats connect_to_nearest_places(scene_graph::SceneGraph* graph, const NearestPlaceIndex& index,
                                       const scene_graph::NodeId* nodes, std::size_t count);
// The same over the incremental index (incremental_place_index.h), among the places still in the graph (the index
// may hold a removed place until its sweep drops it).
class IncrementalPlaceIndex;
ConnectStats connect_to_nearest_places(scene_graph::SceneGraph* graph, const IncrementalPlaceIndex& index,
                                       const scene_graph::NodeId* nodes, std::size_t count);

}  // namespace qsg::frontend

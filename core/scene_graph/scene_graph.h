// The layered 3D scene graph (objects and agents, places, rooms, buildings) in fixed-capacity stores.
//
// Every store is carved from one arena at init(), sized by the board's budget table; after that no operation
// allocates. The paper's hierarchy rules are enforced on every edge: an edge joins nodes of the same layer
// (and partition) or of adjacent layers; a node has at most one parent, in the layer directly above
// (which also makes the children of different parents disjoint).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/pool.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/attributes.h"
#include "core/scene_graph/node_id.h"
#include "core/scene_graph/place_grid.h"

namespace qsg::scene_graph {

enum class NodeKind : std::uint8_t { kObject, kAgent, kPlace, kRoom, kBuilding };
const char* to_string(NodeKind kind);
LayerKey layer_of(NodeKind kind, char agent_prefix = kDefaultAgentPrefix);

enum class Status : std::uint8_t {
  kOk,
  kDuplicateNode,
  kDuplicateEdge,
  kMissingNode,
  kFull,              // a store is at capacity (counted in its stats)
  kSelfLoop,
  kLayersNotAdjacent, // locality rule: edges only within a layer or between adjacent layers
  kPartitionMismatch, // same layer number, different partitions (e.g. an object and an agent)
  kParentExists,      // single-parent rule
  kWrongKind,
};
const char* to_string(Status status);

// How many of each thing the graph holds; from the budget table (capacities_from_budget()).
struct Capacities {
  std::size_t object_nodes = 0;
  std::size_t agent_nodes = 0;
  std::size_t place_nodes = 0;
  std::size_t room_nodes = 0;
  std::size_t building_nodes = 0;
  std::size_t edges = 0;
  std::size_t adjacency_chunks = 0;  // chunks of kAdjacencyChunkEdges edge references
  std::size_t mesh_connections = 0;  // object-to-mesh-vertex references, all objects together

  std::size_t nodes() const { return object_nodes + agent_nodes + place_nodes + room_nodes + building_nodes; }
  void print(std::FILE* out) const;
};

// The capacities and arena bytes of the board this build targets (budgets/<QSG_BOARD>.json).
Capacities capacities_from_budget();
std::size_t arena_bytes_from_budget();

inline constexpr std::size_t kAdjacencyChunkEdges = 15;
inline constexpr std::size_t kMeshChunkValues = 15;

struct NodeRecord {
  NodeId id = kNoNode;
  LayerKey layer;
  NodeKind kind = NodeKind::kObject;
  std::uint32_t attributes = memory::kInvalidHandle;  // handle in the pool of its kind
  std::uint32_t adjacency_head = memory::kInvalidHandle;
  std::uint32_t degree = 0;
  NodeId parent = kNoNode;
  std::uint32_t num_children = 0;
};

struct EdgeRecord {
  NodeId source = kNoNode;
  NodeId target = kNoNode;
  std::uint32_t source_node = memory::kInvalidHandle;
  std::uint32_t target_node = memory::kInvalidHandle;
  EdgeAttributes info;
};

class SceneGraph {
 public:
  SceneGraph() = default;
  SceneGraph(const SceneGraph&) = delete;
  SceneGraph& operator=(const SceneGraph&) = delete;
  ~SceneGraph() = default;  // pools (declared after the arena) release their elements first

  static memory::ArenaPlan plan(const Capacities& capacities);
  // Carves every store from one arena of at most `budget_bytes`. Start-up only; false with a reason on error.
  bool init(const Capacities& capacities, std::size_t budget_bytes, std::string* error);
  bool initialized() const { return arena_.sealed(); }
  const Capacities& capacities() const { return capacities_; }

  // Nodes. Attributes are copied in; mesh connections of objects are added with append_mesh_connection().
  Status add_object(NodeId id, const ObjectAttributes& attributes);
  Status add_place(NodeId id, const PlaceAttributes& attributes);
  Status add_room(NodeId id, const RoomAttributes& attributes);
  Status add_building(NodeId id, const BuildingAttributes& attributes);
  Status add_agent(NodeId id, char prefix, const AgentAttributes& attributes);
  // Removes the node, its edges and its mesh connections.
  bool remove_node(NodeId id);

  // Edges are undirected; (a, b) and (b, a) are the same edge.
  Status add_edge(NodeId a, NodeId b, const EdgeAttributes& info = {});
  bool remove_edge(NodeId a, NodeId b);
  // Merges `from` into `into` (two nodes of one kind found to be the same thing, e.g. a revisited place): every
  // edge of `from` moves to `into` with its attributes, then `from` is removed. An edge `into` already has, one to
  // `into` itself, and a second parent (`into` keeps its own) are dropped; so is an edge a full store refuses
  // (counted in `refused`). Attributes of `into` are the caller's to update.
  struct MergeResult {
    Status status = Status::kOk;  // kMissingNode, kSelfLoop or kWrongKind: nothing changed
    std::size_t moved = 0;
    std::size_t dropped = 0;
    std::size_t refused = 0;
  };
  MergeResult merge_into(NodeId into, NodeId from);
  // A node or edge a stage did not ask for because it saw the graph full (stages check for room first, so a full
  // graph is a counted degradation in every build rather than an abort under QSG_OVERFLOW_ABORT): counted as a
  // refusal of the store that is full (the node kind's pool, else the node table; the edge pool, else the adjacency
  // chunks), so the stores' `refused` in telemetry and the exit report shows it under that store's own name.
  void count_refused_node(NodeKind kind, std::uint64_t n = 1);
  void count_refused_edge(std::uint64_t n = 1);
  // The rule add_edge() applies to two layers (also used to validate imports before touching the graph).
  static Status check_layers(const LayerKey& a, const LayerKey& b);

  bool has_node(NodeId id) const { return node_index_.contains(id); }
  bool has_edge(NodeId a, NodeId b) const;
  const NodeRecord* node(NodeId id) const;
  // The record in a slot of the node table (a slot for_each_child_record gave; valid while that node lives).
  const NodeRecord& node_at(std::uint32_t slot) const { return nodes_[slot]; }
  const EdgeRecord* edge(NodeId a, NodeId b) const;
  EdgeAttributes* edge_info(NodeId a, NodeId b);
  NodeId parent(NodeId id) const;

  // Typed attribute access; nullptr when the node is absent or of another kind. The writable access to a place
  // marks it open (below): whoever may write its is_active goes through here.
  ObjectAttributes* object(NodeId id) { return typed(id, NodeKind::kObject, objects_); }
  PlaceAttributes* place(NodeId id) {
    const std::uint32_t* h = node_index_.find(id);
    if (h == nullptr || nodes_[*h].kind != NodeKind::kPlace) return nullptr;
    mark_open(*h);
    return &places_[nodes_[*h].attributes];
  }
  RoomAttributes* room(NodeId id) { return typed(id, NodeKind::kRoom, rooms_); }
  BuildingAttributes* building(NodeId id) { return typed(id, NodeKind::kBuilding, buildings_); }
  AgentAttributes* agent(NodeId id) { return typed(id, NodeKind::kAgent, agents_); }
  const ObjectAttributes* object(NodeId id) const { return const_cast<SceneGraph*>(this)->object(id); }
  const PlaceAttributes* place(NodeId id) const {
    const std::uint32_t* h = node_index_.find(id);
    return h == nullptr || nodes_[*h].kind != NodeKind::kPlace ? nullptr : &places_[nodes_[*h].attributes];
  }
  const RoomAttributes* room(NodeId id) const { return const_cast<SceneGraph*>(this)->room(id); }
  const BuildingAttributes* building(NodeId id) const { return const_cast<SceneGraph*>(this)->building(id); }
  const AgentAttributes* agent(NodeId id) const { return const_cast<SceneGraph*>(this)->agent(id); }
  // A place's attributes from its record as for_each_node gives it, without the id lookup (nullptr: not a place).
  const PlaceAttributes* place_of(const NodeRecord& n) const {
    return n.kind == NodeKind::kPlace ? &places_[n.attributes] : nullptr;
  }

  // Object mesh connections (indices of mesh vertices). False when the pool is full (counted).
  bool append_mesh_connection(NodeId object_id, std::uint32_t vertex);
  void clear_mesh_connections(NodeId object_id);
  std::size_t num_mesh_connections(NodeId object_id) const;
  template <typename Fn>
  void for_each_mesh_connection(NodeId object_id, Fn&& fn) const;

  // Iteration. fn must not add or remove nodes or edges.
  template <typename Fn>
  void for_each_node(Fn&& fn) const {  // fn(const NodeRecord&)
    nodes_.for_each([&](std::uint32_t, const NodeRecord& n) { fn(n); });
  }
  template <typename Fn>
  void for_each_edge(Fn&& fn) const {  // fn(const EdgeRecord&)
    edges_.for_each([&](std::uint32_t, const EdgeRecord& e) { fn(e); });
  }
  template <typename Fn>
  void for_each_neighbor(NodeId id, Fn&& fn) const;  // fn(NodeId neighbour, const EdgeRecord&)
  template <typename Fn>
  void for_each_child(NodeId id, Fn&& fn) const;  // fn(NodeId child)
  // The nodes of one kind, in for_each_node's order, without visiting the others (a bitmap per kind over the node
  // table: a word per 64 slots, then the kind's nodes).
  template <typename Fn>
  void for_each_node_of(NodeKind kind, Fn&& fn) const {  // fn(const NodeRecord&)
    for_each_bit(kind_bits_[static_cast<int>(kind)], [&](std::uint32_t h) { fn(nodes_[h]); });
  }
  // The children of a node with their slots in the node table (ascending slots are for_each_node's order), read
  // from the edges' own handles: no lookup per child.
  template <typename Fn>
  void for_each_child_record(NodeId id, Fn&& fn) const;  // fn(std::uint32_t slot, const NodeRecord& child)

  // Open places: every place that is active or has no parent, in a set that may hold more (issue 37: the room
  // finder's window without a scan of the places layer). A place enters when it is added, when its parent edge
  // goes, and on every writable access (place(id) non-const), which is how any writer of its is_active reaches it;
  // for_each_open_place drops those it finds inactive with a parent. Never allocates (a bitmap over the node table).
  template <typename Fn>
  void for_each_open_place(Fn&& fn) {  // fn(const NodeRecord&, const PlaceAttributes&), in for_each_node's order
    for_each_bit(open_bits_, [&](std::uint32_t h) {
      const NodeRecord& n = nodes_[h];
      const PlaceAttributes& a = places_[n.attributes];
      if (!a.is_active && n.parent != kNoNode) {
        close_place(h);
        return;
      }
      fn(n, a);
    });
  }
  memory::ResourceStats open_places_stats() const { return open_places_.stats(); }

  // Closed places (the others: inactive, with a parent) are kept in a spatial hash, and each room has the sums of
  // its closed children (place_grid.h). fn(slot, const NodeRecord&, const PlaceAttributes&) for every closed place
  // in a cell the box [lo, hi] touches: a superset of the box's closed places, in no particular order.
  template <typename Fn>
  void for_each_closed_place_near(const double* lo, const double* hi, Fn&& fn) const {
    grid_.for_each_in_box(lo, hi, [&](std::uint32_t h) { fn(h, nodes_[h], places_[nodes_[h].attributes]); });
  }
  // Every place inside the box [lo, hi] (closed ones from the hash, open ones from their set), each once, in no
  // particular order: fn(slot, const NodeRecord&, const PlaceAttributes&).
  template <typename Fn>
  void for_each_place_in_box(const double* lo, const double* hi, Fn&& fn) const {
    const auto inside = [&](const PlaceAttributes& a) {
      for (int d = 0; d < 3; ++d)
        if (!(a.position_m[d] >= lo[d] && a.position_m[d] <= hi[d])) return false;
      return true;
    };
    for_each_closed_place_near(lo, hi, [&](std::uint32_t h, const NodeRecord& n, const PlaceAttributes& a) {
      if (inside(a)) fn(h, n, a);
    });
    for_each_bit(open_bits_, [&](std::uint32_t h) {
      const PlaceAttributes& a = places_[nodes_[h].attributes];
      if (inside(a)) fn(h, nodes_[h], a);
    });
  }
  // The sums of a room's closed children (count 0: none, or not a room).
  const ChildSums& closed_child_sums(NodeId room) const;
  std::size_t num_closed_places() const { return grid_.filed_places(); }

  std::size_t num_nodes() const { return nodes_.size(); }
  std::size_t num_nodes(NodeKind kind) const;
  std::size_t num_edges() const { return edges_.size(); }
  std::size_t num_layer_edges(bool interlayer) const;

  // Empties the graph; capacities and stores stay.
  void clear();

  // Usage of every store, for telemetry and tests: fn(const memory::ResourceStats&).
  template <typename Fn>
  void for_each_resource(Fn&& fn) const {
    fn(arena_.stats());
    fn(nodes_.stats());
    fn(node_index_.stats());
    fn(objects_.stats());
    fn(agents_.stats());
    fn(places_.stats());
    fn(rooms_.stats());
    fn(buildings_.stats());
    fn(edges_.stats());
    fn(edge_index_.stats());
    fn(adjacency_.stats());
    fn(mesh_chunks_.stats());
    fn(open_places_.stats());
    fn(grid_.stats());
  }

 private:
  struct EdgeKey {
    NodeId lo;
    NodeId hi;
    friend bool operator==(const EdgeKey& a, const EdgeKey& b) { return a.lo == b.lo && a.hi == b.hi; }
  };
  struct EdgeKeyHash {
    std::uint64_t operator()(const EdgeKey& k) const { return memory::mix64(k.lo ^ memory::mix64(k.hi)); }
  };
  struct AdjacencyChunk {
    std::uint32_t edges[kAdjacencyChunkEdges];
    std::uint32_t next;
  };
  struct MeshChunk {
    std::uint32_t values[kMeshChunkValues];
    std::uint32_t next;
  };
  static EdgeKey key_of(NodeId a, NodeId b) { return a < b ? EdgeKey{a, b} : EdgeKey{b, a}; }

  template <typename Attr>
  Status add_node(NodeId id, NodeKind kind, const LayerKey& layer, memory::Pool<Attr>& pool, const Attr& attributes);
  template <typename Attr>
  Attr* typed(NodeId id, NodeKind kind, memory::Pool<Attr>& pool) {
    const std::uint32_t* h = node_index_.find(id);
    if (h == nullptr || nodes_[*h].kind != kind) return nullptr;
    return &pool[nodes_[*h].attributes];
  }
  // A place opens (its filed cell and share of its room's sums go) before anything about it can change.
  void mark_open(std::uint32_t h) {
    std::uint64_t& w = open_bits_[h >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (h & 63);
    if ((w & bit) != 0) return;
    w |= bit;
    open_places_.set_in_use(open_places_.in_use() + 1);
    grid_.unfile(nodes_[h].attributes, places_[nodes_[h].attributes]);
  }
  void close_place(std::uint32_t h);
  void set_slot_bits(std::uint32_t h, NodeKind kind);
  void clear_bits();
  void clear_slot_bits(std::uint32_t h, NodeKind kind);
  // fn(slot) for each set bit of a node-table bitmap, ascending; fn may clear the bit it is given.
  template <typename Fn>
  void for_each_bit(const std::uint64_t* bits, Fn&& fn) const {
    for (std::size_t w = 0; w < bit_words_; ++w)
      for (std::uint64_t x = bits[w]; x != 0; x &= x - 1)
        fn(static_cast<std::uint32_t>(w * 64 + static_cast<std::size_t>(__builtin_ctzll(x))));
  }
  bool adjacency_push(NodeRecord& node, std::uint32_t edge);
  void adjacency_remove(NodeRecord& node, std::uint32_t edge);
  void remove_edge_handle(std::uint32_t edge);
  void release_attributes(const NodeRecord& node);

  Capacities capacities_;
  memory::Arena arena_;
  memory::Pool<NodeRecord> nodes_{"scene_graph.nodes"};
  memory::FixedHashMap<NodeId, std::uint32_t, memory::U64Hash> node_index_{"scene_graph.node_index"};
  memory::Pool<ObjectAttributes> objects_{"scene_graph.objects"};
  memory::Pool<AgentAttributes> agents_{"scene_graph.agents"};
  memory::Pool<PlaceAttributes> places_{"scene_graph.places"};
  memory::Pool<RoomAttributes> rooms_{"scene_graph.rooms"};
  memory::Pool<BuildingAttributes> buildings_{"scene_graph.buildings"};
  memory::Pool<EdgeRecord> edges_{"scene_graph.edges"};
  memory::FixedHashMap<EdgeKey, std::uint32_t, EdgeKeyHash> edge_index_{"scene_graph.edge_index"};
  memory::Pool<AdjacencyChunk> adjacency_{"scene_graph.adjacency_chunks"};
  memory::Pool<MeshChunk> mesh_chunks_{"scene_graph.mesh_chunks"};
  // Bitmaps over the node table's slots: one per node kind, and the open places (for_each_open_place).
  std::uint64_t* kind_bits_[5] = {};
  std::uint64_t* open_bits_ = nullptr;
  std::size_t bit_words_ = 0;
  memory::UsageCounter open_places_{"scene_graph.open_places", "places", 0};
  PlaceGrid grid_;  // the closed places (carved after the bitmaps)
};

template <typename Fn>
void SceneGraph::for_each_neighbor(NodeId id, Fn&& fn) const {
  const std::uint32_t* h = node_index_.find(id);
  if (h == nullptr) return;
  const NodeRecord& n = nodes_[*h];
  std::uint32_t remaining = n.degree;
  // The head chunk holds the newest (degree - 1) % k + 1 references; the rest are full.
  std::uint32_t in_chunk = remaining == 0 ? 0 : (remaining - 1) % kAdjacencyChunkEdges + 1;
  for (std::uint32_t c = n.adjacency_head; c != memory::kInvalidHandle && remaining > 0; c = adjacency_[c].next) {
    for (std::uint32_t i = 0; i < in_chunk; ++i) {
      const EdgeRecord& e = edges_[adjacency_[c].edges[i]];
      fn(e.source == id ? e.target : e.source, e);
    }
    remaining -= in_chunk;
    in_chunk = kAdjacencyChunkEdges;
  }
}

template <typename Fn>
void SceneGraph::for_each_child(NodeId id, Fn&& fn) const {
  const NodeRecord* n = node(id);
  if (n == nullptr || n->num_children == 0) return;
  for_each_neighbor(id, [&](NodeId other, const EdgeRecord&) {
    const NodeRecord* o = node(other);
    if (o != nullptr && o->parent == id) fn(other);
  });
}

template <typename Fn>
void SceneGraph::for_each_child_record(NodeId id, Fn&& fn) const {
  const std::uint32_t* h = node_index_.find(id);
  if (h == nullptr || nodes_[*h].num_children == 0) return;
  for_each_neighbor(id, [&](NodeId, const EdgeRecord& e) {
    const std::uint32_t other = e.source == id ? e.target_node : e.source_node;
    if (nodes_[other].parent == id) fn(other, nodes_[other]);
  });
}

template <typename Fn>
void SceneGraph::for_each_mesh_connection(NodeId object_id, Fn&& fn) const {
  const ObjectAttributes* o = object(object_id);
  if (o == nullptr) return;
  std::uint32_t remaining = o->mesh_connections.size;
  for (std::uint32_t c = o->mesh_connections.head; c != memory::kInvalidHandle && remaining > 0;
       c = mesh_chunks_[c].next) {
    const std::uint32_t n = remaining < kMeshChunkValues ? remaining : static_cast<std::uint32_t>(kMeshChunkValues);
    for (std::uint32_t i = 0; i < n; ++i) fn(mesh_chunks_[c].values[i]);
    remaining -= n;
  }
}

}  // namespace qsg::scene_graph

// Scene-graph stores, hierarchy rules and the arena carve.
#include "core/scene_graph/scene_graph.h"

#include <algorithm>
#include <cstdio>

#include "budgets/budget_table.h"

namespace qsg::scene_graph {

const char* to_string(NodeKind kind) {
  switch (kind) {
    case NodeKind::kObject: return "object";
    case NodeKind::kAgent: return "agent";
    case NodeKind::kPlace: return "place";
    case NodeKind::kRoom: return "room";
    case NodeKind::kBuilding: return "building";
  }
  return "?";
}

LayerKey layer_of(NodeKind kind, char agent_prefix) {
  switch (kind) {
    case NodeKind::kObject: return {static_cast<std::uint8_t>(Layer::kObjects), 0};
    case NodeKind::kAgent: return {static_cast<std::uint8_t>(Layer::kAgents), agent_prefix};
    case NodeKind::kPlace: return {static_cast<std::uint8_t>(Layer::kPlaces), 0};
    case NodeKind::kRoom: return {static_cast<std::uint8_t>(Layer::kRooms), 0};
    case NodeKind::kBuilding: return {static_cast<std::uint8_t>(Layer::kBuildings), 0};
  }
  return {};
}

const char* to_string(Status status) {
  switch (status) {
    case Status::kOk: return "ok";
    case Status::kDuplicateNode: return "duplicate node";
    case Status::kDuplicateEdge: return "duplicate edge";
    case Status::kMissingNode: return "missing node";
    case Status::kFull: return "store full";
    case Status::kSelfLoop: return "self loop";
    case Status::kLayersNotAdjacent: return "layers not adjacent";
    case Status::kPartitionMismatch: return "partition mismatch";
    case Status::kParentExists: return "node already has a parent";
    case Status::kWrongKind: return "wrong node kind";
  }
  return "?";
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out,
               "scene graph capacities: objects %zu, agents %zu, places %zu, rooms %zu, buildings %zu, edges %zu, "
               "adjacency chunks %zu, mesh connections %zu\n",
               object_nodes, agent_nodes, place_nodes, room_nodes, building_nodes, edges, adjacency_chunks,
               mesh_connections);
}

Capacities capacities_from_budget() {
  namespace b = budgets::active::scene_graph;
  Capacities c;
  c.object_nodes = b::kObjectNodes;
  c.agent_nodes = b::kAgentNodes;
  c.place_nodes = b::kPlaceNodes;
  c.room_nodes = b::kRoomNodes;
  c.building_nodes = b::kBuildingNodes;
  c.edges = b::kEdges;
  c.adjacency_chunks = b::kAdjacencyChunks;
  c.mesh_connections = b::kMeshConnections;
  return c;
}

std::size_t arena_bytes_from_budget() { return budgets::active::scene_graph::kArenaBytes; }

namespace {
std::size_t mesh_chunk_count(const Capacities& c) { return (c.mesh_connections + kMeshChunkValues - 1) / kMeshChunkValues; }
std::size_t bit_words(const Capacities& c) { return (c.nodes() + 63) / 64; }
constexpr int kKinds = 5;
}  // namespace

memory::ArenaPlan SceneGraph::plan(const Capacities& c) {
  memory::ArenaPlan plan;
  memory::Pool<NodeRecord>::plan(plan, c.nodes());
  memory::FixedHashMap<NodeId, std::uint32_t, memory::U64Hash>::plan(
      plan, memory::FixedHashMap<NodeId, std::uint32_t, memory::U64Hash>::slots_for(c.nodes()));
  memory::Pool<ObjectAttributes>::plan(plan, c.object_nodes);
  memory::Pool<AgentAttributes>::plan(plan, c.agent_nodes);
  memory::Pool<PlaceAttributes>::plan(plan, c.place_nodes);
  memory::Pool<RoomAttributes>::plan(plan, c.room_nodes);
  memory::Pool<BuildingAttributes>::plan(plan, c.building_nodes);
  memory::Pool<EdgeRecord>::plan(plan, c.edges);
  memory::FixedHashMap<EdgeKey, std::uint32_t, EdgeKeyHash>::plan(
      plan, memory::FixedHashMap<EdgeKey, std::uint32_t, EdgeKeyHash>::slots_for(c.edges));
  memory::Pool<AdjacencyChunk>::plan(plan, c.adjacency_chunks);
  memory::Pool<MeshChunk>::plan(plan, mesh_chunk_count(c));
  for (int k = 0; k <= kKinds; ++k) plan.add_array<std::uint64_t>(bit_words(c));  // the kinds', the open places'
  PlaceGrid::plan(plan, c.place_nodes, c.room_nodes);
  return plan;
}

bool SceneGraph::init(const Capacities& c, std::size_t budget_bytes, std::string* error) {
  if (!arena_.create("scene_graph", plan(c), budget_bytes, error)) return false;
  capacities_ = c;
  const std::size_t node_slots = decltype(node_index_)::slots_for(c.nodes());
  const std::size_t edge_slots = decltype(edge_index_)::slots_for(c.edges);
  const bool ok = nodes_.carve(arena_, c.nodes()) && node_index_.carve(arena_, node_slots, c.nodes()) &&
                  objects_.carve(arena_, c.object_nodes) && agents_.carve(arena_, c.agent_nodes) &&
                  places_.carve(arena_, c.place_nodes) && rooms_.carve(arena_, c.room_nodes) &&
                  buildings_.carve(arena_, c.building_nodes) && edges_.carve(arena_, c.edges) &&
                  edge_index_.carve(arena_, edge_slots, c.edges) && adjacency_.carve(arena_, c.adjacency_chunks) &&
                  mesh_chunks_.carve(arena_, mesh_chunk_count(c));
  bit_words_ = bit_words(c);
  bool bits = true;
  for (int k = 0; k < kKinds; ++k) bits = (kind_bits_[k] = arena_.carve_array<std::uint64_t>(bit_words_)) && bits;
  open_bits_ = arena_.carve_array<std::uint64_t>(bit_words_);
  bits = bits && open_bits_ != nullptr && grid_.carve(arena_, c.place_nodes, c.room_nodes);
  if (!ok || !bits || !arena_.seal()) {
    if (error != nullptr) *error = "scene_graph: the arena carve did not match its plan";
    return false;
  }
  open_places_.set_capacity(c.place_nodes);
  clear_bits();
  return true;
}

void SceneGraph::clear_bits() {
  for (int k = 0; k < kKinds; ++k) std::fill(kind_bits_[k], kind_bits_[k] + bit_words_, std::uint64_t{0});
  std::fill(open_bits_, open_bits_ + bit_words_, std::uint64_t{0});
  open_places_.set_in_use(0);
  grid_.clear();
}

// An inactive place with a parent leaves the open set for the grid (its parent is a room: the layer above places).
void SceneGraph::close_place(std::uint32_t h) {
  open_bits_[h >> 6] &= ~(std::uint64_t{1} << (h & 63));
  open_places_.set_in_use(open_places_.in_use() - 1);
  const NodeRecord& n = nodes_[h];
  const std::uint32_t* parent = node_index_.find(n.parent);
  if (parent != nullptr && nodes_[*parent].kind == NodeKind::kRoom)
    grid_.file(n.attributes, h, nodes_[*parent].attributes, places_[n.attributes]);
}

const ChildSums& SceneGraph::closed_child_sums(NodeId room) const {
  static const ChildSums kNone = [] {
    ChildSums s;
    s.reset();
    return s;
  }();
  const std::uint32_t* h = node_index_.find(room);
  return h == nullptr || nodes_[*h].kind != NodeKind::kRoom ? kNone : grid_.sums(nodes_[*h].attributes);
}

void SceneGraph::set_slot_bits(std::uint32_t h, NodeKind kind) {
  kind_bits_[static_cast<int>(kind)][h >> 6] |= std::uint64_t{1} << (h & 63);
  if (kind == NodeKind::kPlace) mark_open(h);
}

void SceneGraph::clear_slot_bits(std::uint32_t h, NodeKind kind) {
  const std::uint64_t bit = std::uint64_t{1} << (h & 63);
  kind_bits_[static_cast<int>(kind)][h >> 6] &= ~bit;
  if ((open_bits_[h >> 6] & bit) == 0) return;
  open_bits_[h >> 6] &= ~bit;
  open_places_.set_in_use(open_places_.in_use() - 1);
}

void SceneGraph::clear() {
  nodes_.clear();
  node_index_.clear();
  objects_.clear();
  agents_.clear();
  places_.clear();
  rooms_.clear();
  buildings_.clear();
  edges_.clear();
  edge_index_.clear();
  adjacency_.clear();
  mesh_chunks_.clear();
  if (arena_.sealed()) clear_bits();
}

template <typename Attr>
Status SceneGraph::add_node(NodeId id, NodeKind kind, const LayerKey& layer, memory::Pool<Attr>& pool,
                            const Attr& attributes) {
  if (node_index_.contains(id)) return Status::kDuplicateNode;
  if (pool.full() || nodes_.full()) {
    if (pool.full()) pool.refuse();  // counted on the store that is full
    else nodes_.refuse();
    return Status::kFull;
  }
  const std::uint32_t attr = pool.acquire(attributes);
  const std::uint32_t h = nodes_.acquire();
  NodeRecord& n = nodes_[h];
  n.id = id;
  n.layer = layer;
  n.kind = kind;
  n.attributes = attr;
  if (node_index_.insert(id, h) == nullptr) {  // cannot happen while the index has a slot per node
    nodes_.release(h);
    pool.release(attr);
    return Status::kFull;
  }
  set_slot_bits(h, kind);
  return Status::kOk;
}

Status SceneGraph::add_object(NodeId id, const ObjectAttributes& attributes) {
  ObjectAttributes a = attributes;
  a.mesh_connections = MeshConnectionList{};  // connections belong to the graph's pool, not the caller
  return add_node(id, NodeKind::kObject, layer_of(NodeKind::kObject), objects_, a);
}
Status SceneGraph::add_place(NodeId id, const PlaceAttributes& attributes) {
  return add_node(id, NodeKind::kPlace, layer_of(NodeKind::kPlace), places_, attributes);
}
Status SceneGraph::add_room(NodeId id, const RoomAttributes& attributes) {
  return add_node(id, NodeKind::kRoom, layer_of(NodeKind::kRoom), rooms_, attributes);
}
Status SceneGraph::add_building(NodeId id, const BuildingAttributes& attributes) {
  return add_node(id, NodeKind::kBuilding, layer_of(NodeKind::kBuilding), buildings_, attributes);
}
Status SceneGraph::add_agent(NodeId id, char prefix, const AgentAttributes& attributes) {
  return add_node(id, NodeKind::kAgent, layer_of(NodeKind::kAgent, prefix), agents_, attributes);
}

void SceneGraph::count_refused_node(NodeKind kind, std::uint64_t n) {
  const auto count = [&](auto& pool) {
    if (!pool.full() && nodes_.full()) nodes_.count_refused(n);
    else pool.count_refused(n);
  };
  switch (kind) {
    case NodeKind::kObject: count(objects_); break;
    case NodeKind::kAgent: count(agents_); break;
    case NodeKind::kPlace: count(places_); break;
    case NodeKind::kRoom: count(rooms_); break;
    case NodeKind::kBuilding: count(buildings_); break;
  }
}

void SceneGraph::count_refused_edge(std::uint64_t n) {
  if (edges_.full()) edges_.count_refused(n);
  else adjacency_.count_refused(n);  // the edge table has room; its ends' adjacency chunks do not
}

const NodeRecord* SceneGraph::node(NodeId id) const {
  const std::uint32_t* h = node_index_.find(id);
  return h == nullptr ? nullptr : &nodes_[*h];
}

NodeId SceneGraph::parent(NodeId id) const {
  const NodeRecord* n = node(id);
  return n == nullptr ? kNoNode : n->parent;
}

std::size_t SceneGraph::num_nodes(NodeKind kind) const {
  switch (kind) {
    case NodeKind::kObject: return objects_.size();
    case NodeKind::kAgent: return agents_.size();
    case NodeKind::kPlace: return places_.size();
    case NodeKind::kRoom: return rooms_.size();
    case NodeKind::kBuilding: return buildings_.size();
  }
  return 0;
}

std::size_t SceneGraph::num_layer_edges(bool interlayer) const {
  std::size_t count = 0;
  edges_.for_each([&](std::uint32_t, const EdgeRecord& e) {
    if ((nodes_[e.source_node].layer.layer != nodes_[e.target_node].layer.layer) == interlayer) ++count;
  });
  return count;
}

Status SceneGraph::check_layers(const LayerKey& a, const LayerKey& b) {
  if (a.layer == b.layer) return a.partition == b.partition ? Status::kOk : Status::kPartitionMismatch;
  if (a.layer + 1 == b.layer || b.layer + 1 == a.layer) return Status::kOk;
  return Status::kLayersNotAdjacent;
}

bool SceneGraph::has_edge(NodeId a, NodeId b) const { return edge_index_.contains(key_of(a, b)); }

const EdgeRecord* SceneGraph::edge(NodeId a, NodeId b) const {
  const std::uint32_t* h = edge_index_.find(key_of(a, b));
  return h == nullptr ? nullptr : &edges_[*h];
}

EdgeAttributes* SceneGraph::edge_info(NodeId a, NodeId b) {
  const std::uint32_t* h = edge_index_.find(key_of(a, b));
  return h == nullptr ? nullptr : &edges_[*h].info;
}

bool SceneGraph::adjacency_push(NodeRecord& n, std::uint32_t edge) {
  const std::uint32_t slot = n.degree % kAdjacencyChunkEdges;
  if (slot == 0) {
    const std::uint32_t c = adjacency_.acquire();
    if (c == memory::kInvalidHandle) return false;
    adjacency_[c].next = n.adjacency_head;
    n.adjacency_head = c;
  }
  adjacency_[n.adjacency_head].edges[slot] = edge;
  ++n.degree;
  return true;
}

void SceneGraph::adjacency_remove(NodeRecord& n, std::uint32_t edge) {
  // Swap the newest reference (last used slot of the head chunk) into the removed one's place.
  const std::uint32_t last_slot = (n.degree - 1) % kAdjacencyChunkEdges;
  const std::uint32_t last = adjacency_[n.adjacency_head].edges[last_slot];
  std::uint32_t in_chunk = last_slot + 1;
  for (std::uint32_t c = n.adjacency_head; c != memory::kInvalidHandle; c = adjacency_[c].next) {
    for (std::uint32_t i = 0; i < in_chunk; ++i) {
      if (adjacency_[c].edges[i] == edge) {
        adjacency_[c].edges[i] = last;
        --n.degree;
        if (last_slot == 0) {
          const std::uint32_t head = n.adjacency_head;
          n.adjacency_head = adjacency_[head].next;
          adjacency_.release(head);
        }
        return;
      }
    }
    in_chunk = kAdjacencyChunkEdges;
  }
}

Status SceneGraph::add_edge(NodeId a, NodeId b, const EdgeAttributes& info) {
  if (a == b) return Status::kSelfLoop;
  const std::uint32_t* ha = node_index_.find(a);
  const std::uint32_t* hb = node_index_.find(b);
  if (ha == nullptr || hb == nullptr) return Status::kMissingNode;
  NodeRecord& na = nodes_[*ha];
  NodeRecord& nb = nodes_[*hb];
  const Status layers = check_layers(na.layer, nb.layer);
  if (layers != Status::kOk) return layers;
  if (edge_index_.contains(key_of(a, b))) return Status::kDuplicateEdge;
  NodeRecord* child = nullptr;
  NodeId parent_id = kNoNode;
  if (na.layer.layer + 1 == nb.layer.layer) {
    child = &na;
    parent_id = b;
  } else if (nb.layer.layer + 1 == na.layer.layer) {
    child = &nb;
    parent_id = a;
  }
  if (child != nullptr && child->parent != kNoNode) return Status::kParentExists;

  // Every store this edge needs must have room before anything changes.
  const auto chunk_needed = [](const NodeRecord& n) { return n.degree % kAdjacencyChunkEdges == 0 ? 1u : 0u; };
  if (edges_.full() || adjacency_.capacity() - adjacency_.size() < chunk_needed(na) + chunk_needed(nb)) {
    if (edges_.full()) edges_.refuse();
    else adjacency_.refuse(chunk_needed(na) + chunk_needed(nb));
    return Status::kFull;
  }
  const std::uint32_t e = edges_.acquire();
  EdgeRecord& rec = edges_[e];
  rec.source = a;
  rec.target = b;
  rec.source_node = *ha;
  rec.target_node = *hb;
  rec.info = info;
  if (edge_index_.insert(key_of(a, b), e) == nullptr) {
    edges_.release(e);
    return Status::kFull;
  }
  adjacency_push(na, e);
  adjacency_push(nb, e);
  if (child != nullptr) {
    child->parent = parent_id;
    ++nodes_[child == &na ? *hb : *ha].num_children;
  }
  return Status::kOk;
}

void SceneGraph::remove_edge_handle(std::uint32_t e) {
  const EdgeRecord rec = edges_[e];
  NodeRecord& ns = nodes_[rec.source_node];
  NodeRecord& nt = nodes_[rec.target_node];
  if (ns.parent == rec.target) {
    ns.parent = kNoNode;
    --nt.num_children;
    if (ns.kind == NodeKind::kPlace) mark_open(rec.source_node);  // a place without a parent is open
  } else if (nt.parent == rec.source) {
    nt.parent = kNoNode;
    --ns.num_children;
    if (nt.kind == NodeKind::kPlace) mark_open(rec.target_node);
  }
  adjacency_remove(ns, e);
  adjacency_remove(nt, e);
  edge_index_.erase(key_of(rec.source, rec.target));
  edges_.release(e);
}

bool SceneGraph::remove_edge(NodeId a, NodeId b) {
  const std::uint32_t* h = edge_index_.find(key_of(a, b));
  if (h == nullptr) return false;
  remove_edge_handle(*h);
  return true;
}

SceneGraph::MergeResult SceneGraph::merge_into(NodeId into, NodeId from) {
  MergeResult r;
  const std::uint32_t* hi = node_index_.find(into);
  const std::uint32_t* hf = node_index_.find(from);
  if (hi == nullptr || hf == nullptr) {
    r.status = Status::kMissingNode;
    return r;
  }
  if (into == from) {
    r.status = Status::kSelfLoop;
    return r;
  }
  if (nodes_[*hi].kind != nodes_[*hf].kind || nodes_[*hi].layer.layer != nodes_[*hf].layer.layer) {
    r.status = Status::kWrongKind;
    return r;
  }
  const std::uint32_t h = *hf;
  while (nodes_[h].degree > 0) {
    // The newest edge of `from`: removed first (a child's parent edge must go before it can move), then re-added.
    const NodeRecord& n = nodes_[h];
    const EdgeRecord e = edges_[adjacency_[n.adjacency_head].edges[(n.degree - 1) % kAdjacencyChunkEdges]];
    const NodeId other = e.source == from ? e.target : e.source;
    remove_edge(from, other);
    if (other == into || has_edge(into, other)) {
      ++r.dropped;
      continue;
    }
    const Status s = add_edge(into, other, e.info);
    if (s == Status::kOk) ++r.moved;
    else if (s == Status::kFull) ++r.refused;
    else ++r.dropped;  // kParentExists: `into` keeps its own parent
  }
  remove_node(from);
  return r;
}

void SceneGraph::release_attributes(const NodeRecord& n) {
  switch (n.kind) {
    case NodeKind::kObject: objects_.release(n.attributes); break;
    case NodeKind::kAgent: agents_.release(n.attributes); break;
    case NodeKind::kPlace: places_.release(n.attributes); break;
    case NodeKind::kRoom: rooms_.release(n.attributes); break;
    case NodeKind::kBuilding: buildings_.release(n.attributes); break;
  }
}

bool SceneGraph::remove_node(NodeId id) {
  const std::uint32_t* hp = node_index_.find(id);
  if (hp == nullptr) return false;
  const std::uint32_t h = *hp;
  while (nodes_[h].degree > 0) {
    const NodeRecord& n = nodes_[h];
    remove_edge_handle(adjacency_[n.adjacency_head].edges[(n.degree - 1) % kAdjacencyChunkEdges]);
  }
  if (nodes_[h].kind == NodeKind::kObject) clear_mesh_connections(id);
  release_attributes(nodes_[h]);
  clear_slot_bits(h, nodes_[h].kind);
  node_index_.erase(id);
  nodes_.release(h);
  return true;
}

bool SceneGraph::append_mesh_connection(NodeId object_id, std::uint32_t vertex) {
  ObjectAttributes* o = object(object_id);
  if (o == nullptr) return false;
  MeshConnectionList& list = o->mesh_connections;
  const std::uint32_t slot = list.size % kMeshChunkValues;
  if (slot == 0) {
    const std::uint32_t c = mesh_chunks_.acquire();
    if (c == memory::kInvalidHandle) return false;
    mesh_chunks_[c].next = memory::kInvalidHandle;
    if (list.tail == memory::kInvalidHandle) list.head = c;
    else mesh_chunks_[list.tail].next = c;
    list.tail = c;
  }
  mesh_chunks_[list.tail].values[slot] = vertex;
  ++list.size;
  return true;
}

void SceneGraph::clear_mesh_connections(NodeId object_id) {
  ObjectAttributes* o = object(object_id);
  if (o == nullptr) return;
  for (std::uint32_t c = o->mesh_connections.head; c != memory::kInvalidHandle;) {
    const std::uint32_t next = mesh_chunks_[c].next;
    mesh_chunks_.release(c);
    c = next;
  }
  o->mesh_connections = MeshConnectionList{};
}

std::size_t SceneGraph::num_mesh_connections(NodeId object_id) const {
  const ObjectAttributes* o = object(object_id);
  return o == nullptr ? 0 : o->mesh_connections.size;
}

}  // namespace qsg::scene_graph

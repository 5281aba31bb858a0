// K-d tree over place positions and the object/agent-to-place parent edges.
#include "core/frontend/nearest_place_index.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include "core/frontend/incremental_place_index.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::frontend {

namespace {
constexpr std::uint32_t kLeafSize = 8;  // ranges this small are scanned, not split
}

NearestPlaceCapacities nearest_place_capacities_from_budget() {
  NearestPlaceCapacities c;
  c.places = scene_graph::capacities_from_budget().place_nodes;
  return c;
}

memory::ArenaPlan NearestPlaceIndex::plan(const NearestPlaceCapacities& c) {
  memory::ArenaPlan p;
  p.add_array<Point>(c.places);
  p.add_array<std::uint8_t>(c.places);
  return p;
}

bool NearestPlaceIndex::init(const NearestPlaceCapacities& c, std::size_t budget_bytes, std::string* error) {
  if (c.places == 0 || c.places > std::numeric_limits<std::uint32_t>::max() / 2) {
    if (error != nullptr) *error = "nearest place index: capacities.places must be in [1, 2^31)";
    return false;
  }
  if (arena_.sealed()) {
    if (error != nullptr) *error = "nearest place index: init() called twice";
    return false;
  }
  if (!arena_.create("nearest_place_index", plan(c), budget_bytes, error)) return false;
  points_ = arena_.carve_array<Point>(c.places);
  split_dim_ = arena_.carve_array<std::uint8_t>(c.places);
  if (points_ == nullptr || split_dim_ == nullptr || !arena_.seal()) {
    if (error != nullptr) *error = "nearest place index: the arena carve did not match its plan";
    return false;
  }
  capacity_ = c.places;
  return true;
}

void NearestPlaceIndex::build(std::uint32_t lo, std::uint32_t hi) {
  if (hi - lo <= kLeafSize) return;
  // Split on the axis of largest spread at the median: balanced, so depth stays log2(n) (recursion is bounded).
  double mn[3] = {points_[lo].p[0], points_[lo].p[1], points_[lo].p[2]};
  double mx[3] = {mn[0], mn[1], mn[2]};
  for (std::uint32_t i = lo + 1; i < hi; ++i)
    for (int d = 0; d < 3; ++d) {
      mn[d] = std::min(mn[d], points_[i].p[d]);
      mx[d] = std::max(mx[d], points_[i].p[d]);
    }
  int dim = 0;
  for (int d = 1; d < 3; ++d)
    if (mx[d] - mn[d] > mx[dim] - mn[dim]) dim = d;
  const std::uint32_t mid = lo + (hi - lo) / 2;
  std::nth_element(points_ + lo, points_ + mid, points_ + hi,
                   [dim](const Point& a, const Point& b) { return a.p[dim] < b.p[dim]; });
  split_dim_[mid] = static_cast<std::uint8_t>(dim);
  build(lo, mid);
  build(mid + 1, hi);
}

std::size_t NearestPlaceIndex::rebuild(const Eigen::Vector3d* points, const scene_graph::NodeId* ids, std::size_t n) {
  size_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (size_ == capacity_) {
      dropped_ += n - i;
      break;
    }
    if (!points[i].allFinite()) continue;
    Point& p = points_[size_++];
    p.p[0] = points[i].x();
    p.p[1] = points[i].y();
    p.p[2] = points[i].z();
    p.id = ids != nullptr ? ids[i] : static_cast<scene_graph::NodeId>(i);
  }
  build(0, static_cast<std::uint32_t>(size_));
  high_water_ = std::max(high_water_, size_);
  return size_;
}

std::size_t NearestPlaceIndex::rebuild(const scene_graph::SceneGraph& graph, bool active_only) {
  size_ = 0;
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kPlace) return;
    const scene_graph::PlaceAttributes* a = graph.place(n.id);
    if (a == nullptr || (active_only && !a->is_active) || !a->position_m.allFinite()) return;
    if (size_ == capacity_) {
      ++dropped_;
      return;
    }
    Point& p = points_[size_++];
    p.p[0] = a->position_m.x();
    p.p[1] = a->position_m.y();
    p.p[2] = a->position_m.z();
    p.id = n.id;
  });
  build(0, static_cast<std::uint32_t>(size_));
  high_water_ = std::max(high_water_, size_);
  return size_;
}

bool NearestPlaceIndex::add_point(scene_graph::NodeId id, const Eigen::Vector3d& position) {
  if (!position.allFinite()) return false;
  if (size_ == capacity_) {
    ++dropped_;
    return false;
  }
  Point& p = points_[size_++];
  p.p[0] = position.x();
  p.p[1] = position.y();
  p.p[2] = position.z();
  p.id = id;
  return true;
}

std::size_t NearestPlaceIndex::build_tree() {
  build(0, static_cast<std::uint32_t>(size_));
  high_water_ = std::max(high_water_, size_);
  return size_;
}

// The k best so far, sorted by squared distance (insertion into a tiny array beats a heap at k <= 16).
struct NearestPlaceIndex::Best {
  std::size_t k = 1;
  std::size_t n = 0;
  double d2[kMaxK];
  std::uint32_t index[kMaxK];
  double worst() const { return n < k ? std::numeric_limits<double>::infinity() : d2[n - 1]; }
  void offer(double d, std::uint32_t i) {
    if (n == k && d >= d2[n - 1]) return;
    std::size_t j = n < k ? n++ : n - 1;
    while (j > 0 && d2[j - 1] > d) {
      d2[j] = d2[j - 1];
      index[j] = index[j - 1];
      --j;
    }
    d2[j] = d;
    index[j] = i;
  }
};

void NearestPlaceIndex::search(std::uint32_t lo, std::uint32_t hi, const double* q, Best& best) const {
  const auto offer = [&](std::uint32_t i) {
    const double dx = points_[i].p[0] - q[0], dy = points_[i].p[1] - q[1], dz = points_[i].p[2] - q[2];
    best.offer(dx * dx + dy * dy + dz * dz, i);
  };
  if (hi - lo <= kLeafSize) {
    for (std::uint32_t i = lo; i < hi; ++i) offer(i);
    return;
  }
  const std::uint32_t mid = lo + (hi - lo) / 2;
  const int dim = split_dim_[mid];
  const double diff = q[dim] - points_[mid].p[dim];
  offer(mid);
  if (diff < 0) {
    search(lo, mid, q, best);
    if (diff * diff < best.worst()) search(mid + 1, hi, q, best);
  } else {
    search(mid + 1, hi, q, best);
    if (diff * diff < best.worst()) search(lo, mid, q, best);
  }
}

std::size_t NearestPlaceIndex::nearest(const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out) const {
  if (size_ == 0 || k == 0 || out == nullptr || !q.allFinite()) return 0;
  Best best;
  best.k = std::min(k, kMaxK);
  const double qq[3] = {q.x(), q.y(), q.z()};
  search(0, static_cast<std::uint32_t>(size_), qq, best);
  for (std::size_t i = 0; i < best.n; ++i) {
    out[i].id = points_[best.index[i]].id;
    out[i].distance_m = std::sqrt(best.d2[i]);
  }
  return best.n;
}

namespace {
std::size_t free_adjacency_chunks(const scene_graph::SceneGraph& graph) {
  std::size_t free_chunks = 0;
  graph.for_each_resource([&](const memory::ResourceStats& s) {
    if (std::strcmp(s.name, "scene_graph.adjacency_chunks") == 0) free_chunks = s.capacity - s.in_use;
  });
  return free_chunks;
}
}  // namespace

namespace {
// find(position, k, out) -> the k nearest candidates.
template <typename Find>
ConnectStats connect_nodes(scene_graph::SceneGraph* graph, Find&& find, const scene_graph::NodeId* nodes,
                           std::size_t count) {
  ConnectStats stats;
  if (graph == nullptr || nodes == nullptr) return stats;
  for (std::size_t i = 0; i < count; ++i) {
    const scene_graph::NodeId id = nodes[i];
    Eigen::Vector3d position;
    if (const scene_graph::ObjectAttributes* o = graph->object(id)) position = o->position_m;
    else if (const scene_graph::AgentAttributes* a = graph->agent(id)) position = a->position_m;
    else {
      ++stats.no_place;
      continue;
    }
    PlaceNeighbor candidates[kParentCandidates];
    const std::size_t found = find(position, kParentCandidates, candidates);
    PlaceNeighbor nearest;
    double best_gap = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < found; ++c) {
      const scene_graph::PlaceAttributes* p = graph->place(candidates[c].id);
      if (p == nullptr) continue;
      const double gap = candidates[c].distance_m - std::max(0.0, p->distance_m);
      if (gap < best_gap) {
        best_gap = gap;
        nearest = candidates[c];
      }
    }
    if (nearest.id == scene_graph::kNoNode) {
      ++stats.no_place;
      continue;
    }
    const scene_graph::NodeId parent = graph->parent(id);
    if (parent == nearest.id) {
      ++stats.unchanged;
      continue;
    }
    // Room for the new edge (the removed one frees its slot only after it is gone; check without counting it).
    const scene_graph::Capacities& gc = graph->capacities();
    if (parent == scene_graph::kNoNode && (graph->num_edges() >= gc.edges || free_adjacency_chunks(*graph) < 2)) {
      graph->count_refused_edge();  // shown under the store's own name
      ++stats.failed;
      continue;
    }
    if (parent != scene_graph::kNoNode) graph->remove_edge(id, parent);
    if (graph->num_edges() >= gc.edges || free_adjacency_chunks(*graph) < 2 ||
        graph->add_edge(id, nearest.id) != scene_graph::Status::kOk) {
      if (graph->num_edges() >= gc.edges || free_adjacency_chunks(*graph) < 2) graph->count_refused_edge();
      ++stats.failed;
      continue;
    }
    ++stats.connected;
  }
  return stats;
}

}  // namespace

ConnectStats connect_to_nearest_places(scene_graph::SceneGraph* graph, const NearestPlaceIndex& index,
                                       const scene_graph::NodeId* nodes, std::size_t count) {
  return connect_nodes(
      graph, [&](const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out) { return index.nearest(q, k, out); },
      nodes, count);
}

ConnectStats connect_to_nearest_places(scene_graph::SceneGraph* graph, const IncrementalPlaceIndex& index,
                                       const scene_graph::NodeId* nodes, std::size_t count) {
  if (graph == nullptr) return ConnectStats{};
  const scene_graph::SceneGraph& g = *graph;
  const auto in_graph = [&g](scene_graph::NodeId id) { return g.place(id) != nullptr; };
  return connect_nodes(
      graph,
      [&](const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out) { return index.nearest(q, k, out, in_graph); },
      nodes, count);
}

}  // namespace qsg::frontend

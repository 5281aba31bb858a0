// H-tree construction (mirrors bench/neural_tree/htree.py step by step so PyTorch and C++ see the same tree).
#include "core/neural_tree/h_tree.h"

#include <algorithm>
#include <cinttypes>

namespace qsg::neural_tree {
namespace {

bool sorted_subset(const std::int32_t* a, int na, const std::int32_t* b, int nb) {
  int j = 0;
  for (int i = 0; i < na; ++i) {
    while (j < nb && b[j] < a[i]) ++j;
    if (j == nb || b[j] != a[i]) return false;
  }
  return true;
}

std::uint8_t node_type(const LayeredGraph& graph, const std::int32_t* members, int count) {
  if (count == 1) {
    switch (graph.layers[members[0]]) {
      case NodeLayer::kObject: return kLeafObject;
      case NodeLayer::kRoom: return kLeafRoom;
      default: return kLeafBuilding;
    }
  }
  int rooms = 0, objects = 0;
  for (int i = 0; i < count; ++i) {
    rooms += graph.layers[members[i]] == NodeLayer::kRoom;
    objects += graph.layers[members[i]] == NodeLayer::kObject;
  }
  if (objects == count) return kBagObjects;
  if (rooms == 1 && objects == count - 1) return kBagRoomObjects;
  return kBagRooms;
}

}  // namespace

int BagTree::width() const {
  int w = -1;
  for (int k = 0; k < num_bags(); ++k) w = std::max(w, bag_size(k) - 1);
  return w;
}

void HTreeBuilder::Config::print(std::FILE* out) const {
  std::fprintf(out, "HTreeBuilder::Config: max_graph_nodes=%d max_htree_nodes=%d max_member_entries=%d\n",
               max_graph_nodes, max_htree_nodes, max_member_entries);
}

HTreeBuilder::HTreeBuilder() : HTreeBuilder(Config()) {}

HTreeBuilder::HTreeBuilder(const Config& config) : config_(config) {
  const auto n = static_cast<std::size_t>(std::max(config_.max_graph_nodes, 1));
  const std::size_t words = (n + 63) / 64;
  adjacency_bits_.reserve(n * words);
  csr_begin_.reserve(n + 1);
  csr_neighbours_.reserve(n * 8);
  local_adjacency_.reserve(n * n);
  for (auto* v : {&degree_, &order_, &position_, &parent_, &kept_index_, &children_, &top_vertices_, &all_vertices_,
                 &bag_members_})
    v->reserve(n);
  bag_buffer_.reserve(2 * n);
  elim_begin_.reserve(n + 1);
  elim_members_.reserve(n * 8);
  eliminated_.reserve(n);
  alive_.reserve(n);
  const auto bags = static_cast<std::size_t>(config_.max_htree_nodes);
  const auto entries = static_cast<std::size_t>(config_.max_member_entries);
  for (BagTree* t : {&sub_tree_, &split_tree_}) {
    t->begin.reserve(n + 1);
    t->members.reserve(entries / 4 + n);
    t->edge_parent.reserve(entries / 4 + n);
    t->edge_child.reserve(entries / 4 + n);
  }
  queue_.reserve(bags);
}

bool HTreeBuilder::adjacent(int a, int b) const {
  return (adjacency_bits_[static_cast<std::size_t>(a) * words_per_row_ + (b >> 6)] >> (b & 63)) & 1u;
}

bool HTreeBuilder::prepare_adjacency(const LayeredGraph& graph, std::string* error) {
  num_nodes_ = graph.num_nodes();
  if (num_nodes_ > config_.max_graph_nodes) {
    if (error) *error = "h_tree: " + std::to_string(num_nodes_) + " graph nodes exceed max_graph_nodes " +
                        std::to_string(config_.max_graph_nodes);
    return false;
  }
  if (graph.edge_a.size() != graph.edge_b.size()) {
    if (error) *error = "h_tree: edge_a and edge_b differ in length";
    return false;
  }
  graph_ = &graph;
  words_per_row_ = (num_nodes_ + 63) / 64;
  adjacency_bits_.assign(static_cast<std::size_t>(num_nodes_) * words_per_row_, 0u);
  for (std::size_t k = 0; k < graph.edge_a.size(); ++k) {
    const int a = graph.edge_a[k], b = graph.edge_b[k];
    if (a < 0 || b < 0 || a >= num_nodes_ || b >= num_nodes_) {
      if (error) *error = "h_tree: edge " + std::to_string(k) + " (" + std::to_string(a) + "," + std::to_string(b) +
                          ") names a node outside 0.." + std::to_string(num_nodes_ - 1);
      return false;
    }
    if (a == b) continue;
    adjacency_bits_[static_cast<std::size_t>(a) * words_per_row_ + (b >> 6)] |= std::uint64_t{1} << (b & 63);
    adjacency_bits_[static_cast<std::size_t>(b) * words_per_row_ + (a >> 6)] |= std::uint64_t{1} << (a & 63);
  }
  // Sorted neighbour lists, read off the bit rows.
  csr_begin_.assign(1, 0);
  csr_neighbours_.clear();
  for (int a = 0; a < num_nodes_; ++a) {
    for (int w = 0; w < words_per_row_; ++w) {
      std::uint64_t bits = adjacency_bits_[static_cast<std::size_t>(a) * words_per_row_ + w];
      while (bits) {
        const int bit = __builtin_ctzll(bits);
        csr_neighbours_.push_back(w * 64 + bit);
        bits &= bits - 1;
      }
    }
    csr_begin_.push_back(static_cast<std::int32_t>(csr_neighbours_.size()));
  }
  return true;
}

bool HTreeBuilder::is_complete(const std::int32_t* members, int count) const {
  for (int i = 0; i < count; ++i)
    for (int j = i + 1; j < count; ++j)
      if (!adjacent(members[i], members[j])) return false;
  return true;
}

bool HTreeBuilder::decompose(const std::int32_t* vertices, int k, BagTree* out, std::string* error) {
  if (k == 0) return true;
  const auto kk = static_cast<std::size_t>(k);
  local_adjacency_.assign(kk * kk, 0);
  degree_.assign(kk, 0);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      if (i != j && adjacent(vertices[i], vertices[j])) {
        local_adjacency_[i * kk + j] = 1;
        ++degree_[i];
      }
  eliminated_.assign(kk, 0);
  order_.assign(kk, 0);
  position_.assign(kk, 0);
  elim_begin_.assign(kk + 1, 0);
  elim_members_.clear();
  // Min-degree elimination; ties go to the smallest vertex id (vertices are sorted, so the smallest local index).
  for (int step = 0; step < k; ++step) {
    int v = -1;
    for (int i = 0; i < k; ++i)
      if (!eliminated_[i] && (v < 0 || degree_[i] < degree_[v])) v = i;
    const auto first = static_cast<std::int32_t>(elim_members_.size());
    for (int j = 0; j < k; ++j)
      if (!eliminated_[j] && local_adjacency_[v * kk + j]) elim_members_.push_back(j);
    const auto last = static_cast<std::int32_t>(elim_members_.size());
    for (int p = first; p < last; ++p) {
      const int a = elim_members_[p];
      local_adjacency_[a * kk + v] = 0;
      --degree_[a];
    }
    for (int p = first; p < last; ++p)
      for (int q = first; q < last; ++q) {
        const int a = elim_members_[p], b = elim_members_[q];
        if (a != b && !local_adjacency_[a * kk + b]) {
          local_adjacency_[a * kk + b] = 1;
          ++degree_[a];
        }
      }
    eliminated_[v] = 1;
    order_[step] = v;
    position_[v] = step;
    elim_begin_[step] = first;
    elim_begin_[step + 1] = last;
  }
  // Parent of a bag: the bag of its earliest-eliminated neighbour; roots hang under the last root.
  parent_.assign(kk, -1);
  int top = -1;
  for (int step = k - 1; step >= 0 && top < 0; --step)
    if (elim_begin_[step] == elim_begin_[step + 1]) top = order_[step];
  for (int step = 0; step < k; ++step) {
    const int v = order_[step];
    int best = -1;
    for (int p = elim_begin_[step]; p < elim_begin_[step + 1]; ++p) {
      const int u = elim_members_[p];
      if (best < 0 || position_[u] < position_[best]) best = u;
    }
    parent_[v] = best >= 0 ? best : (v == top ? -1 : top);
  }
  // Bag of local vertex v: {v} + its elimination neighbours, as sorted local indices (sorted local = sorted global).
  auto bag_of = [&](int v, std::int32_t* buffer) {
    const int step = position_[v];
    int n = 0;
    bool placed = false;
    for (int p = elim_begin_[step]; p < elim_begin_[step + 1]; ++p) {
      if (!placed && v < elim_members_[p]) {
        buffer[n++] = v;
        placed = true;
      }
      buffer[n++] = elim_members_[p];
    }
    if (!placed) buffer[n++] = v;
    return n;
  };
  // Contract a parent bag into the first child (in elimination order) that contains it, top-down.
  alive_.assign(kk, 1);
  bag_buffer_.resize(2 * kk);
  std::int32_t* bag_u = bag_buffer_.data();
  std::int32_t* bag_c = bag_u + k;
  for (int s = k - 1; s >= 0; --s) {
    const int u = order_[s];
    if (!alive_[u]) continue;
    const int nu = bag_of(u, bag_u);
    int sup = -1;
    children_.clear();
    for (int t = 0; t < k; ++t) {
      const int c = order_[t];
      if (!alive_[c] || parent_[c] != u) continue;
      children_.push_back(c);
      if (sup < 0) {
        const int nc = bag_of(c, bag_c);
        if (sorted_subset(bag_u, nu, bag_c, nc)) sup = c;
      }
    }
    if (sup < 0) continue;
    parent_[sup] = parent_[u];
    for (const int c : children_)
      if (c != sup) parent_[c] = sup;
    alive_[u] = 0;
  }
  // Emit kept bags root first (reverse elimination order).
  const int base = out->num_bags();
  kept_index_.assign(kk, -1);
  int kept = 0;
  for (int s = k - 1; s >= 0; --s)
    if (alive_[order_[s]]) kept_index_[order_[s]] = kept++;
  int needed = 0;
  for (int s = 0; s < k; ++s)
    if (alive_[order_[s]]) needed += elim_begin_[s + 1] - elim_begin_[s] + 1;
  if (out->members.size() + static_cast<std::size_t>(needed) > static_cast<std::size_t>(config_.max_member_entries) ||
      out->num_bags() + kept > config_.max_htree_nodes) {
    if (error) *error = "h_tree: tree decomposition exceeds max_htree_nodes / max_member_entries";
    return false;
  }
  for (int s = k - 1; s >= 0; --s) {
    const int v = order_[s];
    if (!alive_[v]) continue;
    const int n = bag_of(v, bag_u);
    for (int i = 0; i < n; ++i) out->members.push_back(vertices[bag_u[i]]);
    out->begin.push_back(static_cast<std::int32_t>(out->members.size()));
  }
  for (int s = k - 1; s >= 0; --s) {
    const int v = order_[s];
    if (!alive_[v] || parent_[v] < 0) continue;
    out->edge_parent.push_back(base + kept_index_[parent_[v]]);
    out->edge_child.push_back(base + kept_index_[v]);
  }
  return true;
}

bool HTreeBuilder::hierarchical(const std::int32_t* vertices, int count, BagTree* out, std::string* error) {
  const LayeredGraph& graph = *graph_;
  if (count == 0) return true;
  int top_layer = 0;
  for (int i = 0; i < count; ++i) top_layer = std::max(top_layer, static_cast<int>(graph.layers[vertices[i]]));
  top_vertices_.clear();
  for (int i = 0; i < count; ++i)
    if (static_cast<int>(graph.layers[vertices[i]]) == top_layer) top_vertices_.push_back(vertices[i]);
  const int base = out->num_bags();
  if (!decompose(top_vertices_.data(), static_cast<int>(top_vertices_.size()), out, error)) return false;
  for (int layer = top_layer; layer > static_cast<int>(NodeLayer::kObject); --layer) {
    for (int i = 0; i < count; ++i) {
      const int v = vertices[i];
      if (static_cast<int>(graph.layers[v]) != layer) continue;
      children_.clear();
      for (int p = csr_begin_[v]; p < csr_begin_[v + 1]; ++p) {
        const int u = csr_neighbours_[p];
        if (static_cast<int>(graph.layers[u]) == layer - 1 && std::binary_search(vertices, vertices + count, u))
          children_.push_back(u);
      }
      if (children_.empty()) continue;
      // decompose() reuses children_ as scratch: hand it a copy.
      top_vertices_.assign(children_.begin(), children_.end());
      sub_tree_.clear();
      if (!decompose(top_vertices_.data(), static_cast<int>(top_vertices_.size()), &sub_tree_, error)) return false;
      int attach = -1;
      for (int k = base; k < out->num_bags() && attach < 0; ++k)
        if (std::binary_search(out->bag(k), out->bag(k) + out->bag_size(k), v)) attach = k;
      const std::size_t extra = sub_tree_.members.size() + static_cast<std::size_t>(sub_tree_.num_bags());
      if (out->members.size() + extra > static_cast<std::size_t>(config_.max_member_entries) ||
          out->num_bags() + sub_tree_.num_bags() > config_.max_htree_nodes) {
        if (error) *error = "h_tree: hierarchical decomposition exceeds max_htree_nodes / max_member_entries";
        return false;
      }
      const int offset = out->num_bags();
      for (int k = 0; k < sub_tree_.num_bags(); ++k) {
        const std::int32_t* b = sub_tree_.bag(k);
        const int n = sub_tree_.bag_size(k);
        bool placed = false;
        for (int j = 0; j < n; ++j) {
          if (!placed && v < b[j]) {
            out->members.push_back(v);
            placed = true;
          }
          out->members.push_back(b[j]);
        }
        if (!placed) out->members.push_back(v);
        out->begin.push_back(static_cast<std::int32_t>(out->members.size()));
      }
      for (std::size_t e = 0; e < sub_tree_.edge_parent.size(); ++e) {
        out->edge_parent.push_back(offset + sub_tree_.edge_parent[e]);
        out->edge_child.push_back(offset + sub_tree_.edge_child[e]);
      }
      out->edge_parent.push_back(attach);
      out->edge_child.push_back(offset);
    }
  }
  return true;
}

bool HTreeBuilder::hierarchical_decomposition(const LayeredGraph& graph, const std::int32_t* vertices, int count,
                                              BagTree* out, std::string* error) {
  return prepare_adjacency(graph, error) && hierarchical(vertices, count, out, error);
}

bool HTreeBuilder::build(const LayeredGraph& graph, HTree* out, std::string* error) {
  out->clear();
  if (out->tree.begin.capacity() < static_cast<std::size_t>(config_.max_htree_nodes) + 1) {
    // First use of this HTree: size it once (later builds reuse the storage).
    out->tree.begin.reserve(static_cast<std::size_t>(config_.max_htree_nodes) + 1);
    out->tree.members.reserve(static_cast<std::size_t>(config_.max_member_entries));
    out->tree.edge_parent.reserve(static_cast<std::size_t>(config_.max_htree_nodes));
    out->tree.edge_child.reserve(static_cast<std::size_t>(config_.max_htree_nodes));
    out->types.reserve(static_cast<std::size_t>(config_.max_htree_nodes));
  }
  if (!prepare_adjacency(graph, error)) return false;
  if (num_nodes_ == 0) return true;
  BagTree& tree = out->tree;
  auto fail = [&](const char* what) {
    if (error) *error = std::string("h_tree: ") + what;
    out->clear();
    return false;
  };
  all_vertices_.clear();
  for (int v = 0; v < num_nodes_; ++v) all_vertices_.push_back(v);
  if (!hierarchical(all_vertices_.data(), num_nodes_, &tree, error)) {
    out->clear();
    return false;
  }
  out->width = tree.width();
  for (int k = 0; k < tree.num_bags(); ++k) out->types.push_back(node_type(graph, tree.bag(k), tree.bag_size(k)));
  queue_.clear();
  for (int k = 0; k < tree.num_bags(); ++k) queue_.push_back(k);
  const auto max_nodes = static_cast<std::size_t>(config_.max_htree_nodes);
  const auto max_entries = static_cast<std::size_t>(config_.max_member_entries);
  // Breadth-first over bags: split each until its pieces are single graph nodes.
  for (std::size_t head = 0; head < queue_.size(); ++head) {
    const int node = queue_[head];
    const int size = tree.bag_size(node);
    if (size == 1) continue;
    bag_members_.assign(tree.bag(node), tree.bag(node) + size);
    bool use_split = false;
    if (!is_complete(bag_members_.data(), size)) {
      split_tree_.clear();
      if (!hierarchical(bag_members_.data(), size, &split_tree_, error)) {
        out->clear();
        return false;
      }
      use_split = split_tree_.width() + 1 < size;  // no progress: split into leaves instead
    }
    if (!use_split) {
      if (tree.begin.size() + bag_members_.size() > max_nodes + 1 ||
          tree.members.size() + bag_members_.size() > max_entries)
        return fail("H-tree exceeds max_htree_nodes / max_member_entries");
      for (const std::int32_t m : bag_members_) {
        tree.members.push_back(m);
        tree.begin.push_back(static_cast<std::int32_t>(tree.members.size()));
        out->types.push_back(node_type(graph, &m, 1));
        tree.edge_parent.push_back(node);
        tree.edge_child.push_back(tree.num_bags() - 1);
      }
      continue;
    }
    const BagTree& split = split_tree_;
    if (tree.begin.size() + static_cast<std::size_t>(split.num_bags()) > max_nodes + 1 ||
        tree.members.size() + split.members.size() > max_entries)
      return fail("H-tree exceeds max_htree_nodes / max_member_entries");
    const int sub_base = tree.num_bags();
    for (int k = 0; k < split.num_bags(); ++k) {
      tree.members.insert(tree.members.end(), split.bag(k), split.bag(k) + split.bag_size(k));
      tree.begin.push_back(static_cast<std::int32_t>(tree.members.size()));
      out->types.push_back(node_type(graph, split.bag(k), split.bag_size(k)));
      queue_.push_back(sub_base + k);
    }
    for (std::size_t e = 0; e < split.edge_parent.size(); ++e) {
      tree.edge_parent.push_back(sub_base + split.edge_parent[e]);
      tree.edge_child.push_back(sub_base + split.edge_child[e]);
    }
    tree.edge_parent.push_back(node);
    tree.edge_child.push_back(sub_base);
  }
  return true;
}

namespace {

// "" when the undirected edges over `n` nodes form a tree.
std::string check_is_tree(int n, const std::vector<std::int32_t>& ea, const std::vector<std::int32_t>& eb,
                          const char* what) {
  if (n == 0) return ea.empty() ? "" : std::string(what) + ": edges without nodes";
  if (static_cast<int>(ea.size()) != n - 1)
    return std::string(what) + " is not a tree: " + std::to_string(n) + " nodes, " + std::to_string(ea.size()) +
           " edges";
  std::vector<int> root(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) root[i] = i;
  auto find = [&](int x) {
    while (root[x] != x) x = root[x] = root[root[x]];
    return x;
  };
  for (std::size_t e = 0; e < ea.size(); ++e) {
    if (ea[e] < 0 || eb[e] < 0 || ea[e] >= n || eb[e] >= n) return std::string(what) + ": edge out of range";
    const int a = find(ea[e]), b = find(eb[e]);
    if (a == b) return std::string(what) + " is not a tree: edge " + std::to_string(e) + " closes a cycle";
    root[a] = b;
  }
  return "";
}

}  // namespace

std::string check_tree_decomposition(const LayeredGraph& graph, const std::vector<std::int32_t>& vertices,
                                     const BagTree& tree) {
  const int n = tree.num_bags();
  if (n == 0) return vertices.empty() ? "" : "no bags";
  std::string r = check_is_tree(n, tree.edge_parent, tree.edge_child, "tree decomposition");
  if (!r.empty()) return r;
  std::vector<std::uint8_t> in_set(graph.layers.size(), 0);
  for (const int v : vertices) in_set[v] = 1;
  std::vector<std::vector<int>> bags_of(graph.layers.size());
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < tree.bag_size(k); ++i) {
      const int v = tree.bag(k)[i];
      if (v < 0 || v >= graph.num_nodes() || !in_set[v])
        return "bag " + std::to_string(k) + " holds vertex " + std::to_string(v) + " outside the graph";
      if (i > 0 && tree.bag(k)[i - 1] >= v) return "bag " + std::to_string(k) + " is not sorted and unique";
      bags_of[v].push_back(k);
    }
  // Each vertex: in some bag, and its bags connected (edges among them = count - 1 in a tree).
  std::vector<std::uint8_t> holds(static_cast<std::size_t>(n), 0);
  for (const int v : vertices) {
    if (bags_of[v].empty()) return "vertex " + std::to_string(v) + " is in no bag";
    for (const int k : bags_of[v]) holds[k] = 1;
    std::size_t inner = 0;
    for (std::size_t e = 0; e < tree.edge_parent.size(); ++e)
      inner += holds[tree.edge_parent[e]] && holds[tree.edge_child[e]];
    for (const int k : bags_of[v]) holds[k] = 0;
    if (inner + 1 != bags_of[v].size()) return "the bags of vertex " + std::to_string(v) + " are not connected";
  }
  for (std::size_t e = 0; e < graph.edge_a.size(); ++e) {
    const int a = graph.edge_a[e], b = graph.edge_b[e];
    if (a == b || !in_set[a] || !in_set[b]) continue;
    bool covered = false;
    for (const int k : bags_of[a])
      covered = covered || std::binary_search(tree.bag(k), tree.bag(k) + tree.bag_size(k), b);
    if (!covered) return "edge (" + std::to_string(a) + "," + std::to_string(b) + ") is in no bag";
  }
  return "";
}

std::string check_h_tree(const LayeredGraph& graph, const HTree& h_tree) {
  const int n = h_tree.num_nodes();
  if (graph.num_nodes() == 0) return n == 0 ? "" : "H-tree of an empty graph has nodes";
  std::string r = check_is_tree(n, h_tree.tree.edge_parent, h_tree.tree.edge_child, "H-tree");
  if (!r.empty()) return r;
  if (static_cast<int>(h_tree.types.size()) != n) return "H-tree types and nodes differ in count";
  std::vector<std::uint8_t> covered(graph.layers.size(), 0);
  for (int k = 0; k < n; ++k)
    if (h_tree.tree.bag_size(k) == 1) covered[h_tree.tree.bag(k)[0]] = 1;
  for (int v = 0; v < graph.num_nodes(); ++v)
    if (!covered[v]) return "graph node " + std::to_string(v) + " has no leaf in the H-tree";
  return "";
}

}  // namespace qsg::neural_tree

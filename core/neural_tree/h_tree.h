// H-tree of an object-room(-building) graph: the paper's hierarchical tree decomposition (Algorithm 1) with every
// bag split further until the leaves are single graph nodes; the tree the neural tree passes messages on.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "budgets/budget_table.h"

namespace qsg::neural_tree {

// Layers of the hierarchical graph, bottom to top (the paper's V_1..V_3 of the object-room-building graph).
enum class NodeLayer : std::uint8_t { kObject = 1, kRoom = 2, kBuilding = 3 };

// H-tree node types (one-hot input to the network); mirrored in bench/neural_tree/htree.py.
enum HTreeNodeType : std::uint8_t {
  kLeafObject = 0,
  kLeafRoom = 1,
  kLeafBuilding = 2,
  kBagObjects = 3,      // objects only
  kBagRoomObjects = 4,  // exactly one room plus objects
  kBagRooms = 5,        // rooms (and possibly the building), or any other mix
  kNumHTreeNodeTypes = 6,
};

// Undirected graph with a layer per node. Must be hierarchical (single parent, locality, disjoint children);
// the classifier's input builder guarantees it.
struct LayeredGraph {
  std::vector<NodeLayer> layers;
  std::vector<std::int32_t> edge_a;  // undirected edges (edge_a[k], edge_b[k])
  std::vector<std::int32_t> edge_b;

  void clear() {
    layers.clear();
    edge_a.clear();
    edge_b.clear();
  }
  int num_nodes() const { return static_cast<int>(layers.size()); }
};

// A tree decomposition (or a tree of bags): bag k holds members[begin[k] .. begin[k + 1]), sorted ascending.
struct BagTree {
  std::vector<std::int32_t> begin{0};
  std::vector<std::int32_t> members;
  std::vector<std::int32_t> edge_parent;  // tree edges (edge_parent[k], edge_child[k])
  std::vector<std::int32_t> edge_child;

  void clear() {
    begin.assign(1, 0);
    members.clear();
    edge_parent.clear();
    edge_child.clear();
  }
  int num_bags() const { return static_cast<int>(begin.size()) - 1; }
  int bag_size(int k) const { return begin[k + 1] - begin[k]; }
  const std::int32_t* bag(int k) const { return members.data() + begin[k]; }
  int width() const;  // largest bag size - 1 (-1 when empty)
};

// The H-tree: bags of the hierarchical decomposition and their recursive splits; nodes with one member are the
// leaves a graph node's label is pooled from (a graph node usually has several).
struct HTree {
  BagTree tree;
  std::vector<std::uint8_t> types;  // HTreeNodeType per node
  int width = -1;                   // width of the top-level decomposition (Algorithm 1)
  void clear() {
    tree.clear();
    types.clear();
    width = -1;
  }
  int num_nodes() const { return tree.num_bags(); }
};

// Builds H-trees into preallocated storage: after construction it does not allocate while the inputs stay within
// Config; beyond it, build() fails with a message instead.
class HTreeBuilder {
 public:
  struct Config {
    // Capacities: the budget table's "rooms" arena (budgets/<board>.json), or a test's own.
    int max_graph_nodes = static_cast<int>(budgets::active::rooms::kHtreeGraphNodes);  // objects + rooms + building
    // 30 rooms with 300 objects take about 1,000
    int max_htree_nodes = static_cast<int>(budgets::active::rooms::kHtreeNodes);
    int max_member_entries = static_cast<int>(budgets::active::rooms::kHtreeMemberEntries);  // bag sizes summed
    void print(std::FILE* out) const;
  };

  HTreeBuilder();
  explicit HTreeBuilder(const Config& config);

  // Returns false with a reason (capacity exceeded, bad edge) and leaves `out` empty on failure.
  bool build(const LayeredGraph& graph, HTree* out, std::string* error);

  // Algorithm 1 alone on graph[vertices] (sorted ascending), appended to `out`; exposed for tests.
  bool hierarchical_decomposition(const LayeredGraph& graph, const std::int32_t* vertices, int count, BagTree* out,
                                  std::string* error);

  const Config& config() const { return config_; }

 private:
  bool prepare_adjacency(const LayeredGraph& graph, std::string* error);
  // Algorithm 1 on the prepared graph restricted to `vertices` (sorted).
  bool hierarchical(const std::int32_t* vertices, int count, BagTree* out, std::string* error);
  bool adjacent(int a, int b) const;
  // Min-degree elimination tree decomposition of graph[vertices] (sorted); root bag first; appended to `out`.
  bool decompose(const std::int32_t* vertices, int count, BagTree* out, std::string* error);
  bool is_complete(const std::int32_t* members, int count) const;

  Config config_;
  int num_nodes_ = 0;
  int words_per_row_ = 0;
  const LayeredGraph* graph_ = nullptr;
  std::vector<std::uint64_t> adjacency_bits_;  // num_nodes x num_nodes bit matrix
  std::vector<std::int32_t> csr_begin_, csr_neighbours_;
  // Scratch for decompose() and hierarchical_decomposition().
  std::vector<std::uint8_t> local_adjacency_;
  std::vector<std::int32_t> degree_, order_, position_, parent_, elim_begin_, elim_members_, kept_index_;
  std::vector<std::uint8_t> eliminated_, alive_;
  std::vector<std::int32_t> children_, top_vertices_, all_vertices_, bag_members_, bag_buffer_;
  BagTree sub_tree_, split_tree_;
  std::vector<std::int32_t> queue_;
};

// Checks that `tree` is a tree and a valid tree decomposition of graph[vertices]: every vertex in a bag, every
// edge inside one bag, each vertex's bags connected, no foreign vertex. Returns "" when valid, else the reason.
std::string check_tree_decomposition(const LayeredGraph& graph, const std::vector<std::int32_t>& vertices,
                                     const BagTree& tree);
// Checks that the H-tree is a tree and its single-member leaves cover every graph node. "" when valid.
std::string check_h_tree(const LayeredGraph& graph, const HTree& h_tree);

}  // namespace qsg::neural_tree

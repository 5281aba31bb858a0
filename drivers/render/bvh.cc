// Binned surface-area-heuristic build of the flat BVH (see bvh.h).
#include "drivers/render/bvh.h"

#include <cmath>
#include <limits>

namespace qsg::render {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

Aabb empty_box() {
  Aabb b;
  for (int k = 0; k < 3; ++k) {
    b.min_m[k] = kInf;
    b.max_m[k] = -kInf;
  }
  return b;
}

void grow(Aabb& b, const Aabb& o) {
  for (int k = 0; k < 3; ++k) {
    b.min_m[k] = std::min(b.min_m[k], o.min_m[k]);
    b.max_m[k] = std::max(b.max_m[k], o.max_m[k]);
  }
}

float half_area(const Aabb& b) {
  const float dx = b.max_m[0] - b.min_m[0];
  const float dy = b.max_m[1] - b.min_m[1];
  const float dz = b.max_m[2] - b.min_m[2];
  if (!(dx >= 0.0f && dy >= 0.0f && dz >= 0.0f)) return 0.0f;
  return dx * dy + dy * dz + dz * dx;
}

}  // namespace

void Bvh::Config::print(std::FILE* out) const {
  std::fprintf(out, "bvh: num_bins=%d max_leaf_items=%d traversal_cost=%g\n", num_bins, max_leaf_items,
               static_cast<double>(traversal_cost));
}

BvhRay Bvh::make_ray(const double origin_m[3], const double direction[3]) {
  BvhRay r;
  for (int k = 0; k < 3; ++k) {
    r.origin_m[k] = static_cast<float>(origin_m[k]);
    // A zero component would give 0 * inf = NaN in the slab test; a tiny one keeps the arithmetic finite.
    float d = static_cast<float>(direction[k]);
    if (std::fabs(d) < 1e-30f) d = std::signbit(d) ? -1e-30f : 1e-30f;
    r.inv_dir[k] = 1.0f / d;
    r.near_bound[k] = 2 * k + (d < 0.0f ? 1 : 0);
  }
  return r;
}

void Bvh::build(const std::vector<Aabb>& boxes, const Config& config) {
  nodes_.clear();
  wide_.clear();
  item_order_.clear();
  depth_ = 0;
  num_leaves_ = 0;
  if (boxes.empty()) return;
  std::vector<BuildItem> items(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    items[i].box = boxes[i];
    for (int k = 0; k < 3; ++k) items[i].centroid[k] = 0.5f * (boxes[i].min_m[k] + boxes[i].max_m[k]);
    items[i].id = static_cast<std::uint32_t>(i);
  }
  nodes_.reserve(2 * boxes.size());
  build_recursive(items, 0, static_cast<std::uint32_t>(items.size()), 1, config);
  item_order_.resize(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) item_order_[i] = items[i].id;
  nodes_.shrink_to_fit();
  wide_.reserve(nodes_.size() / 2 + 1);
  collapse(0);
  wide_.shrink_to_fit();
}

// Turns the binary subtree at `binary_node` into wide nodes: repeatedly opens the largest inner child until
// four children are gathered (or only leaves remain).
std::uint32_t Bvh::collapse(std::uint32_t binary_node) {
  const std::uint32_t self = static_cast<std::uint32_t>(wide_.size());
  wide_.push_back(BvhWideNode{});
  std::uint32_t kids[4];
  int n = 0;
  if (nodes_[binary_node].count > 0) {
    kids[n++] = binary_node;  // a tree that is a single leaf
  } else {
    kids[n++] = binary_node + 1;
    kids[n++] = nodes_[binary_node].index;
  }
  while (n < 4) {
    int open = -1;
    float open_area = -1.0f;
    for (int i = 0; i < n; ++i) {
      const BvhNode& k = nodes_[kids[i]];
      if (k.count > 0) continue;
      Aabb b;
      for (int a = 0; a < 3; ++a) {
        b.min_m[a] = k.min_m[a];
        b.max_m[a] = k.max_m[a];
      }
      const float area = half_area(b);
      if (area > open_area) {
        open_area = area;
        open = i;
      }
    }
    if (open < 0) break;
    const std::uint32_t inner = kids[open];
    kids[open] = inner + 1;
    kids[n++] = nodes_[inner].index;
  }
  std::uint32_t child[4] = {0, 0, 0, 0};
  std::uint32_t count[4] = {0, 0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const BvhNode& k = nodes_[kids[i]];
    if (k.count > 0) {
      child[i] = k.index;
      count[i] = k.count;
    } else {
      child[i] = collapse(kids[i]);  // may reallocate wide_: write `self` only afterwards
    }
  }
  BvhWideNode& w = wide_[self];
  for (int i = 0; i < 4; ++i) {
    for (int a = 0; a < 3; ++a) {
      // Unused slots: a point far away along +x, +y, +z; every ray misses it within any sane t_max.
      w.bounds[2 * a][i] = i < n ? nodes_[kids[i]].min_m[a] : 1e30f;
      w.bounds[2 * a + 1][i] = i < n ? nodes_[kids[i]].max_m[a] : 1e30f;
    }
    w.child[i] = child[i];
    w.count[i] = count[i];
  }
  return self;
}

std::uint32_t Bvh::build_recursive(std::vector<BuildItem>& items, std::uint32_t begin, std::uint32_t end, int depth,
                                   const Config& config) {
  const std::uint32_t self = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back(BvhNode{});
  depth_ = std::max(depth_, depth);

  Aabb bounds = empty_box();
  Aabb centroids = empty_box();
  for (std::uint32_t i = begin; i < end; ++i) {
    grow(bounds, items[i].box);
    Aabb c;
    for (int k = 0; k < 3; ++k) c.min_m[k] = c.max_m[k] = items[i].centroid[k];
    grow(centroids, c);
  }
  for (int k = 0; k < 3; ++k) {
    nodes_[self].min_m[k] = bounds.min_m[k];
    nodes_[self].max_m[k] = bounds.max_m[k];
  }
  const std::uint32_t count = end - begin;
  auto make_leaf = [&]() {
    nodes_[self].index = begin;
    nodes_[self].count = count;
    ++num_leaves_;
    return self;
  };
  if (count <= 1 || depth >= kMaxDepth) return make_leaf();

  // Best binned SAH split over the three axes.
  const int num_bins = std::max(2, std::min(config.num_bins, 64));
  float best_cost = kInf;
  int best_axis = -1;
  int best_split = 0;  // items in bins [0, best_split) go left
  for (int axis = 0; axis < 3; ++axis) {
    const float lo = centroids.min_m[axis];
    const float extent = centroids.max_m[axis] - lo;
    if (!(extent > 0.0f)) continue;
    const float scale = static_cast<float>(num_bins) / extent;
    Aabb bin_box[64];
    std::uint32_t bin_count[64] = {};
    for (int b = 0; b < num_bins; ++b) bin_box[b] = empty_box();
    for (std::uint32_t i = begin; i < end; ++i) {
      const int b = std::min(num_bins - 1, static_cast<int>((items[i].centroid[axis] - lo) * scale));
      ++bin_count[b];
      grow(bin_box[b], items[i].box);
    }
    // Sweep from the right to get the right-hand areas, then from the left to evaluate each split.
    float right_area[64];
    std::uint32_t right_count[64];
    Aabb acc = empty_box();
    std::uint32_t n = 0;
    for (int b = num_bins - 1; b > 0; --b) {
      grow(acc, bin_box[b]);
      n += bin_count[b];
      right_area[b] = half_area(acc);
      right_count[b] = n;
    }
    acc = empty_box();
    n = 0;
    for (int b = 1; b < num_bins; ++b) {
      grow(acc, bin_box[b - 1]);
      n += bin_count[b - 1];
      if (n == 0 || right_count[b] == 0) continue;
      const float cost = half_area(acc) * static_cast<float>(n) + right_area[b] * static_cast<float>(right_count[b]);
      if (cost < best_cost) {
        best_cost = cost;
        best_axis = axis;
        best_split = b;
      }
    }
  }

  const float parent_area = half_area(bounds);
  const float leaf_cost = static_cast<float>(count);
  const float split_cost =
      parent_area > 0.0f ? config.traversal_cost + best_cost / parent_area : config.traversal_cost + leaf_cost;
  std::uint32_t middle = begin;
  if (best_axis >= 0 && (split_cost < leaf_cost || count > static_cast<std::uint32_t>(config.max_leaf_items))) {
    const float lo = centroids.min_m[best_axis];
    const float scale = static_cast<float>(num_bins) / (centroids.max_m[best_axis] - lo);
    auto it = std::partition(items.begin() + begin, items.begin() + end, [&](const BuildItem& item) {
      return std::min(num_bins - 1, static_cast<int>((item.centroid[best_axis] - lo) * scale)) < best_split;
    });
    middle = static_cast<std::uint32_t>(it - items.begin());
  } else if (count > static_cast<std::uint32_t>(config.max_leaf_items)) {
    // All centroids coincide: split by index so leaves stay small.
    middle = begin + count / 2;
  } else {
    return make_leaf();
  }
  if (middle == begin || middle == end) middle = begin + count / 2;

  build_recursive(items, begin, middle, depth + 1, config);
  const std::uint32_t right = build_recursive(items, middle, end, depth + 1, config);
  nodes_[self].index = right;
  nodes_[self].count = 0;
  return self;
}

}  // namespace qsg::render

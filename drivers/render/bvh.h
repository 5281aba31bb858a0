// A bounding-volume hierarchy over axis-aligned boxes: built once by binned SAH as a binary tree, then collapsed
// into 4-wide nodes whose four child boxes are tested at once with SIMD; traversal is nearest-child-first with a
// fixed on-stack stack, so a ray query never allocates.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <vector>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace qsg::render {

struct Aabb {
  float min_m[3] = {0.0f, 0.0f, 0.0f};
  float max_m[3] = {0.0f, 0.0f, 0.0f};
};

// Binary build node. Inner: count == 0, left child is the next node, right child is `index`.
// Leaf: count > 0 items starting at `index` in Bvh::item_order().
struct BvhNode {
  float min_m[3];
  std::uint32_t index;
  float max_m[3];
  std::uint32_t count;
};
static_assert(sizeof(BvhNode) == 32, "two nodes per cache line");

// Traversal node: four children stored as structure-of-arrays so one SIMD slab test covers all of them.
// bounds[2 * axis] holds the children's minima along axis, bounds[2 * axis + 1] their maxima. A child with
// count == 0 is an inner wide node `child`; count > 0 is a leaf of `count` items from item_order()[child]. Unused
// slots hold a box no ray can reach.
struct alignas(64) BvhWideNode {
  float bounds[6][4];
  std::uint32_t child[4];
  std::uint32_t count[4];
};
static_assert(sizeof(BvhWideNode) == 128, "two cache lines per node");

// A ray as the traversal sees it: float origin and reciprocal direction (zero components replaced by tiny ones),
// and which bound (min or max) is the near one per axis.
struct BvhRay {
  float origin_m[3];
  float inv_dir[3];
  int near_bound[3];  // 2 * axis + (1 when the direction is negative along axis)
};

class Bvh {
 public:
  struct Config {
    int num_bins = 16;            // SAH bins per axis
    int max_leaf_items = 2;       // a leaf never holds more, unless the items cannot be separated
    float traversal_cost = 0.5f;  // of one wide-node visit relative to one item test (SIMD boxes are cheap)
    void print(std::FILE* out) const;
  };
  // Depth bound of the binary tree (the wide tree is no deeper), so the traversal stack fits on the stack.
  static constexpr int kMaxDepth = 48;

  // Builds over boxes[i] = bounds of item i (boxes must be finite and non-inverted).
  void build(const std::vector<Aabb>& boxes, const Config& config);
  void build(const std::vector<Aabb>& boxes) { build(boxes, Config{}); }

  const std::vector<BvhNode>& nodes() const { return nodes_; }
  const std::vector<BvhWideNode>& wide_nodes() const { return wide_; }
  // Item ids in leaf order: a leaf covers item_order()[index .. index + count).
  const std::vector<std::uint32_t>& item_order() const { return item_order_; }
  int depth() const { return depth_; }
  int num_leaves() const { return num_leaves_; }
  bool empty() const { return wide_.empty(); }

  static BvhRay make_ray(const double origin_m[3], const double direction[3]);

  // Calls leaf(first, count, t_max) for every leaf whose box the ray crosses within [t_min, t_max], nearest box
  // first; the callback shrinks t_max when it finds a hit, which prunes the boxes behind it.
  template <class LeafFn>
  void traverse(const BvhRay& ray, float t_min, float& t_max, LeafFn&& leaf) const {
    if (wide_.empty()) return;
    struct Entry {
      std::uint32_t ref;
      std::uint32_t count;  // > 0: a leaf
      float t_near;
    };
    Entry stack[3 * kMaxDepth + 8];
    int top = 0;
    const Float4 ox = splat(ray.origin_m[0]), oy = splat(ray.origin_m[1]), oz = splat(ray.origin_m[2]);
    const Float4 ix = splat(ray.inv_dir[0]), iy = splat(ray.inv_dir[1]), iz = splat(ray.inv_dir[2]);
    const int nx = ray.near_bound[0], ny = ray.near_bound[1], nz = ray.near_bound[2];
    const Float4 t_min4 = splat(t_min);
    std::uint32_t node = 0;
    for (;;) {
      const BvhWideNode& n = wide_[node];
      const Float4 near_x = (load(n.bounds[nx]) - ox) * ix;
      const Float4 near_y = (load(n.bounds[ny]) - oy) * iy;
      const Float4 near_z = (load(n.bounds[nz]) - oz) * iz;
      const Float4 far_x = (load(n.bounds[nx ^ 1]) - ox) * ix;
      const Float4 far_y = (load(n.bounds[ny ^ 1]) - oy) * iy;
      const Float4 far_z = (load(n.bounds[nz ^ 1]) - oz) * iz;
      const Float4 t_near = vmax(vmax(near_x, near_y), vmax(near_z, t_min4));
      const Float4 t_far = vmin(vmin(far_x, far_y), vmin(far_z, splat(t_max)));
      int bits = le_mask(t_near, t_far);
      if (bits != 0) {
        alignas(16) float tn[4];
        store(tn, t_near);
        if ((bits & (bits - 1)) == 0) {
          // One child: descend directly (the common case once the search is bounded).
          const int i = lowest_bit(bits);
          if (n.count[i] == 0) {
            node = n.child[i];
            continue;
          }
          leaf(n.child[i], n.count[i], t_max);
        } else {
          // Several: insert them on the stack farthest first so the nearest is popped next (sorted in place; a
          // copy through a temporary array compiles to a slow block move).
          const int base = top;
          while (bits != 0) {
            const int i = lowest_bit(bits);
            bits &= bits - 1;
            const Entry e{n.child[i], n.count[i], tn[i]};
            int j = top++;
            while (j > base && stack[j - 1].t_near < e.t_near) {
              stack[j] = stack[j - 1];
              --j;
            }
            stack[j] = e;
          }
        }
      }
      // Pop the nearest deferred child that may still hold something nearer than the best hit.
      for (;;) {
        if (top == 0) return;
        const Entry& e = stack[--top];
        if (e.t_near > t_max) continue;
        if (e.count > 0) {
          leaf(e.ref, e.count, t_max);
          continue;
        }
        node = e.ref;
        break;
      }
    }
  }

 private:
  // GCC/Clang vector extensions: SSE on x86-64, NEON (through the generic operators) on aarch64.
  typedef float Float4 __attribute__((vector_size(16)));
  typedef std::int32_t Int4 __attribute__((vector_size(16)));
  static Float4 splat(float v) { return Float4{v, v, v, v}; }
  static Float4 load(const float* p) { return Float4{p[0], p[1], p[2], p[3]}; }
  static void store(float* p, Float4 v) {
    p[0] = v[0];
    p[1] = v[1];
    p[2] = v[2];
    p[3] = v[3];
  }
#if defined(__SSE__)
  static Float4 vmin(Float4 a, Float4 b) { return _mm_min_ps(a, b); }
  static Float4 vmax(Float4 a, Float4 b) { return _mm_max_ps(a, b); }
  static int le_mask(Float4 a, Float4 b) { return _mm_movemask_ps(_mm_cmple_ps(a, b)); }
#else
  static Float4 vmin(Float4 a, Float4 b) { return b < a ? b : a; }
  static Float4 vmax(Float4 a, Float4 b) { return a < b ? b : a; }
  static int le_mask(Float4 a, Float4 b) {
    const Int4 m = a <= b;
    return (m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8);
  }
#endif
  static int lowest_bit(int bits) { return __builtin_ctz(static_cast<unsigned>(bits)); }

  struct BuildItem {
    Aabb box;
    float centroid[3];
    std::uint32_t id;
  };
  std::uint32_t build_recursive(std::vector<BuildItem>& items, std::uint32_t begin, std::uint32_t end, int depth,
                                const Config& config);
  std::uint32_t collapse(std::uint32_t binary_node);

  std::vector<BvhNode> nodes_;
  std::vector<BvhWideNode> wide_;
  std::vector<std::uint32_t> item_order_;
  int depth_ = 0;
  int num_leaves_ = 0;
};

}  // namespace qsg::render

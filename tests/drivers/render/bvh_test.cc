// Bvh: every item is reachable, the traversal reports every leaf whose box a ray crosses (nearest first), the
// depth bound holds, and degenerate inputs (coincident boxes, one item, none) build.
#include "drivers/render/bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

namespace qsg::render {
namespace {

std::vector<Aabb> random_boxes(std::uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-20.0f, 20.0f), size(0.05f, 3.0f);
  std::vector<Aabb> boxes(static_cast<std::size_t>(n));
  for (Aabb& b : boxes) {
    for (int k = 0; k < 3; ++k) {
      b.min_m[k] = pos(rng);
      b.max_m[k] = b.min_m[k] + size(rng);
    }
  }
  return boxes;
}

// Reference slab test in double.
bool ray_hits_box(const Aabb& b, const double o[3], const double d[3], double t_max) {
  double lo = 0.0, hi = t_max;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) {
      if (o[k] < b.min_m[k] || o[k] > b.max_m[k]) return false;
      continue;
    }
    double t0 = (b.min_m[k] - o[k]) / d[k], t1 = (b.max_m[k] - o[k]) / d[k];
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0);
    hi = std::min(hi, t1);
  }
  return lo <= hi;
}

TEST(Bvh, EveryItemAppearsOnceAndLeavesAreSmall) {
  const std::vector<Aabb> boxes = random_boxes(1, 500);
  Bvh bvh;
  bvh.build(boxes);
  ASSERT_EQ(bvh.item_order().size(), boxes.size());
  std::set<std::uint32_t> seen(bvh.item_order().begin(), bvh.item_order().end());
  EXPECT_EQ(seen.size(), boxes.size());
  EXPECT_LE(bvh.depth(), Bvh::kMaxDepth);
  std::size_t leaf_items = 0;
  for (const BvhWideNode& n : bvh.wide_nodes())
    for (int i = 0; i < 4; ++i) {
      leaf_items += n.count[i];
      EXPECT_LE(n.count[i], static_cast<std::uint32_t>(Bvh::Config{}.max_leaf_items));
    }
  EXPECT_EQ(leaf_items, boxes.size());
  EXPECT_LT(bvh.wide_nodes().size(), boxes.size());
}

TEST(Bvh, TraversalReportsEveryCrossedBoxNearestFirst) {
  const std::vector<Aabb> boxes = random_boxes(2, 300);
  Bvh bvh;
  bvh.build(boxes);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> pos(-25.0, 25.0), dir(-1.0, 1.0);
  for (int r = 0; r < 400; ++r) {
    double o[3] = {pos(rng), pos(rng), pos(rng)};
    double d[3] = {dir(rng), dir(rng), dir(rng)};
    if (r % 5 == 0) d[r % 3] = 0.0;  // axis-parallel rays
    const double t_max = 60.0;
    std::set<std::uint32_t> expected;
    for (std::uint32_t i = 0; i < boxes.size(); ++i)
      if (ray_hits_box(boxes[i], o, d, t_max)) expected.insert(i);
    std::set<std::uint32_t> reported;
    float t_limit = static_cast<float>(t_max);
    bvh.traverse(Bvh::make_ray(o, d), 0.0f, t_limit, [&](std::uint32_t first, std::uint32_t count, float&) {
      for (std::uint32_t i = first; i < first + count; ++i) reported.insert(bvh.item_order()[i]);
    });
    // Every crossed box is reported (the tree's boxes are exact here, so float rounding may add a grazing one).
    for (std::uint32_t i : expected) ASSERT_TRUE(reported.count(i)) << "ray " << r << " missed item " << i;
    EXPECT_LE(reported.size(), expected.size() + 40);
  }
}

TEST(Bvh, ShrinkingTMaxPrunesFartherLeaves) {
  // A row of unit boxes along x: a hit in the first box must stop the search.
  std::vector<Aabb> boxes;
  for (int i = 0; i < 64; ++i) {
    Aabb b;
    b.min_m[0] = 2.0f * i;
    b.max_m[0] = 2.0f * i + 1.0f;
    b.min_m[1] = b.min_m[2] = -0.5f;
    b.max_m[1] = b.max_m[2] = 0.5f;
    boxes.push_back(b);
  }
  Bvh bvh;
  bvh.build(boxes);
  const double o[3] = {-1.0, 0.0, 0.0}, d[3] = {1.0, 0.0, 0.0};
  int leaves = 0;
  float t_max = 1000.0f;
  std::uint32_t first_item = 999;
  bvh.traverse(Bvh::make_ray(o, d), 0.0f, t_max, [&](std::uint32_t first, std::uint32_t count, float& t) {
    ++leaves;
    for (std::uint32_t i = first; i < first + count; ++i) {
      if (first_item == 999) first_item = bvh.item_order()[i];
      if (bvh.item_order()[i] == 0) t = 1.0f;  // "hit" the first box at its entry
    }
  });
  EXPECT_EQ(first_item, 0u);  // nearest leaf first
  EXPECT_LE(leaves, 2);
}

TEST(Bvh, DegenerateInputsBuild) {
  Bvh bvh;
  bvh.build({});
  EXPECT_TRUE(bvh.empty());
  std::vector<Aabb> same(100);
  for (Aabb& b : same) {
    b.min_m[0] = b.min_m[1] = b.min_m[2] = 1.0f;
    b.max_m[0] = b.max_m[1] = b.max_m[2] = 2.0f;
  }
  bvh.build(same);
  ASSERT_FALSE(bvh.empty());
  EXPECT_LE(bvh.depth(), Bvh::kMaxDepth);
  const double o[3] = {0.0, 0.0, 0.0}, d[3] = {1.0, 1.0, 1.0};
  std::size_t reported = 0;
  float t_max = 10.0f;
  bvh.traverse(Bvh::make_ray(o, d), 0.0f, t_max,
               [&](std::uint32_t, std::uint32_t count, float&) { reported += count; });
  EXPECT_EQ(reported, same.size());
  bvh.build(std::vector<Aabb>(1, same[0]));
  reported = 0;
  bvh.traverse(Bvh::make_ray(o, d), 0.0f, t_max,
               [&](std::uint32_t, std::uint32_t count, float&) { reported += count; });
  EXPECT_EQ(reported, 1u);
}

}  // namespace
}  // namespace qsg::render

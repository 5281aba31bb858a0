// Object clustering on synthetic vertex sets: separation, merging across updates, structure labels, size limits,
// equality with a brute-force Euclidean clustering, stale and released vertices, full stores, zero allocations.
#include "core/objects/object_layer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "budgets/budget_table.h"
#include "core/scene_graph/scene_graph.h"
#include "tests/scene_graph/test_graph.h"
#include "tests/support/allocation_counter.h"

namespace qsg::objects {
namespace {

using scene_graph::NodeId;

constexpr double kBlockSize = 0.8;

Capacities small_capacities() {
  Capacities c;
  c.cluster_vertices = 8192;
  c.tracked_vertices = 8192;
  c.vertex_keys = 16384;
  c.tracked_blocks = 256;
  c.objects = 64;
  return c;
}

std::unique_ptr<ObjectLayer> make_layer(const Config& config = Config{}, const Capacities& c = small_capacities()) {
  auto layer = std::make_unique<ObjectLayer>();
  std::string error;
  EXPECT_TRUE(layer->init(config, c, ObjectLayer::plan(c).total_bytes(), &error)) << error;
  return layer;
}

// Every mesh-vertex key kept (no reservoir sampling): for tests that count an object's keys.
Config all_keys() {
  Config c;
  c.max_keys_per_object = 1u << 16;
  return c;
}

struct Vertex {
  InputVertex v;
  memory::Index3 block;
};

memory::Index3 block_of(double x, double y, double z) {
  return {static_cast<std::int32_t>(std::floor(x / kBlockSize)), static_cast<std::int32_t>(std::floor(y / kBlockSize)),
          static_cast<std::int32_t>(std::floor(z / kBlockSize))};
}

// Points on the surface of an axis-aligned box at `step` spacing, with unique keys from *next_key.
std::vector<Vertex> box_surface(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, semantics::Label label,
                                std::uint64_t* next_key, double step = 0.05) {
  std::vector<Vertex> out;
  const Eigen::Vector3i n = ((hi - lo) / step).array().round().cast<int>();
  for (int i = 0; i <= n.x(); ++i)
    for (int j = 0; j <= n.y(); ++j)
      for (int k = 0; k <= n.z(); ++k) {
        const bool surface = i == 0 || j == 0 || k == 0 || i == n.x() || j == n.y() || k == n.z();
        if (!surface) continue;
        const Eigen::Vector3d p = lo + Eigen::Vector3d(i, j, k) * step;
        Vertex v;
        v.v.key = (*next_key)++;
        v.v.x = static_cast<float>(p.x());
        v.v.y = static_cast<float>(p.y());
        v.v.z = static_cast<float>(p.z());
        v.v.label = label;
        v.block = block_of(p.x(), p.y(), p.z());
        out.push_back(v);
      }
  return out;
}

// Presents the vertices grouped by block, as the TSDF adapter does.
UpdateResult present(ObjectLayer* layer, const std::vector<Vertex>& vertices, std::uint64_t time_ns = 1) {
  std::map<std::tuple<int, int, int>, std::vector<const Vertex*>> by_block;
  for (const Vertex& v : vertices) by_block[{v.block.x, v.block.y, v.block.z}].push_back(&v);
  layer->begin_update(time_ns);
  for (const auto& [index, list] : by_block) {
    layer->begin_block({std::get<0>(index), std::get<1>(index), std::get<2>(index)});
    for (const Vertex* v : list) layer->add_vertex(v->v);
  }
  return layer->end_update();
}

std::vector<ObjectView> objects_of(const ObjectLayer& layer) {
  std::vector<ObjectView> out;
  layer.for_each_object([&](const ObjectView& v) { out.push_back(v); });
  std::sort(out.begin(), out.end(), [](const ObjectView& a, const ObjectView& b) { return a.position_m.x() < b.position_m.x(); });
  return out;
}

std::size_t key_chunks_in_use(const ObjectLayer& layer) {
  std::size_t in_use = 0;
  layer.for_each_resource([&](const memory::ResourceStats& s) {
    if (std::string(s.name) == "objects.key_chunks") in_use = s.in_use;
  });
  return in_use;
}

std::vector<Vertex> concat(std::vector<Vertex> a, const std::vector<Vertex>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

TEST(ObjectLayerTest, TwoSeparatedChairsBecomeTwoObjectsInTheSceneGraph) {
  auto layer = make_layer(all_keys());
  std::uint64_t key = 1;
  const auto a = box_surface({0.0, 0.0, 0.0}, {0.5, 0.5, 0.9}, semantics::kChair, &key);
  const auto b = box_surface({2.0, 0.3, 0.0}, {2.5, 0.8, 0.9}, semantics::kChair, &key);
  const UpdateResult r = present(layer.get(), concat(a, b), 42);
  EXPECT_EQ(r.clusters, 2u);
  EXPECT_EQ(r.objects_created, 2u);
  const auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 2u);
  EXPECT_EQ(objs[0].label, semantics::kChair);
  EXPECT_LT((objs[0].position_m - Eigen::Vector3d(0.25, 0.25, 0.45)).norm(), 0.01);
  EXPECT_LT((objs[1].position_m - Eigen::Vector3d(2.25, 0.55, 0.45)).norm(), 0.01);
  EXPECT_LT((objs[0].vertex_mean_m - Eigen::Vector3d(0.25, 0.25, 0.45)).norm(), 0.01);
  EXPECT_NEAR(objs[0].min_m.x(), 0.0, 1e-6);
  EXPECT_NEAR(objs[1].max_m.z(), 0.9, 1e-6);
  EXPECT_EQ(objs[0].num_vertices, a.size());
  EXPECT_EQ(objs[1].num_keys, b.size());

  auto graph = scene_graph::testing::make_graph();
  ASSERT_TRUE(layer->sync(graph.get()));
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), 2u);
  EXPECT_EQ(layer->synced_nodes().size(), 2u);
  for (const ObjectView& o : objs) {
    EXPECT_EQ(scene_graph::node_prefix(o.node), 'O');
    const scene_graph::ObjectAttributes* attr = graph->object(o.node);
    ASSERT_NE(attr, nullptr);
    EXPECT_EQ(attr->semantic_label, semantics::kChair);
    EXPECT_TRUE(attr->position_m.isApprox(o.position_m));
    EXPECT_TRUE(attr->bounding_box.contains(o.position_m));
    EXPECT_TRUE(attr->is_active);
    EXPECT_EQ(attr->last_update_time_ns, 42u);
    EXPECT_EQ(graph->num_mesh_connections(o.node), o.num_keys);
    // Every mesh connection resolves to a key of this object's vertices.
    std::set<std::uint64_t> keys;
    layer->for_each_vertex_key(o.node, [&](std::uint64_t k) { keys.insert(k); });
    EXPECT_EQ(keys.size(), o.num_keys);
    graph->for_each_mesh_connection(o.node, [&](std::uint32_t c) {
      std::uint64_t k = 0;
      ASSERT_TRUE(layer->mesh_vertex_key(c, &k));
      EXPECT_EQ(keys.count(k), 1u);
    });
  }
  // A second sync without changes touches nothing.
  ASSERT_TRUE(layer->sync(graph.get()));
  EXPECT_EQ(layer->synced_nodes().size(), 0u);
}

TEST(ObjectLayerTest, ChairSplitAcrossTwoUpdatesIsOneObject) {
  auto layer = make_layer(all_keys());
  auto graph = scene_graph::testing::make_graph();
  std::uint64_t key = 1;
  // One chair, its left half meshed in one update and its right half (touching it) in the next: the halves'
  // centroids do not lie in each other's boxes, so only the connection through tracked vertices merges them.
  // The halves lie in different blocks (the border is at x = 0.8 m), as a re-meshed block presents all of its
  // vertices.
  const auto left = box_surface({0.5, 0.0, 0.0}, {0.75, 0.5, 0.7}, semantics::kChair, &key);
  const auto right = box_surface({0.8, 0.0, 0.0}, {1.1, 0.5, 0.7}, semantics::kChair, &key);
  present(layer.get(), left, 1);
  ASSERT_TRUE(layer->sync(graph.get()));
  ASSERT_EQ(layer->num_objects(), 1u);
  const NodeId first = objects_of(*layer)[0].node;
  present(layer.get(), right, 2);
  ASSERT_TRUE(layer->sync(graph.get()));
  const auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 1u);
  EXPECT_EQ(objs[0].node, first) << "the new half joins the existing node";
  EXPECT_EQ(objs[0].num_vertices, left.size() + right.size());
  EXPECT_NEAR(objs[0].min_m.x(), 0.5, 1e-6);
  EXPECT_NEAR(objs[0].max_m.x(), 1.1, 1e-6);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), 1u);
  EXPECT_EQ(graph->num_mesh_connections(first), left.size() + right.size());
  EXPECT_EQ(layer->counters().clusters_joined, 1u);
}

TEST(ObjectLayerTest, ABridgeBetweenTwoObjectsMergesThemAndRemovesOneNode) {
  auto layer = make_layer();
  auto graph = scene_graph::testing::make_graph();
  std::uint64_t key = 1;
  // Two sofa parts in blocks x = 0 and x = 2, then a bridge between them in block x = 1.
  present(layer.get(), concat(box_surface({0.2, 0, 0}, {0.7, 0.5, 0.5}, semantics::kSofa, &key),
                              box_surface({1.7, 0, 0}, {2.2, 0.5, 0.5}, semantics::kSofa, &key)), 1);
  // Sofa needs 20 vertices: both boxes have more.
  ASSERT_EQ(layer->num_objects(), 2u);
  ASSERT_TRUE(layer->sync(graph.get()));
  ASSERT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), 2u);
  const auto parts = objects_of(*layer);
  ASSERT_EQ(parts[0].num_vertices, parts[1].num_vertices);
  const NodeId older = std::min(parts[0].node, parts[1].node);
  present(layer.get(), box_surface({0.85, 0.2, 0.0}, {1.55, 0.3, 0.1}, semantics::kSofa, &key), 2);
  ASSERT_EQ(layer->num_objects(), 1u);
  ASSERT_TRUE(layer->sync(graph.get()));
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), 1u);
  EXPECT_EQ(layer->counters().objects_merged, 1u);
  EXPECT_EQ(objects_of(*layer)[0].node, older) << "of two parts of equal size, the older keeps its node";
}

TEST(ObjectLayerTest, OverlappingClustersMergeByThePapersRuleUnlessDisabled) {
  for (const bool merge : {true, false}) {
    Config config;
    config.merge_overlapping = merge;
    config.merge_intersecting = merge;  // the patch's box also lies inside the rim's
    config.merge_by_size_prior = merge;
    auto layer = make_layer(config);
    std::uint64_t key = 1;
    // A table's top rim seen first, then a separate patch at its centre (farther than the tolerance from the
    // rim): the patch's centroid lies in the rim's box.
    std::vector<Vertex> rim;
    for (const Vertex& v : box_surface({0, 0, 0.7}, {1.2, 1.2, 0.75}, semantics::kTable, &key))
      if (v.v.x < 0.15 || v.v.x > 1.05 || v.v.y < 0.15 || v.v.y > 1.05) rim.push_back(v);
    present(layer.get(), rim, 1);
    ASSERT_EQ(layer->num_objects(), 1u);
    present(layer.get(), box_surface({0.45, 0.45, 0.7}, {0.75, 0.75, 0.75}, semantics::kTable, &key), 2);
    EXPECT_EQ(layer->num_objects(), merge ? 1u : 2u) << "merge_overlapping=" << merge;
    EXPECT_EQ(layer->counters().clusters_overlap_merged, merge ? 1u : 0u);
  }
}

TEST(ObjectLayerTest, StructureNeverBecomesObjects) {
  auto layer = make_layer();
  std::uint64_t key = 1;
  std::vector<Vertex> all;
  for (semantics::Label l : {semantics::kWall, semantics::kFloor, semantics::kCeiling, semantics::kDoor,
                             semantics::kWindow, semantics::kStairs, semantics::kVoid, semantics::kUnlabeled})
    all = concat(all, box_surface({0.0 + l, 0, 0}, {0.6 + l, 0.6, 0.6}, l, &key));
  const UpdateResult r = present(layer.get(), all);
  EXPECT_EQ(r.vertices, 0u) << "structure vertices are not even presented to clustering";
  EXPECT_EQ(layer->num_objects(), 0u);

  Config bad;
  bad.labels[semantics::kWall].enabled = true;
  const std::string why = bad.check();
  EXPECT_NE(why.find("labels[1] (wall)"), std::string::npos) << why;
  ObjectLayer rejected;
  std::string error;
  EXPECT_FALSE(rejected.init(bad, small_capacities(), 1 << 24, &error));
  EXPECT_NE(error.find("structure"), std::string::npos) << error;
}

TEST(ObjectLayerTest, MinAndMaxClusterSizesAreRespected) {
  Config config;
  config.labels[semantics::kPlant].min_vertices = 10;
  config.labels[semantics::kPlant].max_vertices = 30;
  auto layer = make_layer(config);
  std::uint64_t key = 1;
  const auto line = [&](double x0, int n) {  // n vertices 0.1 m apart: one cluster at 0.2 m tolerance
    std::vector<Vertex> out;
    for (int i = 0; i < n; ++i) {
      Vertex v;
      v.v = InputVertex{key++, static_cast<float>(x0 + 0.1 * i), 0.5f, 0.5f, semantics::kPlant};
      v.block = block_of(v.v.x, v.v.y, v.v.z);
      out.push_back(v);
    }
    return out;
  };
  present(layer.get(), concat(concat(line(0, 9), line(10, 10)), concat(line(20, 30), line(30, 31))));
  const auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 2u);
  EXPECT_EQ(objs[0].num_vertices, 10u);
  EXPECT_EQ(objs[1].num_vertices, 30u);
  EXPECT_EQ(layer->counters().clusters_too_small, 1u);
  EXPECT_EQ(layer->counters().clusters_too_large, 1u);
}

// Reference: connected components of "distance <= tolerance" among same-label points, by brute force.
std::vector<int> brute_force_components(const std::vector<Vertex>& pts, double tol) {
  std::vector<int> parent(pts.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (std::size_t j = i + 1; j < pts.size(); ++j) {
      if (pts[i].v.label != pts[j].v.label) continue;
      const float dx = pts[i].v.x - pts[j].v.x, dy = pts[i].v.y - pts[j].v.y, dz = pts[i].v.z - pts[j].v.z;
      if (dx * dx + dy * dy + dz * dz <= static_cast<float>(tol * tol)) parent[find(static_cast<int>(i))] = find(static_cast<int>(j));
    }
  std::vector<int> out(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) out[i] = find(static_cast<int>(i));
  return out;
}

// Same partition: a bijection between reference components and objects.
void expect_same_partition(const ObjectLayer& layer, const std::vector<Vertex>& pts, const std::vector<int>& ref) {
  std::map<std::uint64_t, NodeId> object_of_key;
  layer.for_each_object([&](const ObjectView& o) {
    layer.for_each_vertex_key(o.node, [&](std::uint64_t k) { object_of_key[k] = o.node; });
  });
  ASSERT_EQ(object_of_key.size(), pts.size()) << "every point is in exactly one object (min size 1)";
  std::map<int, NodeId> ref_to_obj;
  std::map<NodeId, int> obj_to_ref;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const NodeId o = object_of_key.at(pts[i].v.key);
    const auto a = ref_to_obj.emplace(ref[i], o);
    const auto b = obj_to_ref.emplace(o, ref[i]);
    ASSERT_EQ(a.first->second, o) << "reference component split across objects at point " << i;
    ASSERT_EQ(b.first->second, ref[i]) << "object joins two reference components at point " << i;
  }
  EXPECT_EQ(ref_to_obj.size(), layer.num_objects());
}

TEST(ObjectLayerTest, ClustersEqualBruteForceEuclideanClusteringOnRandomPoints) {
  Config config;
  config.merge_overlapping = false;  // the reference is pure connected components
  config.merge_intersecting = false;
  config.merge_by_size_prior = false;
  for (semantics::Label l : {semantics::kChair, semantics::kTable}) {
    config.labels[l].min_vertices = 1;
    config.labels[l].tolerance_m = l == semantics::kChair ? 0.2 : 0.15;
  }
  std::mt19937 rng(7);
  for (int trial = 0; trial < 3; ++trial) {
    std::uniform_real_distribution<float> ux(0.0f, 4.0f), uz(0.0f, 1.0f);
    std::vector<Vertex> pts;
    for (std::uint64_t i = 0; i < 1200; ++i) {
      Vertex v;
      v.v = InputVertex{1000 + i, ux(rng), ux(rng), uz(rng), (i % 3 == 0) ? semantics::kTable : semantics::kChair};
      v.block = block_of(v.v.x, v.v.y, v.v.z);
      pts.push_back(v);
    }
    std::vector<int> ref(pts.size());
    {
      std::vector<Vertex> chairs, tables;
      std::vector<std::size_t> ci, ti;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        (pts[i].v.label == semantics::kChair ? chairs : tables).push_back(pts[i]);
        (pts[i].v.label == semantics::kChair ? ci : ti).push_back(i);
      }
      const auto rc = brute_force_components(chairs, 0.2);
      const auto rt = brute_force_components(tables, 0.15);
      for (std::size_t i = 0; i < ci.size(); ++i) ref[ci[i]] = static_cast<int>(ci[rc[i]]);
      for (std::size_t i = 0; i < ti.size(); ++i) ref[ti[i]] = static_cast<int>(ti[rt[i]]);
    }
    Capacities caps = small_capacities();
    caps.objects = 2048;
    {  // all at once
      auto layer = make_layer(config, caps);
      present(layer.get(), pts);
      expect_same_partition(*layer, pts, ref);
    }
    {  // in three updates of disjoint block sets: components across updates must still come out whole
      auto layer = make_layer(config, caps);
      for (int part = 0; part < 3; ++part) {
        std::vector<Vertex> subset;
        for (const Vertex& v : pts)
          if (((v.block.x + 2 * v.block.y) % 3 + 3) % 3 == part) subset.push_back(v);
        present(layer.get(), subset, static_cast<std::uint64_t>(part + 1));
      }
      expect_same_partition(*layer, pts, ref);
    }
  }
}

// The clustering's shortcuts (two vertices of one cell are connected; the boxes of two cells' vertices decide most
// pairs of cells) must agree with the vertex test everywhere: dense blobs (many vertices per cell), chains spaced
// at the tolerance (pairs on both sides of it), sparse points, two tolerances, near the origin and kilometres
// from it; all at once and over updates (joining tracked vertices).
TEST(ObjectLayerTest, ClustersEqualBruteForceAtTheToleranceDenseAndSparseFarFromTheOrigin) {
  Config config;
  config.merge_overlapping = false;
  config.merge_intersecting = false;
  config.merge_by_size_prior = false;
  const double tolerance[2] = {0.2, 0.05};
  const semantics::Label labels[2] = {semantics::kChair, semantics::kTable};
  for (int i = 0; i < 2; ++i) {
    config.labels[labels[i]].min_vertices = 1;
    config.labels[labels[i]].tolerance_m = tolerance[i];
  }
  Capacities caps = small_capacities();
  caps.objects = 4096;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (const Eigen::Vector3d& origin : {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(3000.5, -7000.25, 12.0)}) {
    std::vector<Vertex> pts;
    std::uint64_t key = 1;
    const auto add = [&](const Eigen::Vector3d& p, int which) {
      Vertex v;
      const Eigen::Vector3d q = origin + p;
      v.v = InputVertex{key++, static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
                        labels[which]};
      v.block = block_of(q.x(), q.y(), q.z());
      pts.push_back(v);
    };
    for (int which = 0; which < 2; ++which) {
      const double tol = tolerance[which];
      for (int blob = 0; blob < 4; ++blob) {  // dense: a blob of 150 within half a tolerance of its centre
        const Eigen::Vector3d c(0.7 * blob + 0.3 * which, 0.5, 0.4);
        for (int k = 0; k < 150; ++k)
          add(c + 0.5 * tol * Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5), which);
      }
      for (int chain = 0; chain < 6; ++chain) {  // steps within a part in a thousand of the tolerance
        const Eigen::Vector3d dir = Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5).normalized();
        Eigen::Vector3d p(3.0 * unit(rng), 1.5 + unit(rng), unit(rng));
        for (int k = 0; k < 30; ++k, p += dir * tol * (1.0 + 0.002 * (unit(rng) - 0.5))) add(p, which);
      }
      for (int k = 0; k < 250; ++k)  // sparse
        add(Eigen::Vector3d(3.0 * unit(rng), 3.0 + 3.0 * unit(rng), unit(rng)), which);
    }
    std::vector<int> ref(pts.size());
    for (int which = 0; which < 2; ++which) {
      std::vector<Vertex> same;
      std::vector<std::size_t> index;
      for (std::size_t i = 0; i < pts.size(); ++i)
        if (pts[i].v.label == labels[which]) {
          same.push_back(pts[i]);
          index.push_back(i);
        }
      const auto r = brute_force_components(same, tolerance[which]);
      for (std::size_t i = 0; i < index.size(); ++i) ref[index[i]] = static_cast<int>(index[r[i]]);
    }
    {
      auto layer = make_layer(config, caps);
      present(layer.get(), pts);
      expect_same_partition(*layer, pts, ref);
      EXPECT_EQ(layer->counters().candidate_overflow, 0u);
    }
    {
      auto layer = make_layer(config, caps);
      for (int part = 0; part < 3; ++part) {
        std::vector<Vertex> subset;
        for (const Vertex& v : pts)
          if ((((v.block.x + 2 * v.block.y + v.block.z) % 3) + 3) % 3 == part) subset.push_back(v);
        present(layer.get(), subset, static_cast<std::uint64_t>(part + 1));
      }
      expect_same_partition(*layer, pts, ref);
    }
  }
}

// Clustering cells count from the lowest of a label's candidates in the update, 19 bits per axis: a candidate
// farther than that (15 km at the smallest tolerance) from the others is counted, not put in a wrong cell.
TEST(ObjectLayerTest, ACandidateBeyondTheClusteringGridIsCountedNotMisclustered) {
  Config config;
  config.labels[semantics::kChair].tolerance_m = 0.05;
  config.labels[semantics::kChair].min_vertices = 1;
  auto layer = make_layer(config);
  const std::vector<Vertex> pts = {Vertex{InputVertex{1, 0.0f, 0.0f, 0.0f, semantics::kChair}, {0, 0, 0}},
                                   Vertex{InputVertex{2, 0.03f, 0.0f, 0.0f, semantics::kChair}, {0, 0, 0}},
                                   Vertex{InputVertex{3, 20000.0f, 0.0f, 0.0f, semantics::kChair}, {25000, 0, 0}}};
  present(layer.get(), pts);
  EXPECT_EQ(layer->counters().candidate_overflow, 1u);
  const auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 1u);
  EXPECT_EQ(objs[0].num_vertices, 2u);
}

TEST(ObjectLayerTest, StaleVerticesLeaveTheirObjectAndReleasedBlocksKeepTheSummary) {
  auto layer = make_layer();
  auto graph = scene_graph::testing::make_graph();
  std::uint64_t key = 1;
  const auto chair = box_surface({0.05, 0.05, 0.05}, {0.55, 0.55, 0.75}, semantics::kChair, &key);  // one block
  present(layer.get(), chair, 1);
  ASSERT_EQ(layer->num_objects(), 1u);
  // The block is re-meshed and the top 20 vertices are gone (the surface moved).
  std::vector<Vertex> fewer(chair.begin(), chair.end() - 20);
  present(layer.get(), fewer, 2);
  auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 1u);
  EXPECT_EQ(objs[0].num_vertices, fewer.size());
  EXPECT_EQ(layer->counters().vertices_stale, 20u);
  // The block leaves the window: the object keeps its centroid and box but is no longer active.
  const Eigen::Vector3d centroid = objs[0].vertex_mean_m;
  const Eigen::Vector3d position = objs[0].position_m;
  layer->begin_update(3);
  layer->release_block(block_of(0.1, 0.1, 0.1));
  layer->end_update();
  objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 1u);
  EXPECT_EQ(objs[0].num_tracked, 0u);
  EXPECT_EQ(objs[0].num_vertices, fewer.size());
  EXPECT_TRUE(objs[0].vertex_mean_m.isApprox(centroid));
  EXPECT_TRUE(objs[0].position_m.isApprox(position));
  EXPECT_EQ(layer->num_tracked_vertices(), 0u);
  ASSERT_TRUE(layer->sync(graph.get()));
  EXPECT_FALSE(graph->object(objs[0].node)->is_active);
  // A re-mesh that drops every vertex of an object removes it (and its node).
  auto layer2 = make_layer();
  graph = scene_graph::testing::make_graph();
  present(layer2.get(), chair, 1);
  ASSERT_TRUE(layer2->sync(graph.get()));
  const NodeId node = objects_of(*layer2)[0].node;
  EXPECT_TRUE(graph->has_node(node));
  layer2->begin_update(2);
  layer2->begin_block(block_of(0.1, 0.1, 0.1));
  layer2->end_update();
  EXPECT_EQ(layer2->num_objects(), 0u);
  ASSERT_TRUE(layer2->sync(graph.get()));
  EXPECT_FALSE(graph->has_node(node));
}

// A block that leaves the window and comes back (the robot's next tour) presents the same vertex keys again: the
// object keeps each key once, so repeated tours do not fill the key store; an object keeps at most
// max_keys_per_object keys (a revisit under drift lands on new keys every pass).
TEST(ObjectLayerTest, ARevisitedBlockKeepsEachKeyOnceAndAnObjectsKeysAreCapped) {
  auto layer = make_layer(all_keys());
  std::uint64_t key = 1;
  const auto chair = box_surface({0.05, 0.05, 0.05}, {0.55, 0.55, 0.75}, semantics::kChair, &key);  // one block
  std::size_t chunks_after_first = 0;
  for (std::uint64_t tour = 0; tour < 5; ++tour) {
    present(layer.get(), chair, 10 * tour + 1);
    layer->begin_update(10 * tour + 2);
    layer->release_block(block_of(0.1, 0.1, 0.1));
    layer->end_update();
    if (tour == 0) chunks_after_first = key_chunks_in_use(*layer);
  }
  ASSERT_EQ(layer->num_objects(), 1u);
  EXPECT_EQ(objects_of(*layer)[0].num_keys, chair.size());
  EXPECT_EQ(key_chunks_in_use(*layer), chunks_after_first);
  EXPECT_EQ(layer->counters().keys_repeated, 4 * chair.size());

  Config capped;
  capped.max_keys_per_object = 10;
  auto small = make_layer(capped);
  present(small.get(), chair, 1);
  ASSERT_EQ(small->num_objects(), 1u);
  EXPECT_EQ(objects_of(*small)[0].num_keys, 10u);
  EXPECT_EQ(objects_of(*small)[0].num_vertices, chair.size()) << "every vertex still shapes the object";
  EXPECT_EQ(small->counters().keys_capped + small->counters().keys_resampled, chair.size() - 10);
  // A reservoir, not the first ten: kept keys come from across everything the object was given.
  EXPECT_GT(small->counters().keys_resampled, 0u);
  std::uint64_t first = chair.front().v.key, last = chair.front().v.key;
  for (const auto& v : chair) {
    first = std::min(first, v.v.key);
    last = std::max(last, v.v.key);
  }
  std::size_t kept = 0, from_second_half = 0;
  small->for_each_vertex_key(objects_of(*small)[0].node, [&](std::uint64_t k) {
    ++kept;
    from_second_half += k > first + (last - first) / 2 ? 1 : 0;
  });
  EXPECT_EQ(kept, 10u);
  EXPECT_GT(from_second_half, 0u) << "the sample must reach the keys given last";
}

TEST(ObjectLayerTest, FullStoresAreCountedNotFatal) {
  Capacities c = small_capacities();
  c.objects = 1;
  auto layer = make_layer(Config{}, c);
  std::uint64_t key = 1;
  present(layer.get(), concat(box_surface({0, 0, 0}, {0.5, 0.5, 0.9}, semantics::kChair, &key),
                              box_surface({2, 0, 0}, {2.5, 0.5, 0.9}, semantics::kChair, &key)));
  EXPECT_EQ(layer->num_objects(), 1u);
  EXPECT_EQ(layer->counters().object_overflow, 1u);

  // A graph with room for one object and a few mesh connections.
  auto layer2 = make_layer();
  present(layer2.get(), concat(box_surface({0, 0, 0}, {0.5, 0.5, 0.9}, semantics::kChair, &key),
                               box_surface({2, 0, 0}, {2.5, 0.5, 0.9}, semantics::kChair, &key)));
  scene_graph::Capacities gc = scene_graph::testing::small_capacities();
  gc.object_nodes = 1;
  gc.mesh_connections = 60;
  auto graph = scene_graph::testing::make_graph(gc);
  EXPECT_FALSE(layer2->sync(graph.get()));
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), 1u);
  EXPECT_EQ(layer2->counters().graph_node_failures, 1u);
  EXPECT_GT(layer2->counters().graph_connection_failures, 0u);
  EXPECT_FALSE(layer2->sync(graph.get())) << "the object that did not fit is retried";
  EXPECT_EQ(layer2->counters().graph_node_failures, 2u);
}

TEST(ObjectLayerTest, UpdatesAndSyncDoNotAllocateAfterInit) {
  auto layer = make_layer();
  auto graph = scene_graph::testing::make_graph();
  std::uint64_t key = 1;
  std::vector<std::vector<Vertex>> updates;
  for (int i = 0; i < 4; ++i)
    updates.push_back(concat(box_surface({1.0 * i, 0, 0}, {1.0 * i + 0.5, 0.5, 0.9}, semantics::kChair, &key),
                             box_surface({1.0 * i, 2, 0}, {1.0 * i + 0.3, 2.3, 0.2}, semantics::kPlant, &key)));
  // Group by block outside the measured region (the test's own std::map allocates).
  struct Batch {
    std::vector<memory::Index3> blocks;
    std::vector<std::vector<InputVertex>> vertices;
  };
  std::vector<Batch> batches;
  for (const auto& u : updates) {
    Batch b;
    std::map<std::tuple<int, int, int>, std::vector<InputVertex>> m;
    for (const Vertex& v : u) m[{v.block.x, v.block.y, v.block.z}].push_back(v.v);
    for (auto& [k, list] : m) {
      b.blocks.push_back({std::get<0>(k), std::get<1>(k), std::get<2>(k)});
      b.vertices.push_back(list);
    }
    batches.push_back(std::move(b));
  }
  const auto run = [&](const Batch& b, std::uint64_t t) {
    layer->begin_update(t);
    for (std::size_t i = 0; i < b.blocks.size(); ++i) {
      layer->begin_block(b.blocks[i]);
      for (const InputVertex& v : b.vertices[i]) layer->add_vertex(v);
    }
    layer->end_update();
    layer->sync(graph.get());
  };
  run(batches[0], 1);
  EXPECT_NO_ALLOCATIONS(run(batches[1], 2));
  EXPECT_NO_ALLOCATIONS(run(batches[2], 3));
  EXPECT_NO_ALLOCATIONS(run(batches[1], 4));  // a re-mesh of known vertices
  EXPECT_NO_ALLOCATIONS(layer->release_block(batches[0].blocks[0]));
  EXPECT_NO_ALLOCATIONS(run(batches[3], 5));
  EXPECT_EQ(layer->num_objects(), 8u);
}

TEST(ObjectLayerTest, BadConfigAndCapacitiesAreRejectedClearly) {
  std::string error;
  {
    Config c;
    c.labels[semantics::kChair].tolerance_m = 0.0;
    ObjectLayer layer;
    EXPECT_FALSE(layer.init(c, small_capacities(), 1 << 26, &error));
    EXPECT_NE(error.find("labels[3] (chair).tolerance_m"), std::string::npos) << error;
  }
  {
    Config c;
    c.labels[semantics::kTable].min_vertices = 100;
    c.labels[semantics::kTable].max_vertices = 10;
    ObjectLayer layer;
    EXPECT_FALSE(layer.init(c, small_capacities(), 1 << 26, &error));
    EXPECT_NE(error.find("(table)"), std::string::npos) << error;
    EXPECT_NE(error.find("min_vertices <= max_vertices"), std::string::npos) << error;
  }
  {
    Capacities caps = small_capacities();
    caps.objects = 0;
    ObjectLayer layer;
    EXPECT_FALSE(layer.init(Config{}, caps, 1 << 26, &error));
    EXPECT_NE(error.find("objects must be positive"), std::string::npos) << error;
  }
  {
    ObjectLayer layer;
    EXPECT_FALSE(layer.init(Config{}, small_capacities(), 1024, &error));
    EXPECT_NE(error.find("objects"), std::string::npos) << error;
    // Calls on an uninitialised layer are harmless.
    layer.begin_update(1);
    layer.begin_block({0, 0, 0});
    layer.add_vertex(InputVertex{1, 0, 0, 0, semantics::kChair});
    EXPECT_EQ(layer.end_update().vertices, 0u);
    EXPECT_FALSE(layer.sync(nullptr));
  }
}

TEST(ObjectLayerTest, EveryBoardsBudgetHoldsItsCapacities) {
  const auto fits = [](const char* board, const Capacities& c, std::size_t bytes) {
    EXPECT_EQ(c.check(), "") << board;
    const std::size_t planned = ObjectLayer::plan(c).total_bytes();
    EXPECT_LE(planned, bytes) << board << ": objects capacities need " << planned << " bytes";
    std::printf("%s objects arena: planned %zu of %zu bytes\n", board, planned, bytes);
  };
  {
    namespace b = budgets::host_sim::objects;
    fits("host_sim", Capacities{b::kClusterVertices, b::kTrackedVertices, b::kVertexKeys, b::kTrackedBlocks, b::kObjects},
         b::kArenaBytes);
  }
  {
    namespace b = budgets::xavier_nx::objects;
    fits("xavier_nx", Capacities{b::kClusterVertices, b::kTrackedVertices, b::kVertexKeys, b::kTrackedBlocks, b::kObjects},
         b::kArenaBytes);
  }
  const Capacities active = capacities_from_budget();
  EXPECT_EQ(active.objects, budgets::active::objects::kObjects);
}

}  // namespace
}  // namespace qsg::objects

namespace qsg::objects {
namespace {

// A table seen as a dense top and thin legs: the vertex mean is pulled up toward the top, the position (what the
// scene graph reports) is the box centre.
TEST(ObjectLayerTest, PositionIsTheBoxCentreAndTheVertexMeanIsKeptApart) {
  auto layer = make_layer();
  auto graph = scene_graph::testing::make_graph();
  std::uint64_t key = 1;
  auto table = box_surface({0.1, 0.1, 0.7}, {0.7, 0.7, 0.75}, semantics::kTable, &key);  // the top
  for (const double x : {0.1, 0.7})
    for (const double y : {0.1, 0.7})
      table = concat(table, box_surface({x, y, 0.0}, {x, y, 0.65}, semantics::kTable, &key));  // legs
  present(layer.get(), table, 1);
  const auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 1u);
  EXPECT_LT((objs[0].position_m - Eigen::Vector3d(0.4, 0.4, 0.375)).norm(), 1e-5);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Vertex& v : table) mean += Eigen::Vector3d(v.v.x, v.v.y, v.v.z);
  mean /= static_cast<double>(table.size());
  EXPECT_LT((objs[0].vertex_mean_m - mean).norm(), 1e-5);
  EXPECT_GT(objs[0].vertex_mean_m.z(), 0.5) << "the top dominates the mean";
  ASSERT_TRUE(layer->sync(graph.get()));
  const scene_graph::ObjectAttributes* attr = graph->object(objs[0].node);
  ASSERT_NE(attr, nullptr);
  EXPECT_TRUE(attr->position_m.isApprox(objs[0].position_m));
}

// Two ends of one table seen apart (neither centre in the other's box), then the near end grows until its box
// contains the far end's centre: the paper's rule merges the two existing objects, one node goes.
TEST(ObjectLayerTest, ExistingObjectsMergeWhenAGrownBoxContainsTheOthersCentre) {
  for (const bool merge : {true, false}) {
    Config config = all_keys();
    config.merge_overlapping = merge;
    config.merge_intersecting = merge;    // the side's box reaches into the far end's
    config.merge_by_size_prior = false;   // the two ends fit one table: the prior alone would merge them at once
    auto layer = make_layer(config);
    auto graph = scene_graph::testing::make_graph();
    std::uint64_t key = 1;
    const auto near = box_surface({0.0, 0.0, 0.0}, {0.3, 1.0, 0.7}, semantics::kTable, &key);
    const auto far = box_surface({1.0, 0.5, 0.0}, {1.3, 1.0, 0.7}, semantics::kTable, &key);
    present(layer.get(), concat(near, far), 1);
    ASSERT_EQ(layer->num_objects(), 2u);
    ASSERT_TRUE(layer->sync(graph.get()));
    const NodeId near_node = objects_of(*layer)[0].node;
    // Connected to the near end only (0.05 m from it, 0.4 m from the far end). Its blocks are re-meshed, so
    // they present every vertex they hold.
    const auto side = box_surface({0.35, 0.0, 0.0}, {1.3, 0.1, 0.7}, semantics::kTable, &key);
    present(layer.get(), concat(concat(near, far), side), 2);
    ASSERT_TRUE(layer->sync(graph.get()));
    EXPECT_EQ(layer->num_objects(), merge ? 1u : 2u) << "merge_overlapping=" << merge;
    EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), merge ? 1u : 2u);
    EXPECT_EQ(layer->counters().objects_overlap_merged, merge ? 1u : 0u);
    EXPECT_TRUE(graph->has_node(near_node)) << "the larger object keeps its node";
    if (merge) {
      const auto objs = objects_of(*layer);
      EXPECT_NEAR(objs[0].max_m.x(), 1.3, 1e-6);
      EXPECT_EQ(objs[0].num_vertices, objs[0].num_keys);
    }
  }
}

// A merge offers the merged object's keys to the one that stays through its reservoir: the cap holds after a
// merge too (a concatenation let every merge exceed it; under drift a new cluster merges into its object each pass).
TEST(ObjectLayerTest, AMergedObjectKeepsItsKeysWithinTheCap) {
  Config config;
  config.max_keys_per_object = 40;
  config.merge_by_size_prior = false;
  auto layer = make_layer(config);
  std::uint64_t key = 1;
  const auto near = box_surface({0.0, 0.0, 0.0}, {0.3, 1.0, 0.7}, semantics::kTable, &key);
  const auto far = box_surface({1.0, 0.5, 0.0}, {1.3, 1.0, 0.7}, semantics::kTable, &key);
  present(layer.get(), concat(near, far), 1);
  ASSERT_EQ(layer->num_objects(), 2u);
  const auto side = box_surface({0.35, 0.0, 0.0}, {1.3, 0.1, 0.7}, semantics::kTable, &key);
  present(layer.get(), concat(concat(near, far), side), 2);
  ASSERT_EQ(layer->num_objects(), 1u);
  const auto objs = objects_of(*layer);
  EXPECT_EQ(objs[0].num_keys, 40u);
  EXPECT_GT(objs[0].num_vertices, 200u);
  std::size_t kept = 0;
  layer->for_each_vertex_key(objs[0].node, [&](std::uint64_t) { ++kept; });
  EXPECT_EQ(kept, 40u);
  EXPECT_LE(key_chunks_in_use(*layer), (40u + 14u) / 15u) << "chunks stay full: no partial chunk per merge";
}

// A fragment too small to be an object on its own, farther than the tolerance from an object's vertices but
// inside its box, joins that object rather than lingering as a tentative one.
TEST(ObjectLayerTest, ATentativeFragmentInsideAnObjectsBoxJoinsIt) {
  auto layer = make_layer();
  std::uint64_t key = 1;
  // A hollow 1 m cube of table vertices: its centre is 0.5 m from every vertex.
  const auto shell = box_surface({0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, semantics::kTable, &key, 0.1);
  present(layer.get(), shell, 1);
  ASSERT_EQ(layer->num_objects(), 1u);
  std::vector<Vertex> inner;
  for (int i = 0; i < 5; ++i) {
    Vertex v;
    v.v = InputVertex{key++, 0.4f + 0.05f * static_cast<float>(i), 0.5f, 0.5f, semantics::kTable};
    v.block = block_of(v.v.x, v.v.y, v.v.z);
    inner.push_back(v);
  }
  present(layer.get(), concat(shell, inner), 2);  // re-meshed blocks present every vertex they hold
  EXPECT_EQ(layer->num_objects(), 1u);
  EXPECT_EQ(layer->num_tentative_objects(), 0u) << "the fragment joined the object";
  EXPECT_EQ(objects_of(*layer)[0].num_vertices, shell.size() + inner.size());
  EXPECT_EQ(layer->counters().objects_overlap_merged, 1u);
}

// The box follows the surface: vertices on the boundary that go stale or move inward shrink it; vertices
// released with their block keep bounding it.
TEST(ObjectLayerTest, BoxShrinksWhenBoundaryVerticesGoStaleOrMoveButKeepsReleasedOnes) {
  auto layer = make_layer();
  std::uint64_t key = 1;
  // One chair in block (0,0,0) and its continuation in block (1,0,0).
  const auto a = box_surface({0.05, 0.05, 0.05}, {0.75, 0.55, 0.75}, semantics::kChair, &key);
  const auto b = box_surface({0.85, 0.05, 0.05}, {1.15, 0.55, 0.75}, semantics::kChair, &key);
  present(layer.get(), concat(a, b), 1);
  ASSERT_EQ(layer->num_objects(), 1u);
  EXPECT_NEAR(objects_of(*layer)[0].max_m.z(), 0.75, 1e-6);
  // Block a is re-meshed without its top layer (z = 0.75): the box's top comes down to the highest vertex left
  // in a (0.70) or in b (still 0.75), so it stays 0.75 until b's top goes too.
  std::vector<Vertex> a_low;
  for (const Vertex& v : a)
    if (v.v.z < 0.74f) a_low.push_back(v);
  present(layer.get(), a_low, 2);
  EXPECT_NEAR(objects_of(*layer)[0].max_m.z(), 0.75, 1e-6);
  std::vector<Vertex> b_low;
  for (const Vertex& v : b)
    if (v.v.z < 0.74f) b_low.push_back(v);
  present(layer.get(), b_low, 3);
  EXPECT_NEAR(objects_of(*layer)[0].max_m.z(), 0.70, 1e-5);
  EXPECT_GE(layer->counters().boxes_recomputed, 1u);
  // A vertex on the x = 1.15 face moves inward (same key, new position): the box follows.
  std::vector<Vertex> b_moved = b_low;
  for (Vertex& v : b_moved)
    if (v.v.x > 1.14f) v.v.x = 1.10f;
  present(layer.get(), b_moved, 4);
  EXPECT_NEAR(objects_of(*layer)[0].max_m.x(), 1.10, 1e-5);
  // Block b leaves the window, then block a loses its low layer: b's released vertices still bound the box.
  layer->begin_update(5);
  layer->release_block(block_of(0.9, 0.1, 0.1));
  layer->end_update();
  std::vector<Vertex> a_mid;
  for (const Vertex& v : a_low)
    if (v.v.z > 0.06f) a_mid.push_back(v);
  present(layer.get(), a_mid, 6);
  const auto objs = objects_of(*layer);
  ASSERT_EQ(objs.size(), 1u);
  EXPECT_NEAR(objs[0].min_m.z(), 0.05, 1e-5) << "b's released bottom layer still bounds the box";
  EXPECT_NEAR(objs[0].max_m.x(), 1.10, 1e-5);
  EXPECT_NEAR(objs[0].max_m.z(), 0.70, 1e-5);
}

// The minimum vertex count is a noise gate, the same for large and medium labels: a large object seen only in
// part (a low coffee table's side face, ~30 vertices at 0.1 m voxels) is an object.
TEST(ObjectLayerTest, APartlySeenLargeObjectNeedsOnlyTheCommonMinimum) {
  const LabelTable t = default_label_params();
  EXPECT_EQ(t[semantics::kTable].min_vertices, t[semantics::kChair].min_vertices);
  EXPECT_LT(t[semantics::kPicture].min_vertices, t[semantics::kChair].min_vertices);
  auto layer = make_layer();
  std::uint64_t key = 1;
  // A 0.5 x 0.35 m side face at 0.1 m spacing: 6 x 4 + ... vertices.
  const auto face = box_surface({0.1, 0.1, 0.0}, {0.6, 0.1, 0.3}, semantics::kTable, &key, 0.1);
  ASSERT_GE(face.size(), t[semantics::kTable].min_vertices);
  ASSERT_LT(face.size(), 40u);
  present(layer.get(), face, 1);
  EXPECT_EQ(layer->num_objects(), 1u);
  EXPECT_EQ(layer->num_tentative_objects(), 0u);
}

// A bed seen by a low camera: first its foot end (frame and mattress sides, below the camera), later the headboard
// above the mattress, 1.6 m away (the mattress top at camera height is never seen). The size prior makes them
// one object whose box covers both and whose position is the bed's centre; without it they stay two.
TEST(ObjectLayerTest, ABedSeenAsTwoFragmentsOverTwoUpdatesBecomesOneObject) {
  for (const bool prior : {true, false}) {
    Config config;
    config.merge_by_size_prior = prior;
    auto layer = make_layer(config);
    auto graph = scene_graph::testing::make_graph();
    std::uint64_t key = 1;
    const auto foot = box_surface({9.15, 1.75, 0.0}, {9.55, 3.50, 0.50}, semantics::kBed, &key, 0.1);
    const auto head = box_surface({7.45, 1.85, 0.55}, {7.55, 3.35, 0.85}, semantics::kBed, &key, 0.1);
    present(layer.get(), foot, 1);
    ASSERT_TRUE(layer->sync(graph.get()));
    ASSERT_EQ(layer->num_objects(), 1u);
    present(layer.get(), head, 2);
    ASSERT_TRUE(layer->sync(graph.get()));
    EXPECT_EQ(layer->num_objects(), prior ? 1u : 2u) << "merge_by_size_prior=" << prior;
    EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), prior ? 1u : 2u);
    EXPECT_EQ(layer->counters().objects_size_merged, prior ? 1u : 0u);
    if (!prior) continue;
    const ObjectView bed = objects_of(*layer)[0];
    EXPECT_NEAR(bed.min_m.x(), 7.45, 1e-5);
    EXPECT_NEAR(bed.max_m.x(), 9.55, 1e-5);
    EXPECT_NEAR(bed.max_m.z(), 0.85, 1e-5);
    EXPECT_EQ(bed.num_vertices, foot.size() + head.size()) << "the fragment's vertices stay with the object";
    EXPECT_EQ(bed.num_keys, foot.size() + head.size());
    EXPECT_LT((bed.position_m.head<2>() - Eigen::Vector2d(8.5, 2.625)).norm(), 0.05);
    const scene_graph::ObjectAttributes* attr = graph->object(bed.node);
    ASSERT_NE(attr, nullptr);
    EXPECT_TRUE(attr->position_m.isApprox(bed.position_m));
  }
}

// The size prior pairs fragments of one instance only: two beds side by side whose joint box is wider than one bed
// can be, and a table above another (a floor apart), stay apart.
TEST(ObjectLayerTest, TheSizePriorKeepsObjectsThatDoNotFitOneInstanceApart) {
  auto layer = make_layer();
  std::uint64_t key = 1;
  auto scene = concat(box_surface({0.0, 0.0, 0.0}, {1.0, 2.0, 0.5}, semantics::kBed, &key, 0.1),
                      box_surface({1.5, 0.0, 0.0}, {2.5, 2.0, 0.5}, semantics::kBed, &key, 0.1));
  scene = concat(scene, box_surface({5.0, 0.0, 0.0}, {6.2, 0.8, 0.75}, semantics::kTable, &key, 0.1));
  scene = concat(scene, box_surface({5.0, 0.0, 3.0}, {6.2, 0.8, 3.75}, semantics::kTable, &key, 0.1));
  present(layer.get(), scene, 1);
  EXPECT_EQ(layer->num_objects(), 4u);
  EXPECT_EQ(layer->counters().objects_merged, 0u);
  // A table's far legs, 1.4 m from its near legs, do fit one table.
  present(layer.get(), box_surface({5.0, 1.8, 0.0}, {6.2, 1.9, 0.65}, semantics::kTable, &key, 0.1), 2);
  EXPECT_EQ(layer->num_objects(), 4u);
  EXPECT_EQ(layer->counters().objects_size_merged, 1u);
}

// Hydra's overlap rule: two fragments of a sofa whose boxes intersect, though neither centre lies in the other's
// box and no vertex of one is within the tolerance of the other (two L-shaped walls of vertices), merge.
// Visits kept apart (Config::archive_after_s): a chair seen, left behind (its block released) and seen again in
// other drift long after is a second object, so that a correction can move each visit with its own drift; seen
// again soon after, with archiving off, or with the stores past Config::archive_below_use, it is the same object.
TEST(ObjectLayerTest, AnArchivedObjectDoesNotAbsorbARevisitMadeLongAfter) {
  constexpr std::uint64_t kSecond = 1000000000ull;
  std::uint64_t key = 1;
  const auto first = box_surface({0.05, 0.05, 0.05}, {0.55, 0.55, 0.75}, semantics::kChair, &key);  // one block
  // The revisit: 0.1 m off (drift), on new vertex keys; the boxes intersect and each centre lies in the other box.
  const auto again = box_surface({0.15, 0.05, 0.05}, {0.65, 0.55, 0.75}, semantics::kChair, &key);
  struct Case {
    double archive_after_s;
    std::uint64_t revisit_s;  // the chair was seen at 1 s; its block left the window at 2 s
    double below_use;         // one object is 1/64 of the object store
    std::size_t objects;
  };
  for (const Case& c :
       {Case{10.0, 30, 0.5, 2}, Case{10.0, 5, 0.5, 1}, Case{0.0, 30, 0.5, 1}, Case{10.0, 30, 0.01, 1}}) {
    Config config = all_keys();
    config.archive_after_s = c.archive_after_s;
    config.archive_below_use = c.below_use;
    auto layer = make_layer(config);
    auto graph = scene_graph::testing::make_graph();
    present(layer.get(), first, 1 * kSecond);
    layer->begin_update(2 * kSecond);
    layer->release_block(block_of(0.1, 0.1, 0.1));
    layer->end_update();
    ASSERT_EQ(layer->num_objects(), 1u);
    present(layer.get(), again, c.revisit_s * kSecond);
    const auto objs = objects_of(*layer);
    ASSERT_EQ(objs.size(), c.objects) << "archive_after_s=" << c.archive_after_s << " revisit at " << c.revisit_s;
    EXPECT_EQ(layer->counters().archived_kept_apart > 0, c.objects == 2u);
    EXPECT_EQ(layer->counters().archived_merged_full > 0, c.below_use < 0.5) << "the stores' policy when filling";
    ASSERT_TRUE(layer->sync(graph.get()));
    EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), c.objects);
    // Its life (merge_revisits' Lifetime) starts with the update that created it; merged, with the earlier one's.
    EXPECT_EQ(objs[0].first_update_ns, 1 * kSecond);
    if (c.objects != 2u) continue;
    EXPECT_EQ(objs[1].first_update_ns, c.revisit_s * kSecond);
    // Each visit keeps its own box and its own time, when its vertices were last seen (leaving the window at 2 s is
    // not an observation).
    EXPECT_NEAR(objs[0].min_m.x(), 0.05, 1e-6);
    EXPECT_NEAR(objs[1].min_m.x(), 0.15, 1e-6);
    EXPECT_EQ(objs[0].last_update_ns, 1 * kSecond);
    EXPECT_EQ(objs[1].last_update_ns, c.revisit_s * kSecond);
    EXPECT_EQ(objs[1].num_keys, again.size());
  }
}

TEST(ObjectLayerTest, FragmentsWhoseBoxesIntersectMergeUnlessDisabled) {
  for (const bool intersect : {true, false}) {
    Config config;
    config.merge_intersecting = intersect;
    auto layer = make_layer(config);
    std::uint64_t key = 1;
    // L of walls along x = 0 and y = 0 (box 0..1 x 0..1), and along x = 1.6 and y = 1.6 (box 0.7..1.6 squared).
    auto a = concat(box_surface({0.0, 0.0, 0.0}, {1.0, 0.0, 0.5}, semantics::kSofa, &key, 0.1),
                    box_surface({0.0, 0.1, 0.0}, {0.0, 1.0, 0.5}, semantics::kSofa, &key, 0.1));
    auto b = concat(box_surface({0.7, 1.6, 0.0}, {1.6, 1.6, 0.5}, semantics::kSofa, &key, 0.1),
                    box_surface({1.6, 0.7, 0.0}, {1.6, 1.5, 0.5}, semantics::kSofa, &key, 0.1));
    present(layer.get(), a, 1);
    present(layer.get(), concat(a, b), 2);
    EXPECT_EQ(layer->num_objects(), intersect ? 1u : 2u) << "merge_intersecting=" << intersect;
    EXPECT_EQ(layer->counters().objects_overlap_merged, 0u) << "not the centre-in-box rule";
    EXPECT_EQ(layer->counters().objects_intersect_merged + layer->counters().clusters_overlap_merged,
              intersect ? 1u : 0u);
  }
}

// The merge search goes through the grid index: with many objects seen (far away), a new fragment is tested
// against its neighbours only, and the cell size changes the cost, not the result.
TEST(ObjectLayerTest, TheMergeSearchTestsNearbyObjectsOnlyWhateverTheCellSize) {
  Capacities caps = small_capacities();
  caps.objects = 256;  // 120 chairs and, for a moment, their 120 seats
  caps.cluster_vertices = 32768;
  caps.tracked_vertices = 32768;
  caps.vertex_keys = 65536;
  caps.tracked_blocks = 2048;
  std::vector<std::vector<ObjectView>> results;
  for (const double cell_m : {0.25, 2.0, 50.0}) {
    Config config;
    config.index_cell_m = cell_m;
    auto layer = make_layer(config, caps);
    std::uint64_t key = 1;
    // 120 chairs on a 3 m grid, each seen first as its back and a rail (box 0.5 x 0.5 x 0.9), then its seat:
    // farther than the tolerance from both, inside their box.
    const auto chair_frame = [&](double x, double y) {
      return concat(box_surface({x, y, 0.0}, {x + 0.5, y, 0.9}, semantics::kChair, &key, 0.1),
                    box_surface({x, y + 0.1, 0.0}, {x, y + 0.5, 0.0}, semantics::kChair, &key, 0.1));
    };
    const auto seat = [&](double x, double y) {
      return box_surface({x + 0.1, y + 0.25, 0.45}, {x + 0.4, y + 0.45, 0.45}, semantics::kChair, &key, 0.1);
    };
    std::vector<Vertex> frames, seats, first_chair;
    for (int i = 0; i < 120; ++i) {
      const double x = 3.0 * (i % 12), y = 3.0 * (i / 12);
      const auto frame = chair_frame(x, y);
      frames = concat(frames, frame);
      if (i == 0) first_chair = frame;
    }
    const auto first_seat = seat(0.0, 0.0);
    for (int i = 1; i < 120; ++i) seats = concat(seats, seat(3.0 * (i % 12), 3.0 * (i / 12)));
    present(layer.get(), frames, 1);
    ASSERT_EQ(layer->num_objects(), 120u);
    const std::uint64_t visits_before = layer->counters().index_visits;
    // One more fragment next to one chair: its search looks at that chair's neighbourhood, not at 120 objects.
    present(layer.get(), concat(first_chair, first_seat), 2);  // its block is re-meshed: the frame comes again
    EXPECT_EQ(layer->num_objects(), 120u);
    EXPECT_EQ(layer->num_tentative_objects(), 0u) << "the seat joined its chair";
    if (cell_m == 2.0) {
      EXPECT_LE(layer->counters().index_visits - visits_before, 8u);
    }
    present(layer.get(), concat(concat(frames, first_seat), seats), 3);
    EXPECT_EQ(layer->num_objects(), 120u) << "cell " << cell_m;
    EXPECT_EQ(layer->num_tentative_objects(), 0u) << "cell " << cell_m;
    results.push_back(objects_of(*layer));
  }
  for (std::size_t r = 1; r < results.size(); ++r) {
    ASSERT_EQ(results[r].size(), results[0].size());
    for (std::size_t i = 0; i < results[0].size(); ++i) {
      EXPECT_EQ(results[r][i].num_vertices, results[0][i].num_vertices);
      EXPECT_TRUE(results[r][i].min_m.isApprox(results[0][i].min_m));
      EXPECT_TRUE(results[r][i].max_m.isApprox(results[0][i].max_m));
    }
  }
}

}  // namespace
}  // namespace qsg::objects

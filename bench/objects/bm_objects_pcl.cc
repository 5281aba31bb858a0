// Peer comparison for Layer 2 (issue 5 item 8): our object layer's per-label Euclidean clustering against PCL's
// EuclideanClusterExtraction (k-d tree) on the same vertices and tolerance, both times and the ratio from one run,
// after checking that both give the same partition. Optional: built only when PCL is installed (benchmarks
// only; nothing else depends on it).
//
// Point sets: one label, 40 random box-shaped "furniture" surfaces sampled uniformly plus 2% uniform noise in a
// 6 x 6 x 1.5 m room (5k, 20k, 60k points), and the non-structure mesh vertices the frozen frames of bm_objects
// produce (several labels; PCL runs once per label, the layer separates labels itself).
//
// For a partition to be comparable, our layer reports every connected component as an object: min vertex count 1
// (no tentative objects), max count above the set's size (none dropped), and none of the merge rules on top of
// the clustering that PCL does not have (centre-in-box, intersecting boxes, size prior). PCL: min cluster size 1,
// max cluster size unlimited.
//
// What is timed. Ours: begin_update .. end_update of a fresh layer (feeding the points, the voxel-hash grid,
// the flood fill, and creating the objects with their vertex references); init and teardown are not timed.
// PCL: EuclideanClusterExtraction::extract (which builds the k-d tree) on a point cloud converted beforehand,
// with the default KdTree (sorted results, as in PCL's tutorial) and with an unsorted one. Times are thread CPU
// time (both sides are single-threaded).
#include <benchmark/benchmark.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <time.h>

#include "bench/frozen_frames.h"
#include "budgets/budget_table.h"
#include "core/objects/object_layer.h"
#include "core/reconstruction/semantic_tsdf.h"

namespace {

using namespace qsg;

constexpr double kToleranceM = 0.2;  // the layer's default for every label
constexpr std::uint32_t kMaxClusterVertices = 1u << 30;

// This thread's CPU time: both sides are single-threaded, and on a machine shared with other builds the wall
// clock also counts time spent descheduled, unevenly between the two.
double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct PointSet {
  std::string name;
  std::vector<objects::InputVertex> points;  // key = index + 1, so a key names its point
  std::vector<semantics::Label> labels;      // the distinct labels, each clustered on its own
};

// Random box-shaped objects sampled on their surfaces (face chosen by area) plus uniform noise, one label.
PointSet clustered_set(std::size_t n, unsigned seed) {
  PointSet set;
  set.name = "clustered_" + std::to_string(n);
  set.labels = {semantics::kChair};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  struct Box {
    float lo[3], size[3];
    float area[3];  // of the two faces normal to each axis, together
  };
  std::vector<Box> boxes(40);
  for (Box& b : boxes) {
    for (int i = 0; i < 3; ++i) b.size[i] = 0.2f + 1.0f * unit(rng);
    b.lo[0] = 6.0f * unit(rng) - 0.5f * b.size[0];
    b.lo[1] = 6.0f * unit(rng) - 0.5f * b.size[1];
    b.lo[2] = 0.0f;
    b.area[0] = 2.0f * b.size[1] * b.size[2];
    b.area[1] = 2.0f * b.size[0] * b.size[2];
    b.area[2] = 2.0f * b.size[0] * b.size[1];
  }
  std::uniform_int_distribution<std::size_t> pick_box(0, boxes.size() - 1);
  set.points.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    float p[3];
    if (k % 50 == 0) {  // 2% noise anywhere in the room
      p[0] = 6.0f * unit(rng);
      p[1] = 6.0f * unit(rng);
      p[2] = 1.5f * unit(rng);
    } else {
      const Box& b = boxes[pick_box(rng)];
      const float r = unit(rng) * (b.area[0] + b.area[1] + b.area[2]);
      const int axis = r < b.area[0] ? 0 : (r < b.area[0] + b.area[1] ? 1 : 2);
      for (int i = 0; i < 3; ++i) p[i] = b.lo[i] + b.size[i] * unit(rng);
      p[axis] = b.lo[axis] + (unit(rng) < 0.5f ? 0.0f : b.size[axis]);
    }
    set.points[k] = objects::InputVertex{k + 1, p[0], p[1], p[2], semantics::kChair};
  }
  return set;
}

// Every non-structure mesh vertex the frozen frames of bm_objects produced: after each frame, the vertices of
// each re-meshed block replace that block's previous ones (blocks that left the window keep their last mesh),
// one per voxel-edge key (border duplicates dropped), enabled labels only.
PointSet frozen_set() {
  PointSet set;
  set.name = "frozen_frames";
  const std::unique_ptr<bench::FrozenFrames> data = bench::render_frozen_frames(320, 240, 120);
  auto tsdf = std::make_unique<reconstruction::SemanticTsdf>();
  std::string error;
  if (data->frames.empty() ||
      !tsdf->init(reconstruction::Config{}, reconstruction::capacities_from_budget(),
                  budgets::active::reconstruction::kArenaBytes, &error)) {
    std::fprintf(stderr, "bm_objects_pcl: frozen frames unavailable: %s\n", error.c_str());
    return set;
  }
  const objects::LabelTable params = objects::default_label_params();
  std::unordered_map<memory::Index3, std::vector<objects::InputVertex>, memory::Index3Hash> mesh;
  std::uint32_t since = 0;
  for (std::size_t k = 0; k < data->frames.size(); ++k) {
    tsdf->process(*data->frames[k], data->poses[k]);
    tsdf->for_each_block([&](std::uint32_t handle, const reconstruction::SemanticTsdf::BlockView& view) {
      if (view.meshed_stamp <= since) return;
      std::vector<objects::InputVertex>& block = mesh[view.index];
      block.clear();
      reconstruction::SemanticTsdf::VertexCursor cursor;
      reconstruction::MeshVertex v;
      std::uint64_t key = 0;
      while (tsdf->next_block_vertex(handle, &cursor, &v, &key)) {
        if (v.label >= semantics::kNumObjectLabels || !params[v.label].enabled) continue;
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) continue;
        block.push_back(objects::InputVertex{key, v.x, v.y, v.z, v.label});
      }
    });
    since = tsdf->mesh_stamp();
  }
  std::unordered_set<std::uint64_t> seen;
  std::unordered_set<semantics::Label> labels;
  for (const auto& entry : mesh) {
    for (objects::InputVertex v : entry.second) {
      if (!seen.insert(v.key).second) continue;
      v.key = set.points.size() + 1;
      set.points.push_back(v);
      labels.insert(v.label);
    }
  }
  set.labels.assign(labels.begin(), labels.end());
  std::sort(set.labels.begin(), set.labels.end());
  return set;
}

const std::vector<PointSet>& point_sets() {
  static std::vector<PointSet> sets;
  if (sets.empty()) {
    sets.push_back(clustered_set(5000, 5));
    sets.push_back(clustered_set(20000, 20));
    sets.push_back(clustered_set(60000, 60));
    sets.push_back(frozen_set());
  }
  return sets;
}

// ------------------------------------------------------------------------------------------------ ours
objects::Config layer_config(const PointSet& set) {
  objects::Config config;
  config.merge_overlapping = false;
  config.merge_intersecting = false;
  config.merge_by_size_prior = false;
  for (objects::LabelParams& p : config.labels) p.enabled = false;
  for (const semantics::Label l : set.labels) {
    objects::LabelParams& p = config.labels[l];
    p.enabled = true;
    p.tolerance_m = kToleranceM;
    p.min_vertices = 1;
    p.max_vertices = kMaxClusterVertices;
  }
  return config;
}

objects::Capacities layer_capacities(const PointSet& set) {
  objects::Capacities c;
  const std::size_t n = std::max<std::size_t>(set.points.size(), 1024);
  c.cluster_vertices = n;
  c.tracked_vertices = n;
  c.vertex_keys = objects::ObjectLayer::kKeysPerChunk * n;  // a chunk per object even if every point is alone
  c.tracked_blocks = 16;
  c.objects = n;  // every point could be its own cluster
  return c;
}

std::unique_ptr<objects::ObjectLayer> make_layer(const PointSet& set, std::string* error) {
  auto layer = std::make_unique<objects::ObjectLayer>();
  const objects::Capacities caps = layer_capacities(set);
  if (!layer->init(layer_config(set), caps, objects::ObjectLayer::plan(caps).total_bytes(), error)) return nullptr;
  return layer;
}

// The timed part: one update presenting every point (their block does not matter to the clustering).
void cluster_ours(const PointSet& set, objects::ObjectLayer* layer) {
  layer->begin_update(1);
  layer->begin_block({0, 0, 0});
  for (const objects::InputVertex& v : set.points) layer->add_vertex(v);
  layer->end_update();
}

// Cluster id of every point from our layer's objects; false (with why) when a point is missing or repeated.
bool ours_partition(const objects::ObjectLayer& layer, std::size_t n, std::vector<int>* cluster_of,
                    std::string* why) {
  cluster_of->assign(n, -1);
  const objects::Counters& k = layer.counters();
  if (layer.num_tentative_objects() != 0 || k.clusters_too_large != 0 || k.candidate_overflow != 0 ||
      k.tracked_overflow != 0 || k.key_overflow != 0 || k.object_overflow != 0) {
    *why = "our layer did not report every cluster (tentative, too large or overflow)";
    return false;
  }
  std::vector<scene_graph::NodeId> nodes;
  layer.for_each_object([&](const objects::ObjectView& o) { nodes.push_back(o.node); });
  bool ok = true;
  for (std::size_t c = 0; c < nodes.size(); ++c) {
    layer.for_each_vertex_key(nodes[c], [&](std::uint64_t key) {
      if (key == 0 || key > n || (*cluster_of)[key - 1] != -1) {
        ok = false;
        return;
      }
      (*cluster_of)[key - 1] = static_cast<int>(c);
    });
  }
  if (!ok) {
    *why = "our layer returned an unknown or repeated vertex key";
    return false;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if ((*cluster_of)[i] < 0) {
      *why = "our layer left point " + std::to_string(i) + " out of every object";
      return false;
    }
  }
  return true;
}

// ------------------------------------------------------------------------------------------------ PCL
struct PclInput {
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> clouds;  // one per label
  std::vector<std::vector<std::size_t>> index;               // cloud point -> set point
};

PclInput pcl_input(const PointSet& set) {
  PclInput in;
  for (const semantics::Label l : set.labels) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    std::vector<std::size_t> index;
    for (std::size_t i = 0; i < set.points.size(); ++i) {
      const objects::InputVertex& v = set.points[i];
      if (v.label != l) continue;
      cloud->push_back(pcl::PointXYZ(v.x, v.y, v.z));
      index.push_back(i);
    }
    in.clouds.push_back(cloud);
    in.index.push_back(std::move(index));
  }
  return in;
}

// The timed part: one extraction per label (the k-d tree is built inside extract()).
void cluster_pcl(const PclInput& in, bool sorted, std::vector<std::vector<pcl::PointIndices>>* out) {
  out->resize(in.clouds.size());
  for (std::size_t l = 0; l < in.clouds.size(); ++l) {
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>(sorted));
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
    ec.setClusterTolerance(kToleranceM);
    ec.setMinClusterSize(1);
    ec.setMaxClusterSize(kMaxClusterVertices);
    ec.setSearchMethod(tree);
    ec.setInputCloud(in.clouds[l]);
    (*out)[l].clear();
    ec.extract((*out)[l]);
  }
}

bool pcl_partition(const PclInput& in, const std::vector<std::vector<pcl::PointIndices>>& clusters, std::size_t n,
                   std::vector<int>* cluster_of, std::string* why) {
  cluster_of->assign(n, -1);
  int next = 0;
  for (std::size_t l = 0; l < clusters.size(); ++l) {
    for (const pcl::PointIndices& c : clusters[l]) {
      for (const auto i : c.indices) {
        const std::size_t p = in.index[l][static_cast<std::size_t>(i)];
        if ((*cluster_of)[p] != -1) {
          *why = "PCL put point " + std::to_string(p) + " in two clusters";
          return false;
        }
        (*cluster_of)[p] = next;
      }
      ++next;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if ((*cluster_of)[i] < 0) {
      *why = "PCL left point " + std::to_string(i) + " out of every cluster";
      return false;
    }
  }
  return true;
}

// ------------------------------------------------------------------------------------------------ comparison
std::size_t count_clusters(const std::vector<int>& cluster_of) {
  return cluster_of.empty() ? 0 : static_cast<std::size_t>(*std::max_element(cluster_of.begin(), cluster_of.end())) + 1;
}

// Same partition: the map from our cluster ids to PCL's is a bijection (each of our clusters is exactly one of
// PCL's). On a difference, says which point and how large both clusters around it are.
bool same_partition(const PointSet& set, const std::vector<int>& ours, const std::vector<int>& theirs,
                    std::string* why) {
  const std::size_t n = ours.size();
  std::vector<int> ours_size(count_clusters(ours), 0), theirs_size(count_clusters(theirs), 0);
  for (std::size_t i = 0; i < n; ++i) {
    ++ours_size[static_cast<std::size_t>(ours[i])];
    ++theirs_size[static_cast<std::size_t>(theirs[i])];
  }
  std::unordered_map<int, int> o2t, t2o;
  for (std::size_t i = 0; i < n; ++i) {
    const auto a = o2t.emplace(ours[i], theirs[i]);
    const auto b = t2o.emplace(theirs[i], ours[i]);
    if (a.first->second != theirs[i] || b.first->second != ours[i]) {
      const objects::InputVertex& v = set.points[i];
      char buf[320];
      std::snprintf(buf, sizeof(buf),
                    "partition mismatch on %s at point %zu (%.4f, %.4f, %.4f) label %u: our cluster %d (%d points) vs "
                    "PCL cluster %d (%d points); ours has %zu clusters, PCL %zu",
                    set.name.c_str(), i, static_cast<double>(v.x), static_cast<double>(v.y), static_cast<double>(v.z),
                    static_cast<unsigned>(v.label), ours[i], ours_size[static_cast<std::size_t>(ours[i])], theirs[i],
                    theirs_size[static_cast<std::size_t>(theirs[i])], ours_size.size(), theirs_size.size());
      *why = buf;
      return false;
    }
  }
  if (ours_size.size() != theirs_size.size()) {
    *why = "partition mismatch on " + set.name + ": cluster counts differ";
    return false;
  }
  return true;
}

// Runs both once and compares the partitions; fills the cluster count and the largest cluster's size.
bool verify(const PointSet& set, const PclInput& in, std::size_t* clusters, std::size_t* largest, std::string* why) {
  const std::size_t n = set.points.size();
  auto layer = make_layer(set, why);
  if (!layer) return false;
  cluster_ours(set, layer.get());
  std::vector<int> ours, theirs, theirs_unsorted;
  if (!ours_partition(*layer, n, &ours, why)) return false;
  std::vector<std::vector<pcl::PointIndices>> out;
  cluster_pcl(in, true, &out);
  if (!pcl_partition(in, out, n, &theirs, why)) return false;
  if (!same_partition(set, ours, theirs, why)) return false;
  cluster_pcl(in, false, &out);
  if (!pcl_partition(in, out, n, &theirs_unsorted, why)) return false;
  if (!same_partition(set, ours, theirs_unsorted, why)) {
    *why += " (unsorted k-d tree)";
    return false;
  }
  std::vector<int> size(count_clusters(ours), 0);
  for (const int c : ours) ++size[static_cast<std::size_t>(c)];
  *clusters = size.size();
  *largest = size.empty() ? 0 : static_cast<std::size_t>(*std::max_element(size.begin(), size.end()));
  return true;
}

// One iteration = the set clustered by ours, then by PCL (default k-d tree), then by PCL (unsorted k-d tree),
// back to back; the counters are the per-pass means of each (thread CPU time) and their ratios, all from this one
// run, plus the default-tree ratio on the wall clock for reference.
void BM_ObjectsClusterVsPcl(benchmark::State& state) {
  const PointSet& set = point_sets()[static_cast<std::size_t>(state.range(0))];
  state.SetLabel(set.name);
  if (set.points.empty()) {
    state.SkipWithError("empty point set");
    return;
  }
  const PclInput in = pcl_input(set);
  std::size_t clusters = 0, largest = 0;
  std::string why;
  if (!verify(set, in, &clusters, &largest, &why)) {
    std::fprintf(stderr, "bm_objects_pcl: %s: clusters differ from PCL's: %s\n", set.name.c_str(), why.c_str());
    state.SkipWithError(why.c_str());
    return;
  }
  double ours_s = 0.0, pcl_s = 0.0, pcl_unsorted_s = 0.0;  // thread CPU time
  double ours_wall_s = 0.0, pcl_wall_s = 0.0;
  std::size_t passes = 0;
  std::vector<std::vector<pcl::PointIndices>> out;
  for (auto _ : state) {
    state.PauseTiming();
    auto layer = make_layer(set, &why);
    if (!layer) {
      state.SkipWithError(why.c_str());
      return;
    }
    state.ResumeTiming();
    const auto w0 = std::chrono::steady_clock::now();
    const double c0 = thread_cpu_s();
    cluster_ours(set, layer.get());
    const double c1 = thread_cpu_s();
    const auto w1 = std::chrono::steady_clock::now();
    cluster_pcl(in, true, &out);
    const double c2 = thread_cpu_s();
    const auto w2 = std::chrono::steady_clock::now();
    cluster_pcl(in, false, &out);
    const double c3 = thread_cpu_s();
    benchmark::DoNotOptimize(out.data());
    ours_s += c1 - c0;
    pcl_s += c2 - c1;
    pcl_unsorted_s += c3 - c2;
    ours_wall_s += std::chrono::duration<double>(w1 - w0).count();
    pcl_wall_s += std::chrono::duration<double>(w2 - w1).count();
    ++passes;
    state.PauseTiming();
    layer.reset();  // the arena is released outside the timed region
    state.ResumeTiming();
  }
  const double p = static_cast<double>(std::max<std::size_t>(passes, 1));
  const double ours_ms = 1e3 * ours_s / p;
  const double pcl_ms = 1e3 * pcl_s / p;
  const double pcl_unsorted_ms = 1e3 * pcl_unsorted_s / p;
  state.counters["points"] = static_cast<double>(set.points.size());
  state.counters["labels"] = static_cast<double>(set.labels.size());
  state.counters["clusters"] = static_cast<double>(clusters);
  state.counters["largest"] = static_cast<double>(largest);
  state.counters["same_partition"] = 1.0;
  state.counters["ours_ms"] = ours_ms;
  state.counters["pcl_ms"] = pcl_ms;
  state.counters["pcl_unsorted_ms"] = pcl_unsorted_ms;
  state.counters["ratio_pcl_over_ours"] = ours_ms > 0.0 ? pcl_ms / ours_ms : 0.0;
  state.counters["ratio_pcl_unsorted_over_ours"] = ours_ms > 0.0 ? pcl_unsorted_ms / ours_ms : 0.0;
  state.counters["ratio_pcl_over_ours_wall"] = ours_wall_s > 0.0 ? pcl_wall_s / ours_wall_s : 0.0;
}
BENCHMARK(BM_ObjectsClusterVsPcl)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace

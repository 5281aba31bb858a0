// places_eval's ground-truth regions, graph components and --diagnose output (places_diagnosis.h).
#include "bench/places/places_diagnosis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace qsg::bench {

double polygon_area(const world::Polygon2& p) {
  double twice = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d& a = p[i];
    const Eigen::Vector2d& b = p[(i + 1) % p.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return std::abs(twice) * 0.5;
}

// Connected components of the visited rooms through their doors: the connected free-space regions mapped.
std::size_t free_space_regions(const world::World& w, const std::set<std::int32_t>& visited) {
  std::map<std::int32_t, std::int32_t> parent;
  for (std::int32_t r : visited) parent[r] = r;
  const auto find = [&](std::int32_t r) {
    while (parent[r] != r) r = parent[r] = parent[parent[r]];
    return r;
  };
  for (const world::Door& d : w.doors)
    if (visited.count(d.room_a) != 0 && visited.count(d.room_b) != 0) parent[find(d.room_a)] = find(d.room_b);
  std::set<std::int32_t> roots;
  for (std::int32_t r : visited) roots.insert(find(r));
  return roots.size();
}

// Connected free-space regions from the ground-truth grid (for floor plans, whose doors the import records only
// where a separator line marks them): 6-connected components of voxels with at least min_clearance_m (the
// clearance a place needs), counted when the tour passed through them.
// The ground-truth voxel holding p (may lie outside the grid), and its index when it lies inside.
Eigen::Vector3i gt_cell(const sim::GroundTruth& truth, const Eigen::Vector3d& p) {
  return ((p - truth.origin_m) / truth.config.voxel_size_m).array().floor().cast<int>();
}
bool gt_index(const sim::GroundTruth& truth, const Eigen::Vector3d& p, std::size_t* out) {
  const Eigen::Vector3i q = gt_cell(truth, p);
  if ((q.array() < 0).any() || (q.array() >= truth.dims.array()).any()) return false;
  *out = truth.index(q.x(), q.y(), q.z());
  return true;
}

std::size_t free_space_regions_gt(const sim::GroundTruth& truth, const std::vector<Eigen::Vector3d>& path_m,
                                  double min_clearance_m) {
  const std::size_t n = truth.clearance_m.size();
  std::vector<std::int32_t> label(n, -1);
  const auto free = [&](std::size_t i) {
    return truth.voxel_room[i] != sim::kVoxelOccupied && truth.clearance_m[i] >= min_clearance_m;
  };
  const auto voxel_of = [&](const Eigen::Vector3d& p, std::size_t* out) { return gt_index(truth, p, out); };
  std::set<std::int32_t> visited;
  std::int32_t next = 0;
  std::vector<std::size_t> stack;
  const int nx = truth.dims.x(), ny = truth.dims.y(), nz = truth.dims.z();
  for (const Eigen::Vector3d& p : path_m) {
    std::size_t start = 0;
    if (!voxel_of(p, &start) || !free(start)) continue;
    if (label[start] < 0) {
      label[start] = next;
      stack.push_back(start);
      while (!stack.empty()) {
        const std::size_t i = stack.back();
        stack.pop_back();
        const int x = static_cast<int>(i % static_cast<std::size_t>(nx));
        const int y = static_cast<int>((i / static_cast<std::size_t>(nx)) % static_cast<std::size_t>(ny));
        const int z = static_cast<int>(i / (static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny)));
        const int d[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (const auto& o : d) {
          const int xx = x + o[0], yy = y + o[1], zz = z + o[2];
          if (xx < 0 || yy < 0 || zz < 0 || xx >= nx || yy >= ny || zz >= nz) continue;
          const std::size_t j = truth.index(xx, yy, zz);
          if (label[j] >= 0 || !free(j)) continue;
          label[j] = next;
          stack.push_back(j);
        }
      }
      ++next;
    }
    visited.insert(label[start]);
  }
  return visited.size();
}

// Components of the places graph; *sizes gets their node counts.
std::size_t place_components(const scene_graph::SceneGraph& g, std::vector<std::size_t>* sizes) {
  std::vector<scene_graph::NodeId> ids;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kPlace) ids.push_back(n.id);
  });
  std::set<scene_graph::NodeId> seen;
  std::size_t components = 0;
  for (scene_graph::NodeId start : ids) {
    if (!seen.insert(start).second) continue;
    ++components;
    sizes->push_back(0);
    std::vector<scene_graph::NodeId> stack{start};
    while (!stack.empty()) {
      const scene_graph::NodeId id = stack.back();
      stack.pop_back();
      ++sizes->back();
      g.for_each_neighbor(id, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
        if (scene_graph::node_prefix(m) == scene_graph::kPlacePrefix && seen.insert(m).second) stack.push_back(m);
      });
    }
  }
  return components;
}



namespace {

std::size_t place_degree(const scene_graph::SceneGraph& g, scene_graph::NodeId id) {
  std::size_t d = 0;
  g.for_each_neighbor(id, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
    d += scene_graph::node_prefix(m) == scene_graph::kPlacePrefix ? 1 : 0;
  });
  return d;
}

}  // namespace

void track_history(const scene_graph::SceneGraph& g, int kf, std::map<scene_graph::NodeId, NodeHistory>* h) {
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kPlace) return;
    NodeHistory& e = (*h)[n.id];
    if (e.added_kf < 0) e.added_kf = kf;
    const std::size_t d = place_degree(g, n.id);
    e.max_degree = std::max(e.max_degree, d);
    const bool active = g.place(n.id)->is_active;
    if (!active && e.deactivated_kf < 0) {
      e.deactivated_kf = kf;
      e.degree_at_deactivation = d;
      e.neighbours_at_deactivation.clear();
      g.for_each_neighbor(n.id, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
        if (scene_graph::node_prefix(m) == scene_graph::kPlacePrefix) e.neighbours_at_deactivation.push_back(m);
      });
    } else if (active && e.deactivated_kf >= 0) {
      e.deactivated_kf = -1;
      ++e.reactivations;
    }
  });
}

void diagnose_components(const scene_graph::SceneGraph& g, const places::Places& places, const sim::GroundTruth& truth,
                         const std::map<scene_graph::NodeId, NodeHistory>& history) {
  std::vector<places::PlaceInfo> live;
  places.places(&live);
  std::map<scene_graph::NodeId, const places::PlaceInfo*> by_id;
  for (const places::PlaceInfo& p : live) by_id[p.id] = &p;
  std::vector<places::GvdVoxelInfo> gvd;
  places.gvd_voxels(&gvd);
  // GVD voxel -> cluster node, and components of the GVD graph (26-neighbourhood).
  const double s = places.voxel_size_m();
  const auto key = [s](const Eigen::Vector3d& p) {
    return std::make_tuple(static_cast<int>(std::floor(p.x() / s)), static_cast<int>(std::floor(p.y() / s)),
                           static_cast<int>(std::floor(p.z() / s)));
  };
  std::map<std::tuple<int, int, int>, scene_graph::NodeId> owner;
  std::map<std::tuple<int, int, int>, int> gvd_comp;
  for (const places::GvdVoxelInfo& v : gvd) {
    owner[key(v.position_m)] = scene_graph::kNoNode;
    gvd_comp[key(v.position_m)] = -1;
  }
  for (const places::PlaceInfo& p : live)
    for (const Eigen::Vector3d& v : p.voxel_positions_m) owner[key(v)] = p.id;
  std::vector<std::size_t> comp_size;
  for (auto& [k, c] : gvd_comp) {
    if (c >= 0) continue;
    const int id = static_cast<int>(comp_size.size());
    comp_size.push_back(0);
    std::vector<std::tuple<int, int, int>> stack{k};
    c = id;
    while (!stack.empty()) {
      const auto [x, y, z] = stack.back();
      stack.pop_back();
      ++comp_size.back();
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            auto it = gvd_comp.find({x + dx, y + dy, z + dz});
            if (it == gvd_comp.end() || it->second >= 0) continue;
            it->second = id;
            stack.push_back(it->first);
          }
    }
  }
  std::vector<std::size_t> sorted = comp_size;
  std::sort(sorted.rbegin(), sorted.rend());
  std::printf("  diagnose: %zu GVD voxels in %zu GVD components (largest", gvd.size(), comp_size.size());
  for (std::size_t i = 0; i < std::min<std::size_t>(6, sorted.size()); ++i) std::printf(" %zu", sorted[i]);
  std::printf(")\n");
  // Places components.
  std::set<scene_graph::NodeId> seen;
  std::vector<std::vector<scene_graph::NodeId>> comps;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kPlace || !seen.insert(n.id).second) return;
    comps.emplace_back();
    std::vector<scene_graph::NodeId> stack{n.id};
    while (!stack.empty()) {
      const scene_graph::NodeId id = stack.back();
      stack.pop_back();
      comps.back().push_back(id);
      g.for_each_neighbor(id, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
        if (scene_graph::node_prefix(m) == scene_graph::kPlacePrefix && seen.insert(m).second) stack.push_back(m);
      });
    }
  });
  std::sort(comps.begin(), comps.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  std::map<std::string, int> causes;
  for (std::size_t ci = 1; ci < comps.size(); ++ci) {
    std::size_t active = 0;
    for (scene_graph::NodeId id : comps[ci]) active += g.place(id)->is_active ? 1 : 0;
    std::printf("  extra component %zu: %zu nodes, %zu active\n", ci, comps[ci].size(), active);
    for (scene_graph::NodeId id : comps[ci]) {
      const scene_graph::PlaceAttributes* a = g.place(id);
      const auto hit = history.find(id);
      const NodeHistory h = hit == history.end() ? NodeHistory{} : hit->second;
      std::string cause;
      char extra[256] = "";
      if (!a->is_active) {
        cause = h.degree_at_deactivation > 0 ? "inactive: lost its edges after leaving"
                                            : (h.max_degree > 0 ? "inactive: lost its edges before leaving"
                                                                : "inactive: never had an edge");
        // Where its edges at deactivation went: to nodes now gone, or to nodes still there.
        int gone = 0, still_there = 0, still_linked = 0;
        for (scene_graph::NodeId m : h.neighbours_at_deactivation) {
          if (g.place(m) == nullptr) {
            ++gone;
            continue;
          }
          ++still_there;
          g.for_each_neighbor(id, [&](scene_graph::NodeId x, const scene_graph::EdgeRecord&) { still_linked += x == m; });
        }
        std::snprintf(extra, sizeof(extra), " (deactivated at keyframe %d with %zu place edges: %d to removed nodes, "
                      "%d to nodes still in the graph, %d of them still linked)", h.deactivated_kf,
                      h.degree_at_deactivation, gone, still_there, still_linked);
      } else {
        const auto pit = by_id.find(id);
        if (pit == by_id.end()) {
          cause = "active in graph but not live";
        } else {
          const places::PlaceInfo& p = *pit->second;
          // Does the cluster touch GVD voxels of other clusters or of none?
          std::size_t touch_other = 0, touch_unclustered = 0;
          int comp = -1;
          for (const Eigen::Vector3d& v : p.voxel_positions_m) {
            const auto [x, y, z] = key(v);
            comp = gvd_comp[key(v)];
            for (int dz = -1; dz <= 1; ++dz)
              for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                  auto it = owner.find({x + dx, y + dy, z + dz});
                  if (it == owner.end()) continue;
                  if (it->second == scene_graph::kNoNode) ++touch_unclustered;
                  else if (it->second != id) ++touch_other;
                }
          }
          const std::size_t cs = comp >= 0 ? comp_size[static_cast<std::size_t>(comp)] : 0;
          if (touch_other > 0) cause = "active: touches another cluster but no graph edge";
          else if (cs == p.num_voxels) cause = "active: isolated GVD fragment";
          else cause = "active: GVD component larger than its cluster (unclustered or edge-less neighbours)";
          std::snprintf(extra, sizeof(extra), " voxels %u gvd_comp %zu touch_other %zu touch_unclustered %zu edges %zu",
                        p.num_voxels, cs, touch_other, touch_unclustered, p.edges.size());
        }
      }
      {
        const Eigen::Vector3d q = (a->position_m - truth.origin_m) / truth.config.voxel_size_m;
        const Eigen::Vector3i qi = q.array().floor().cast<int>();
        if ((qi.array() >= 0).all() && (qi.array() < truth.dims.array()).all()) {
          const std::size_t gi = truth.index(qi.x(), qi.y(), qi.z());
          const std::size_t len = std::strlen(extra);
          std::snprintf(extra + len, sizeof(extra) - len, " gt_clear %.2f gt_room %d", truth.clearance_m[gi],
                        static_cast<int>(truth.voxel_room[gi]));
        }
      }
      ++causes[cause];
      if (comps[ci].size() <= 12 || id == comps[ci].front())
        std::printf("    node %llx %s at %.2f %.2f %.2f clear %.2f basis %u true_gvd %.2f added %d deact %d "
                    "deg_at_deact %zu max_deg %zu reactiv %d%s\n",
                    static_cast<unsigned long long>(id), cause.c_str(), a->position_m.x(), a->position_m.y(),
                    a->position_m.z(), a->distance_m, static_cast<unsigned>(a->num_basis_points),
                    truth.distance_to_gvd(a->position_m), h.added_kf, h.deactivated_kf, h.degree_at_deactivation,
                    h.max_degree, h.reactivations, extra);
    }
  }
  for (const auto& [c, n] : causes) std::printf("  diagnose cause: %3d x %s\n", n, c.c_str());
}

}  // namespace qsg::bench

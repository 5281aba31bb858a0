#include "core/doors/online_doors.h"

#include <algorithm>
#include <cmath>

#include "budgets/budget_table.h"

namespace qsg::rooms {

namespace sg = scene_graph;

std::string OnlineDoorCapacities::check() const {
  if (wall_tiles == 0) return "doors.wall_tiles: must be positive";
  if (window_side < 16) return "doors.window_side: must be at least 16 cells, got " + std::to_string(window_side);
  if (places == 0 || doors == 0 || candidates == 0 || place_edges == 0)
    return "doors: places, doors, candidates and place_edges must be positive";
  return {};
}

OnlineDoorCapacities OnlineDoorCapacities::from_budget() {
  OnlineDoorCapacities c;
  c.wall_tiles = budgets::active::doors::kWallTiles;
  c.window_side = budgets::active::doors::kWindowSide;
  c.places = budgets::active::doors::kPlaces;
  c.doors = budgets::active::doors::kDoors;
  c.candidates = budgets::active::doors::kCandidates;
  c.place_edges = budgets::active::doors::kPlaceEdges;
  return c;
}

namespace {

DoorWorkspace::Capacities workspace_capacities(const OnlineDoorCapacities& c) {
  DoorWorkspace::Capacities w;
  w.cells = c.window_side * c.window_side;
  w.max_side = c.window_side;
  w.places = c.places;
  w.candidates = c.candidates;
  return w;
}

BypassGraph::Capacities bypass_capacities(const OnlineDoorCapacities& c) {
  BypassGraph::Capacities b;
  b.places = c.places;
  b.edges = c.place_edges;
  return b;
}

}  // namespace

memory::ArenaPlan OnlineDoors::plan(const OnlineDoorCapacities& c) {
  memory::ArenaPlan p;
  p.add_plan(WallMap::plan(c.wall_tiles));
  p.add_plan(DoorSet::plan(c.doors));
  p.add_plan(DoorWorkspace::plan(workspace_capacities(c)));
  p.add_plan(BypassGraph::plan(bypass_capacities(c)));
  p.add_plan(WallSight::plan(c.window_side * c.window_side));
  p.add_array<Door>(c.candidates);
  return p;
}

bool OnlineDoors::init(const DoorConfig& config, const OnlineDoorCapacities& capacities, std::size_t budget_bytes,
                       std::string* error) {
  ready_ = false;
  if (!config.validate(error)) return false;
  const std::string bad = capacities.check();
  if (!bad.empty()) {
    if (error != nullptr) *error = bad;
    return false;
  }
  if (2.0 * config.slice_half_band_m / config.cell_m >= 31.0) {
    if (error != nullptr) *error = "doors: the online stage needs a slice band under 31 cells tall";
    return false;
  }
  config_ = config;
  capacities_ = capacities;
  const memory::ArenaPlan p = plan(capacities);
  if (!arena_.create("doors", p, budget_bytes == 0 ? p.total_bytes() : budget_bytes, error)) return false;
  bool ok = wall_map_.carve(arena_, capacities.wall_tiles, config.cell_m);
  arena_.align_to_plan_boundary();
  ok = ok && doors_.carve(arena_, capacities.doors, config);
  arena_.align_to_plan_boundary();
  ok = ok && workspace_.carve(arena_, workspace_capacities(capacities));
  arena_.align_to_plan_boundary();
  ok = ok && bypass_.carve(arena_, bypass_capacities(capacities));
  arena_.align_to_plan_boundary();
  ok = ok && sight_.carve(arena_, capacities.window_side * capacities.window_side);
  arena_.align_to_plan_boundary();
  found_ = arena_.carve_array<Door>(capacities.candidates);
  arena_.align_to_plan_boundary();
  ok = ok && found_ != nullptr && arena_.seal();
  if (!ok) {
    if (error != nullptr) *error = "doors: the arena's carve does not match its plan";
    return false;
  }
  ready_ = true;
  return true;
}

void OnlineDoors::begin_pass(const Eigen::Vector3d& robot_m) {
  begun_ = false;
  climbing_ = false;
  num_places_ = 0;
  places_dropped_ = 0;
  if (ready_) bypass_.clear();
  if (!ready_ || !robot_m.allFinite()) return;
  const double previous = last_robot_z_m_;
  last_robot_z_m_ = robot_m.z();
  if (std::isfinite(previous) && std::abs(robot_m.z() - previous) > config_.storey_bin_m) {
    climbing_ = true;
    return;
  }
  const int side = static_cast<int>(capacities_.window_side);
  // Cell-aligned, so that the WallMap's cells are the raster's.
  raster_.cell_m = config_.cell_m;
  raster_.cols = side;
  raster_.rows = side;
  raster_.lo = Eigen::Vector2d(std::floor(robot_m.x() / config_.cell_m) - side / 2,
                               std::floor(robot_m.y() / config_.cell_m) - side / 2) *
               config_.cell_m;
  slice_z_m_ = robot_m.z() + config_.slice_above_robot_m;
  begun_ = true;
}

bool OnlineDoors::takes(const Eigen::Vector3d& p, int* c, int* r) const {
  return begun_ && p.allFinite() && std::abs(p.z() - slice_z_m_) <= config_.place_band_m &&
         raster_.cell_of(p.x(), p.y(), c, r);
}

void OnlineDoors::add_place(const Eigen::Vector3d& p) {
  int c = 0, r = 0;
  if (!takes(p, &c, &r)) return;
  if (num_places_ == capacities_.places) {
    ++places_dropped_;
    return;
  }
  workspace_.place_cells()[num_places_++] = static_cast<std::uint32_t>(static_cast<std::size_t>(r) * raster_.cols + c);
}

// The places in the window's box come from the graph's grid and open places (not a scan of the places layer), and
// are taken in the node table's order, as a scan would take them: with more than the capacity, the first ones. Their
// slots are kept in the place cells' buffer (a max-heap while collecting), which add_place then overwrites in order.
void OnlineDoors::add_places(const sg::SceneGraph& graph) {
  if (!begun_) return;
  const double lo[3] = {raster_.lo.x(), raster_.lo.y(), slice_z_m_ - config_.place_band_m};
  const double hi[3] = {raster_.lo.x() + raster_.cols * raster_.cell_m, raster_.lo.y() + raster_.rows * raster_.cell_m,
                        slice_z_m_ + config_.place_band_m};
  std::uint32_t* slots = workspace_.place_cells();
  const std::size_t capacity = capacities_.places;
  std::size_t n = 0;
  graph.for_each_place_in_box(lo, hi, [&](std::uint32_t slot, const sg::NodeRecord&, const sg::PlaceAttributes& a) {
    int c = 0, r = 0;
    if (!takes(a.position_m, &c, &r)) return;
    if (n < capacity) {
      slots[n++] = slot;
      std::push_heap(slots, slots + n);
      return;
    }
    ++places_dropped_;  // beyond the capacity: the last in the node table's order
    if (capacity == 0 || slot > slots[0]) return;
    std::pop_heap(slots, slots + n);
    slots[n - 1] = slot;
    std::push_heap(slots, slots + n);
  });
  std::sort(slots, slots + n);
  for (std::size_t k = 0; k < n; ++k) {  // add_place writes entry num_places_ <= k
    const sg::NodeRecord& rec = graph.node_at(slots[k]);
    const Eigen::Vector3d& p = graph.place_of(rec)->position_m;
    add_place(p);
    bypass_.add_place(rec.id, p);
    // Each edge once, from its lower id's end; an end outside the band is dropped by BypassGraph::finish.
    graph.for_each_neighbor(rec.id, [&](sg::NodeId other, const sg::EdgeRecord&) {
      if (other > rec.id && graph.place(other) != nullptr) bypass_.add_edge(rec.id, other);
    });
  }
}

void OnlineDoors::rasterize() {
  if (!begun_) return;
  wall_map_.slice(raster_, slice_z_m_, config_.slice_half_band_m, config_.min_wall_height_m, workspace_.wall());
}

bool OnlineDoors::inside_interior(const Eigen::Vector2d& p) const {
  const double margin = config_.mapped_radius_m;
  const Eigen::Vector2d hi = raster_.lo + Eigen::Vector2d(raster_.cols, raster_.rows) * raster_.cell_m;
  return p.x() >= raster_.lo.x() + margin && p.y() >= raster_.lo.y() + margin && p.x() < hi.x() - margin &&
         p.y() < hi.y() - margin;
}

PassResult OnlineDoors::detect() {
  PassResult result;
  result.slice_z_m = slice_z_m_;
  result.places = num_places_;
  result.places_dropped = places_dropped_;
  result.climbing = climbing_;
  if (!begun_) return result;
  begun_ = false;
  // The window's sight lines first: the detection works in the wall raster's buffer.
  if (sight_.set_window_slice(raster_, workspace_.wall(), slice_z_m_, config_))
    result.sight_structure_cells = sight_.structure_cells(0);
  std::size_t num = 0;
  if (!detect_doors_in_raster(&workspace_, raster_, num_places_, slice_z_m_, config_, found_,
                              capacities_.candidates, &num, &result.stats))
    return result;
  result.ran = true;
  // The doors of the interior on this storey meet the pass's doors there (DoorSet::update_window): found again,
  // new, or missed (dropped after online_misses_to_drop passes in a row). Near the window's edge the free space is
  // cut off by the window, so doors there wait for a window that holds them.
  const double same_storey = 0.5 * config_.storey_separation_m;
  std::size_t kept = 0;
  for (std::size_t k = 0; k < num; ++k)
    if (inside_interior(0.5 * (found_[k].a + found_[k].b))) found_[kept++] = found_[k];
  // A found door the window's places go round is a gap inside one space, not a door (as find_doors drops it).
  if (bypass_.places() > 0 && config_.bypass_max_m > 0.0) {
    bypass_.finish();
    std::size_t real = 0;
    for (std::size_t k = 0; k < kept; ++k) {
      const BypassGraph::Bypass b = bypass_.goes_round(found_[k], config_);
      result.bypass_searches_cut += b == BypassGraph::Bypass::kCut ? 1 : 0;
      if (b == BypassGraph::Bypass::kFound)
        ++result.bypassed;
      else
        found_[real++] = found_[k];
    }
    kept = real;
  }
  result.bypass_refused = bypass_.refused();
  result.found = kept;
  const DoorSet::WindowUpdate u = doors_.update_window(
      found_, kept,
      [&](const Door& d) { return std::abs(d.z_m - slice_z_m_) < same_storey && inside_interior(0.5 * (d.a + d.b)); },
      config_.online_match_m, config_.online_misses_to_drop);
  result.matched = u.matched;
  result.added = u.added;
  result.missed = u.missed;
  result.removed = u.removed;
  result.refused = u.refused;
  return result;
}

}  // namespace qsg::rooms

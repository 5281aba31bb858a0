#include "core/doors/door_detector.h"
#include "core/doors/door_params.h"
#include "core/doors/raster_ops.h"
#include "core/doors/wall_sight.h"

#include "core/memory/fixed_hash_map.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <utility>

namespace qsg::rooms {

namespace sg = scene_graph;

bool DoorConfig::validate(std::string* error) const {
  const auto fail = [&](const std::string& what) {
    if (error != nullptr) *error = "doors: " + what;
    return false;
  };
  // Each field within its declared range (door_params.cc); then the rules between fields and the capacities.
  if (std::string why = params::check(door_params_table(), *this); !why.empty()) return fail(why);
  if (!(min_wall_height_m <= 2.0 * slice_half_band_m))
    return fail("min_wall_height_m must be <= 2 x slice_half_band_m");
  if (!(max_width_m >= min_width_m)) return fail("need min_width_m <= max_width_m");
  if (max_cells == 0) return fail("max_cells must be positive");
  if (bypass_max_m > 0.0 && bypass_max_places == 0) return fail("bypass_max_places must be positive");
  return true;
}

memory::ArenaPlan DoorWorkspace::plan(const Capacities& c) {
  memory::ArenaPlan p;
  p.add_array<std::uint8_t>(c.cells);   // wall
  p.add_array<std::uint8_t>(c.cells);   // free
  p.add_array<std::uint8_t>(c.cells);   // axis
  p.add_array<std::uint8_t>(c.cells);   // walls dilated (the jambs' test)
  p.add_array<float>(c.cells);          // clearance
  p.add_array<std::uint32_t>(c.cells);  // stack
  p.add_array<std::uint32_t>(c.cells);  // list
  p.add_array<std::uint32_t>(c.places);
  p.add_array<double>(c.max_side);
  p.add_array<double>(c.max_side);
  p.add_array<std::int32_t>(c.max_side);
  p.add_array<double>(c.max_side + 1);
  p.add_array<Candidate>(c.candidates);
  return p;
}

bool DoorWorkspace::carve(memory::Arena& arena, const Capacities& c) {
  wall_ = arena.carve_array<std::uint8_t>(c.cells);
  free_ = arena.carve_array<std::uint8_t>(c.cells);
  axis_ = arena.carve_array<std::uint8_t>(c.cells);
  dilated_ = arena.carve_array<std::uint8_t>(c.cells);
  clearance_ = arena.carve_array<float>(c.cells);
  stack_ = arena.carve_array<std::uint32_t>(c.cells);
  list_ = arena.carve_array<std::uint32_t>(c.cells);
  place_cells_ = arena.carve_array<std::uint32_t>(c.places);
  line_f_ = arena.carve_array<double>(c.max_side);
  line_d_ = arena.carve_array<double>(c.max_side);
  line_v_ = arena.carve_array<std::int32_t>(c.max_side);
  line_z_ = arena.carve_array<double>(c.max_side + 1);
  candidates_ = arena.carve_array<Candidate>(c.candidates);
  const bool ok = wall_ != nullptr && free_ != nullptr && axis_ != nullptr && dilated_ != nullptr &&
                  clearance_ != nullptr &&
                  stack_ != nullptr && list_ != nullptr && (place_cells_ != nullptr || c.places == 0) && line_f_ != nullptr &&
                  line_d_ != nullptr && line_v_ != nullptr && line_z_ != nullptr &&
                  (candidates_ != nullptr || c.candidates == 0);
  capacities_ = ok ? c : Capacities{};
  door_params_table();  // built now, at start-up: validating each raster's config then allocates nothing
  return ok;
}

bool DoorWorkspace::allocate(const Capacities& c, std::string* error) {
  const memory::ArenaPlan p = plan(c);
  if (!own_.create("door_workspace", p, p.total_bytes(), error)) return false;
  if (!carve(own_, c) || (own_.align_to_plan_boundary(), !own_.seal())) {
    if (error != nullptr) *error = "doors: the workspace's carve does not match its plan";
    return false;
  }
  return true;
}

namespace {

constexpr double kFar = 1e20;  // "no wall yet" in the squared distance transform

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Proper intersection of segments pq and ab in the plane.
bool segments_cross(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                    const Eigen::Vector2d& b) {
  const double d1 = cross2(b - a, p - a), d2 = cross2(b - a, q - a);
  const double d3 = cross2(q - p, a - p), d4 = cross2(q - p, b - p);
  return ((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0)) && d1 != 0 && d2 != 0 && d3 != 0 && d4 != 0;
}

// One detection's view of the workspace: its buffers and the raster's shape, and the steps of the pass.
struct RasterPass {
  const DoorRaster& raster;
  const DoorConfig& config;
  int cols = 0, rows = 0;
  std::size_t n = 0;
  std::uint8_t* wall = nullptr;
  std::uint8_t* free = nullptr;
  std::uint8_t* axis = nullptr;
  std::uint8_t* dilated = nullptr;
  float* clearance = nullptr;
  std::uint32_t* stack = nullptr;

  std::size_t at(int c, int r) const { return static_cast<std::size_t>(r) * cols + c; }

  // Walls dilated by one cell (into `axis` for now), so that the free space does not leak between diagonal wall
  // cells. `free` is the row scratch (mapped_free_space fills it next).
  void dilate_walls() { raster::dilate3x3(wall, cols, rows, free, axis); }

  // Mapped free space: the non-wall cells within mapped_radius_m of a place that a place reaches without crossing a
  // wall (not the space behind an outer wall that the radius alone would take in). A one-cell frame stays non-free,
  // so the thinning and the distance transform see a closed border. Expects the dilated walls in `axis`; leaves
  // them in `dilated`. Returns the free cells; the wall cells into *wall_cells.
  std::size_t mapped_free_space(const std::uint32_t* place_cells, std::size_t num_place_cells,
                                std::size_t* wall_cells) {
    std::fill(free, free + n, std::uint8_t{0});
    const int radius = std::max(1, static_cast<int>(std::lround(config.mapped_radius_m / config.cell_m)));
    for (std::size_t k = 0; k < num_place_cells; ++k) {
      if (place_cells[k] >= n) continue;
      const int pc = static_cast<int>(place_cells[k] % static_cast<std::uint32_t>(cols));
      const int pr = static_cast<int>(place_cells[k] / static_cast<std::uint32_t>(cols));
      for (int dr = -radius; dr <= radius; ++dr) {
        const int r = pr + dr;
        if (r < 1 || r >= rows - 1) continue;
        const int half = static_cast<int>(std::floor(std::sqrt(static_cast<double>(radius * radius - dr * dr))));
        const int c0 = std::max(1, pc - half), c1 = std::min(cols - 2, pc + half);
        if (c0 <= c1) std::fill(free + at(c0, r), free + at(c1, r) + 1, std::uint8_t{1});
      }
    }
    *wall_cells = 0;
    for (std::size_t i = 0; i < n; ++i) {
      *wall_cells += axis[i];
      if (axis[i] != 0) free[i] = 0;
    }
    std::copy(axis, axis + n, dilated);
    // Keep what the places reach (4-connected); `axis` marks the reached cells.
    std::fill(axis, axis + n, std::uint8_t{0});
    std::size_t top = 0;
    for (std::size_t k = 0; k < num_place_cells; ++k) {
      const std::uint32_t i = place_cells[k];
      if (i >= n || free[i] == 0 || axis[i] != 0) continue;
      axis[i] = 1;
      stack[top++] = i;
      while (top > 0) {
        const std::uint32_t j = stack[--top];
        const std::uint32_t next[4] = {j - 1, j + 1, j - static_cast<std::uint32_t>(cols),
                                       j + static_cast<std::uint32_t>(cols)};
        for (const std::uint32_t q : next)  // the frame is never free, so neighbours of a free cell are inside
          if (free[q] != 0 && axis[q] == 0) {
            axis[q] = 1;
            stack[top++] = q;
          }
      }
    }
    std::size_t free_cells = 0;
    for (std::size_t i = 0; i < n; ++i) {
      free[i] = axis[i];
      free_cells += free[i];
    }
    return free_cells;
  }

  // Clearance of every free cell (metres): the exact Euclidean distance to the nearest non-free cell, columns then
  // rows.
  void clearance_transform(double* f, double* d, std::int32_t* v, double* z) {
    for (int c = 0; c < cols; ++c) {
      for (int r = 0; r < rows; ++r) f[r] = free[at(c, r)] != 0 ? kFar : 0.0;
      raster::distance_1d(f, rows, d, v, z);
      for (int r = 0; r < rows; ++r) clearance[at(c, r)] = static_cast<float>(std::min(d[r], kFar));
    }
    for (int r = 0; r < rows; ++r) {
      float* row = clearance + at(0, r);
      for (int c = 0; c < cols; ++c) f[c] = row[c];
      raster::distance_1d(f, cols, d, v, z);
      for (int c = 0; c < cols; ++c) row[c] = static_cast<float>(std::sqrt(d[c]) * config.cell_m);
    }
  }

  // The first non-free cell from p along direction u (unit), within max_m; false when none. *on_wall: that cell is
  // (dilated) wall, not the edge of the mapped space or of the raster.
  bool ray(const Eigen::Vector2d& p, const Eigen::Vector2d& u, double max_m, Eigen::Vector2d* hit,
           bool* on_wall) const {
    // Samples every half cell, t = k x step, walked in cell units from the raster's corner (no division per sample:
    // this loop is most of a pass).
    const double step = 0.5 * config.cell_m;
    const double x0 = (p.x() - raster.lo.x()) / raster.cell_m, y0 = (p.y() - raster.lo.y()) / raster.cell_m;
    const double dx = 0.5 * u.x(), dy = 0.5 * u.y();
    const int steps = static_cast<int>(std::floor(max_m / step + 1e-9));
    for (int k = 1; k <= steps; ++k) {
      const double fx = x0 + k * dx, fy = y0 + k * dy;
      if (!(fx >= 0.0 && fy >= 0.0 && fx < cols && fy < rows)) {
        *hit = p + (k * step) * u;
        *on_wall = false;
        return true;
      }
      const std::size_t i = at(static_cast<int>(fx), static_cast<int>(fy));
      if (free[i] == 0) {
        *hit = p + (k * step) * u;
        *on_wall = dilated[i] != 0;
        return true;
      }
    }
    return false;
  }

  double clearance_at(const Eigen::Vector2d& q) const {
    int c, r;
    return raster.cell_of(q.x(), q.y(), &c, &r) ? static_cast<double>(clearance[at(c, r)]) : 0.0;
  }

  // A local minimum of clearance among its axis neighbours.
  bool clearance_minimum(int c, int r) const {
    const double dc = clearance[at(c, r)];
    for (int dr = -1; dr <= 1; ++dr)
      for (int dq = -1; dq <= 1; ++dq)
        if ((dr != 0 || dq != 0) && axis[at(c + dq, r + dr)] != 0 && clearance[at(c + dq, r + dr)] < dc)
          return false;
    return true;
  }

  // The shortest wall-to-wall line through p over the given directions: its ends are the jambs. A line that ends at
  // the edge of the mapped space (space the robot has not seen yet) is no door: a half-mapped room would show one at
  // every frontier, and the next pass, with more mapped, would take it back. Returns its length (infinite: none); of
  // equally short lines, the one of the lowest direction index. Direction `first` is tried first (the one towards
  // the nearest wall: a short line early cuts every later ray short); a ray stops one cell past the best line so
  // far, so a line as short as the best is still seen and the result does not depend on the order.
  double shortest_jamb_line(const Eigen::Vector2d& p, const Eigen::Vector2d* directions, int num_directions,
                            int first, Eigen::Vector2d* best_a, Eigen::Vector2d* best_b) const {
    double best = std::numeric_limits<double>::infinity();
    int best_k = num_directions;
    *best_a = p;
    *best_b = p;
    for (int step = 0; step < num_directions; ++step) {
      const int k = step == 0 ? first : (step <= first ? step - 1 : step);
      const Eigen::Vector2d& u = directions[k];
      Eigen::Vector2d a, b;
      bool wall_a = false, wall_b = false;
      const double reach = std::min(config.max_width_m, best + config.cell_m);
      if (!ray(p, u, reach, &a, &wall_a) || !wall_a) continue;
      if (!ray(p, -u, std::min(config.max_width_m, best + config.cell_m - (a - p).norm()), &b, &wall_b) || !wall_b)
        continue;
      const double len = (a - b).norm();
      if (len < best || (len == best && k < best_k)) {
        best = len;
        best_k = k;
        *best_a = a;
        *best_b = b;
      }
    }
    return best;
  }

  // The index of the direction (over half a turn, num_directions of them) nearest the clearance's steepest descent at
  // axis cell (c, r): across the passage. 0 where the clearance is flat.
  int towards_wall(int c, int r, int num_directions) const {
    const double gx = clearance[at(c + 1, r)] - clearance[at(c - 1, r)];
    const double gy = clearance[at(c, r + 1)] - clearance[at(c, r - 1)];
    if (gx == 0.0 && gy == 0.0) return 0;
    double th = std::atan2(gy, gx);
    if (th < 0.0) th += M_PI;
    const int k = static_cast<int>(std::lround(th / M_PI * num_directions));
    return k >= num_directions ? k - num_directions : k;
  }

  // Whether any cell near (c, r) is clear enough for the rise test below to pass in some direction: the test reads
  // the cells holding points within rise_reach_m of the cell's centre, all inside this square. A uniform corridor
  // fails it before its 72 rays are cast (a necessary condition: the outcome is the same).
  bool rise_possible(int c, int r, double dc) const {
    const double need = dc + config.min_rise_m;
    const int half = static_cast<int>(std::ceil(config.rise_reach_m / config.cell_m)) + 1;
    const int c0 = std::max(0, c - half), c1 = std::min(cols - 1, c + half);
    for (int rr = std::max(0, r - half); rr <= std::min(rows - 1, r + half); ++rr) {
      const float* row = clearance + at(0, rr);
      for (int cc = c0; cc <= c1; ++cc)
        if (static_cast<double>(row[cc]) >= need) return true;
    }
    return false;
  }

  // The door through axis cell (c, r), if it is one: a clearance minimum within the width range, a centred
  // jamb-to-jamb line, the clearance rising on both sides of it.
  bool door_at(int c, int r, const Eigen::Vector2d* directions, int num_directions, double slice_z_m,
               DoorWorkspace::Candidate* cand) const {
    if (axis[at(c, r)] == 0) return false;
    const double dc = clearance[at(c, r)];
    if (dc < 0.5 * config.min_width_m || dc > 0.5 * config.max_width_m || !clearance_minimum(c, r)) return false;
    if (!rise_possible(c, r, dc)) return false;
    const Eigen::Vector2d p = raster.centre_of(c, r);
    Eigen::Vector2d best_a, best_b;
    const double best =
        shortest_jamb_line(p, directions, num_directions, towards_wall(c, r, num_directions), &best_a, &best_b);
    if (!(best >= config.min_width_m && best <= config.max_width_m + config.cell_m)) return false;
    const double da = (best_a - p).norm(), db = (best_b - p).norm();
    if (std::abs(da - db) > config.max_off_centre * (da + db)) return false;
    const Eigen::Vector2d u = (best_b - best_a).normalized();
    const Eigen::Vector2d nrm(-u.y(), u.x());
    for (const double side : {1.0, -1.0}) {
      double peak = 0.0;
      for (double t = config.cell_m; t <= config.rise_reach_m; t += config.cell_m)
        peak = std::max(peak, clearance_at(p + side * t * nrm));
      if (peak < dc + config.min_rise_m) return false;
    }
    // The jambs' wall surface: the rays stopped at the walls' one-cell dilation.
    cand->door.a = best_a - u * config.cell_m;
    cand->door.b = best_b + u * config.cell_m;
    cand->door.z_m = slice_z_m;
    cand->half_width = dc;
    return true;
  }
};

// Of candidates closer than suppression_m (line midpoints), the narrowest stays (ties: raster order). Returns how
// many are kept, at the front of the array.
std::size_t suppress_neighbours(DoorWorkspace::Candidate* candidates, std::size_t num_candidates,
                                double suppression_m) {
  std::sort(candidates, candidates + num_candidates,
            [](const DoorWorkspace::Candidate& x, const DoorWorkspace::Candidate& y) {
              return x.half_width < y.half_width;
            });
  std::size_t kept = 0;
  for (std::size_t k = 0; k < num_candidates; ++k) {
    const DoorWorkspace::Candidate& cand = candidates[k];
    const Eigen::Vector2d mid = 0.5 * (cand.door.a + cand.door.b);
    bool near = false;
    // Earlier (narrower) candidates that were kept sit, in order, at the front of the array.
    for (std::size_t j = 0; j < kept && !near; ++j)
      near = (0.5 * (candidates[j].door.a + candidates[j].door.b) - mid).norm() < suppression_m;
    if (!near) candidates[kept++] = cand;
  }
  return kept;
}

}  // namespace

bool detect_doors_in_raster(DoorWorkspace* ws, const DoorRaster& raster, std::size_t num_place_cells,
                            double slice_z_m, const DoorConfig& config, Door* out, std::size_t out_capacity,
                            std::size_t* num_out, DoorStats* stats) {
  DoorStats local;
  DoorStats& st = stats != nullptr ? *stats : local;
  st = DoorStats{};
  if (num_out != nullptr) *num_out = 0;
  if (ws == nullptr || num_out == nullptr || (out == nullptr && out_capacity > 0)) return false;
  if (!config.validate(nullptr) || !std::isfinite(slice_z_m) || std::abs(raster.cell_m - config.cell_m) > 1e-9)
    return false;
  const DoorWorkspace::Capacities& cap = ws->capacities_;
  const int cols = raster.cols, rows = raster.rows;
  if (cols < 3 || rows < 3 || raster.cells() > cap.cells || static_cast<std::size_t>(cols) > cap.max_side ||
      static_cast<std::size_t>(rows) > cap.max_side || num_place_cells > cap.places)
    return false;
  st.cols = static_cast<std::size_t>(cols);
  st.rows = static_cast<std::size_t>(rows);
  RasterPass pass{raster, config, cols, rows, raster.cells(), ws->wall_, ws->free_, ws->axis_, ws->dilated_,
                  ws->clearance_, ws->stack_};
  pass.dilate_walls();
  st.free_cells = pass.mapped_free_space(ws->place_cells_, num_place_cells, &st.wall_cells);
  if (st.free_cells == 0) return true;
  pass.clearance_transform(ws->line_f_, ws->line_d_, ws->line_v_, ws->line_z_);
  std::copy(pass.free, pass.free + pass.n, pass.axis);
  raster::thin(pass.axis, cols, rows, ws->list_, ws->stack_, ws->wall_);  // the wall raster is not needed any more
  st.axis_cells = 0;
  for (std::size_t i = 0; i < pass.n; ++i) st.axis_cells += pass.axis[i];

  constexpr int kAngles = 36;
  Eigen::Vector2d directions[kAngles];  // the line directions tried, over half a turn
  for (int k = 0; k < kAngles; ++k) {
    const double th = M_PI * k / kAngles;
    directions[k] = Eigen::Vector2d(std::cos(th), std::sin(th));
  }
  DoorWorkspace::Candidate* candidates = ws->candidates_;
  std::size_t num_candidates = 0;
  for (int r = 1; r + 1 < rows; ++r)
    for (int c = 1; c + 1 < cols; ++c) {
      DoorWorkspace::Candidate cand;
      if (!pass.door_at(c, r, directions, kAngles, slice_z_m, &cand)) continue;
      if (num_candidates == cap.candidates) {
        ++st.candidates_dropped;
        continue;
      }
      candidates[num_candidates++] = cand;
    }
  st.candidates = num_candidates + st.candidates_dropped;
  const std::size_t kept = suppress_neighbours(candidates, num_candidates, config.suppression_m);
  const std::size_t written = std::min(kept, out_capacity);
  for (std::size_t k = 0; k < written; ++k) out[k] = candidates[k].door;
  st.doors_dropped = kept - written;
  *num_out = written;
  return true;
}

bool detect_doors(const std::vector<Eigen::Vector3f>& surface, const std::vector<Eigen::Vector3d>& places,
                  double slice_z_m, const DoorConfig& config, std::vector<Door>* doors, DoorStats* stats,
                  std::string* error, WallSight* sight) {
  if (!config.validate(error)) return false;
  if (doors == nullptr) {
    if (error != nullptr) *error = "doors: no output";
    return false;
  }
  doors->clear();
  DoorStats local;
  DoorStats& st = stats != nullptr ? *stats : local;
  st = DoorStats{};
  if (!std::isfinite(slice_z_m)) {
    if (error != nullptr) *error = "doors: the slice height is not finite";
    return false;
  }
  // The raster spans the mapped space: the places near the slice, widened by the mapped radius. Surface outside it
  // (a stray vertex far away) is ignored; no surface in the band means no walls and no doors.
  const auto in_band = [&](const Eigen::Vector3f& v) {
    return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()) &&
           std::abs(v.z() - slice_z_m) <= config.slice_half_band_m;
  };
  const auto place_in_band = [&](const Eigen::Vector3d& p) {
    return p.allFinite() && std::abs(p.z() - slice_z_m) <= config.place_band_m;
  };
  if (std::none_of(surface.begin(), surface.end(), in_band)) return true;
  Eigen::Vector2d lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  std::size_t num_places = 0;
  for (const Eigen::Vector3d& p : places)
    if (place_in_band(p)) {
      lo = lo.cwiseMin(p.head<2>());
      hi = hi.cwiseMax(p.head<2>());
      ++num_places;
    }
  if (!(lo.x() <= hi.x())) return true;  // no mapped space near the slice
  const double margin = config.mapped_radius_m + 2.0 * config.cell_m;
  lo -= Eigen::Vector2d::Constant(margin);
  hi += Eigen::Vector2d::Constant(margin);
  const double cols_d = std::ceil((hi.x() - lo.x()) / config.cell_m);
  const double rows_d = std::ceil((hi.y() - lo.y()) / config.cell_m);
  if (!(cols_d * rows_d <= static_cast<double>(config.max_cells))) {
    if (error != nullptr) *error = "doors: the slice's raster exceeds max_cells";
    return false;
  }
  DoorRaster raster;
  raster.lo = lo;
  raster.cols = static_cast<int>(cols_d);
  raster.rows = static_cast<int>(rows_d);
  raster.cell_m = config.cell_m;
  DoorWorkspace ws;
  DoorWorkspace::Capacities cap;
  cap.cells = raster.cells();
  cap.max_side = static_cast<std::size_t>(std::max(raster.cols, raster.rows));
  cap.places = num_places;
  cap.candidates = std::min<std::size_t>(cap.cells, std::size_t{1} << 16);
  if (!ws.allocate(cap, error)) return false;

  // Walls: cells whose surface spans min_wall_height_m within the band.
  std::vector<float> zmin(raster.cells(), std::numeric_limits<float>::infinity());
  std::vector<float> zmax(raster.cells(), -std::numeric_limits<float>::infinity());
  for (const Eigen::Vector3f& v : surface) {
    int c, r;
    if (!in_band(v) || !raster.cell_of(v.x(), v.y(), &c, &r)) continue;
    const std::size_t i = static_cast<std::size_t>(r) * raster.cols + c;
    zmin[i] = std::min(zmin[i], v.z());
    zmax[i] = std::max(zmax[i], v.z());
  }
  std::uint8_t* wall = ws.wall();
  for (std::size_t i = 0; i < raster.cells(); ++i) wall[i] = zmax[i] - zmin[i] >= config.min_wall_height_m ? 1 : 0;
  if (sight != nullptr && !sight->add_slice(raster, wall, slice_z_m, config, error)) return false;
  std::size_t k = 0;
  for (const Eigen::Vector3d& p : places) {
    int c, r;
    if (place_in_band(p) && raster.cell_of(p.x(), p.y(), &c, &r))
      ws.place_cells()[k++] = static_cast<std::uint32_t>(static_cast<std::size_t>(r) * raster.cols + c);
  }
  std::vector<Door> found(cap.candidates);  // every kept candidate fits: no door is dropped here
  std::size_t num = 0;
  if (!detect_doors_in_raster(&ws, raster, k, slice_z_m, config, found.data(), found.size(), &num, &st)) {
    if (error != nullptr) *error = "doors: the slice's detection failed";
    return false;
  }
  found.resize(num);
  *doors = std::move(found);
  return true;
}

std::vector<double> door_slice_heights(const std::vector<double>& robot_z_m, const DoorConfig& config) {
  std::vector<double> z;
  for (const double v : robot_z_m)
    if (std::isfinite(v)) z.push_back(v);
  if (z.empty() || !(config.storey_bin_m > 0.0)) return {};
  const auto [lo_it, hi_it] = std::minmax_element(z.begin(), z.end());
  const double lo = *lo_it;
  const std::size_t bins = static_cast<std::size_t>(std::floor((*hi_it - lo) / config.storey_bin_m)) + 1;
  if (bins > 100000) return {};  // heights spread over kilometres: not a robot walking storeys
  std::vector<std::size_t> count(bins, 0);
  for (const double v : z) ++count[static_cast<std::size_t>(std::floor((v - lo) / config.storey_bin_m))];
  // Modes: bins holding at least the minimum share that no neighbour exceeds; then, strongest first, those not
  // within storey_separation_m of a stronger one.
  std::vector<std::size_t> modes;
  const double min_count = config.storey_min_share * static_cast<double>(z.size());
  for (std::size_t b = 0; b < bins; ++b) {
    const bool peak = (b == 0 || count[b - 1] <= count[b]) && (b + 1 == bins || count[b + 1] < count[b]);
    if (peak && count[b] > 0 && static_cast<double>(count[b]) >= min_count) modes.push_back(b);
  }
  std::stable_sort(modes.begin(), modes.end(), [&](std::size_t a, std::size_t b) { return count[a] > count[b]; });
  std::vector<double> storeys;
  for (const std::size_t b : modes) {
    double sum = 0.0;
    std::size_t n = 0;
    for (const double v : z)
      if (static_cast<std::size_t>(std::floor((v - lo) / config.storey_bin_m)) == b) {
        sum += v;
        ++n;
      }
    const double height = sum / static_cast<double>(n);
    bool near = false;
    for (const double s : storeys) near = near || std::abs(s - height) < config.storey_separation_m;
    if (!near) storeys.push_back(height);
  }
  for (double& s : storeys) s += config.slice_above_robot_m;
  std::sort(storeys.begin(), storeys.end());
  return storeys;
}

bool find_doors(const std::vector<Eigen::Vector3f>& surface, const sg::SceneGraph& graph, const DoorConfig& config,
                std::vector<Door>* doors, DoorStats* stats, std::string* error, WallSight* sight) {
  if (!config.validate(error)) return false;
  if (doors == nullptr) {
    if (error != nullptr) *error = "doors: no output";
    return false;
  }
  doors->clear();
  if (sight != nullptr) sight->clear();
  std::vector<Eigen::Vector3d> places;
  std::vector<double> robot_z;
  graph.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind == sg::NodeKind::kPlace) places.push_back(graph.place(n.id)->position_m);
    if (n.kind == sg::NodeKind::kAgent) robot_z.push_back(graph.agent(n.id)->position_m.z());
  });
  DoorStats total;
  for (const double z : door_slice_heights(robot_z, config)) {
    std::vector<Door> found;
    DoorStats st;
    if (!detect_doors(surface, places, z, config, &found, &st, error, sight)) return false;
    doors->insert(doors->end(), found.begin(), found.end());
    ++total.slices;
    total.cols += st.cols;
    total.rows += st.rows;
    total.wall_cells += st.wall_cells;
    total.free_cells += st.free_cells;
    total.axis_cells += st.axis_cells;
    total.candidates += st.candidates;
  }
  drop_bypassed_doors(doors, config, graph, &total);
  if (stats != nullptr) *stats = total;
  return true;
}

bool door_closes_edge(const Door& d, const DoorConfig& config, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  if (!a.allFinite() || !b.allFinite()) return false;
  if (std::abs(a.z() - d.z_m) > config.cut_max_dz_m || std::abs(b.z() - d.z_m) > config.cut_max_dz_m) return false;
  const Eigen::Vector2d u = (d.b - d.a).normalized() * config.cut_extension_m;
  return segments_cross(a.head<2>(), b.head<2>(), d.a - u, d.b + u);
}

memory::ArenaPlan BypassGraph::plan(const Capacities& c) {
  memory::ArenaPlan p;
  p.add_array<sg::NodeId>(c.places);
  p.add_array<Eigen::Vector3d>(c.places);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<Eigen::Vector3d>(c.places);
  p.add_array<sg::NodeId>(2 * c.edges);
  p.add_array<Edge>(c.edges);
  p.add_array<std::uint32_t>(c.places + 1);
  p.add_array<std::uint32_t>(2 * c.edges);
  p.add_array<float>(c.places);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<HeapItem>(c.edges);
  return p;
}

bool BypassGraph::carve(memory::Arena& arena, const Capacities& c) {
  capacities_ = c;
  ids_ = arena.carve_array<sg::NodeId>(c.places);
  position_ = arena.carve_array<Eigen::Vector3d>(c.places);
  order_ = arena.carve_array<std::uint32_t>(c.places);
  scratch_ = arena.carve_array<Eigen::Vector3d>(c.places);
  edge_ids_ = arena.carve_array<sg::NodeId>(2 * c.edges);
  edges_ = arena.carve_array<Edge>(c.edges);
  offset_ = arena.carve_array<std::uint32_t>(c.places + 1);
  adjacency_ = arena.carve_array<std::uint32_t>(2 * c.edges);
  dist_ = arena.carve_array<float>(c.places);
  touched_ = arena.carve_array<std::uint32_t>(c.places);
  heap_ = arena.carve_array<HeapItem>(c.edges);
  const bool ok = offset_ != nullptr &&
                  (c.places == 0 || (ids_ && position_ && order_ && scratch_ && dist_ && touched_)) &&
                  (c.edges == 0 || (edge_ids_ && edges_ && adjacency_ && heap_));
  if (ok) std::fill(dist_, dist_ + c.places, std::numeric_limits<float>::infinity());
  clear();
  return ok;
}

bool BypassGraph::allocate(const Capacities& c, std::string* error) {
  const memory::ArenaPlan p = plan(c);
  if (!own_.create("door_bypass", p, p.total_bytes(), error)) return false;
  if (!carve(own_, c) || (own_.align_to_plan_boundary(), !own_.seal())) {
    if (error != nullptr) *error = "doors: the bypass graph's carve does not match its plan";
    return false;
  }
  return true;
}

void BypassGraph::clear() {
  num_places_ = num_edges_ = num_edge_ids_ = refused_ = 0;
  finished_ = false;
}

bool BypassGraph::add_place(sg::NodeId id, const Eigen::Vector3d& p) {
  if (finished_ || num_places_ == capacities_.places || !p.allFinite()) {
    ++refused_;
    return false;
  }
  ids_[num_places_] = id;
  position_[num_places_++] = p;
  return true;
}

bool BypassGraph::add_edge(sg::NodeId a, sg::NodeId b) {
  if (finished_ || num_edge_ids_ / 2 == capacities_.edges || a == b) {
    ++refused_;
    return false;
  }
  edge_ids_[num_edge_ids_++] = a;
  edge_ids_[num_edge_ids_++] = b;
  return true;
}

std::uint32_t BypassGraph::index_of(sg::NodeId id) const {
  const sg::NodeId* it = std::lower_bound(ids_, ids_ + num_places_, id);
  return it != ids_ + num_places_ && *it == id ? static_cast<std::uint32_t>(it - ids_) : kNoPlace;
}

void BypassGraph::finish() {
  if (finished_) return;
  finished_ = true;
  // Places in the order of their ids (a duplicate id keeps its first position).
  for (std::uint32_t i = 0; i < num_places_; ++i) order_[i] = i;
  // std::sort with the index as tie-break (std::stable_sort may allocate a buffer).
  std::sort(order_, order_ + num_places_,
            [&](std::uint32_t x, std::uint32_t y) { return ids_[x] != ids_[y] ? ids_[x] < ids_[y] : x < y; });
  for (std::size_t i = 0; i < num_places_; ++i) scratch_[i] = position_[order_[i]];
  std::copy(scratch_, scratch_ + num_places_, position_);
  std::sort(ids_, ids_ + num_places_);
  std::size_t unique = 0;
  for (std::size_t i = 0; i < num_places_; ++i)
    if (unique == 0 || ids_[i] != ids_[unique - 1]) {
      ids_[unique] = ids_[i];
      position_[unique++] = position_[i];
    }
  num_places_ = unique;
  num_edges_ = 0;
  for (std::size_t k = 0; k + 1 < num_edge_ids_; k += 2) {
    const std::uint32_t a = index_of(edge_ids_[k]), b = index_of(edge_ids_[k + 1]);
    if (a != kNoPlace && b != kNoPlace && a != b) edges_[num_edges_++] = Edge{a, b};
  }
  std::fill(offset_, offset_ + num_places_ + 1, 0u);
  for (std::size_t e = 0; e < num_edges_; ++e) {
    ++offset_[edges_[e].a + 1];
    ++offset_[edges_[e].b + 1];
  }
  for (std::size_t i = 0; i < num_places_; ++i) offset_[i + 1] += offset_[i];
  std::copy(offset_, offset_ + num_places_, touched_);  // fill cursors
  for (std::size_t e = 0; e < num_edges_; ++e) {
    adjacency_[touched_[edges_[e].a]++] = static_cast<std::uint32_t>(e);
    adjacency_[touched_[edges_[e].b]++] = static_cast<std::uint32_t>(e);
  }
}

bool BypassGraph::search(const Door& door, const DoorConfig& config, std::uint32_t from, std::uint32_t to,
                         bool* cut) {
  const auto less = [](const HeapItem& x, const HeapItem& y) { return x.d > y.d; };  // a min-heap
  const std::size_t heap_capacity = capacities_.edges;
  if (heap_capacity == 0) return false;
  std::size_t heap_size = 0, touched = 0, settled = 0;
  bool joined = false;
  dist_[from] = 0.0f;
  touched_[touched++] = from;
  heap_[heap_size++] = HeapItem{0.0f, from};
  while (heap_size > 0) {
    std::pop_heap(heap_, heap_ + heap_size, less);
    const HeapItem top = heap_[--heap_size];
    if (top.node == to) {
      joined = true;
      break;
    }
    if (top.d > dist_[top.node]) continue;
    if (++settled > config.bypass_max_places) {
      *cut = true;
      break;
    }
    const Eigen::Vector3d& pu = position_[top.node];
    const double du = dist_[top.node];
    for (std::uint32_t k = offset_[top.node]; k < offset_[top.node + 1]; ++k) {
      const Edge& e = edges_[adjacency_[k]];
      const std::uint32_t v = e.a == top.node ? e.b : e.a;
      const double step = (position_[v] - pu).norm();
      if (!(step <= config.bypass_max_edge_m)) continue;
      const float nd = static_cast<float>(du + step);
      if (!(nd <= config.bypass_max_m) || nd >= dist_[v]) continue;
      if (door_closes_edge(door, config, pu, position_[v])) continue;
      if (heap_size == heap_capacity) {
        *cut = true;
        continue;
      }
      if (dist_[v] == std::numeric_limits<float>::infinity()) touched_[touched++] = v;
      dist_[v] = nd;
      heap_[heap_size++] = HeapItem{nd, v};
      std::push_heap(heap_, heap_ + heap_size, less);
    }
  }
  for (std::size_t i = 0; i < touched; ++i) dist_[touched_[i]] = std::numeric_limits<float>::infinity();
  return joined;
}

BypassGraph::Bypass BypassGraph::goes_round(const Door& door, const DoorConfig& config) {
  if (!finished_ || !(config.bypass_max_m > 0.0) || !door.a.allFinite() || !door.b.allFinite() ||
      !std::isfinite(door.z_m))
    return Bypass::kNone;
  // The search's line: the door's, lengthened by bypass_extension_m (door_closes_edge reads cut_extension_m).
  DoorConfig round = config;
  round.cut_extension_m = config.bypass_extension_m;
  const Eigen::Vector2d lo = door.a.cwiseMin(door.b), hi = door.a.cwiseMax(door.b);
  const double pad = config.cut_extension_m;
  bool any_cut = false;
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const Eigen::Vector3d& pa = position_[edges_[k].a];
    const Eigen::Vector3d& pb = position_[edges_[k].b];
    // Cheap reject: the edge's plan box misses the (lengthened) door line's box.
    if (std::max(pa.x(), pb.x()) < lo.x() - pad || std::min(pa.x(), pb.x()) > hi.x() + pad ||
        std::max(pa.y(), pb.y()) < lo.y() - pad || std::min(pa.y(), pb.y()) > hi.y() + pad)
      continue;
    if (!door_closes_edge(door, config, pa, pb)) continue;
    bool cut = false;
    if (search(door, round, edges_[k].a, edges_[k].b, &cut)) return Bypass::kFound;
    any_cut = any_cut || cut;
  }
  return any_cut ? Bypass::kCut : Bypass::kNone;
}

std::size_t drop_bypassed_doors(std::vector<Door>* doors, const DoorConfig& config, const sg::SceneGraph& graph,
                                DoorStats* stats) {
  if (doors == nullptr || doors->empty() || !(config.bypass_max_m > 0.0)) return 0;
  BypassGraph::Capacities c;
  graph.for_each_node([&](const sg::NodeRecord& n) { c.places += n.kind == sg::NodeKind::kPlace ? 1 : 0; });
  graph.for_each_edge([&](const sg::EdgeRecord& e) {
    c.edges += graph.place(e.source) != nullptr && graph.place(e.target) != nullptr ? 1 : 0;
  });
  BypassGraph g;
  std::string error;
  if (!g.allocate(c, &error)) {  // counted and logged; the doors stay as found
    if (stats != nullptr) stats->bypass_unchecked += doors->size();
    std::fprintf(stderr, "doors: bypass check skipped, %s\n", error.c_str());
    return 0;
  }
  graph.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind == sg::NodeKind::kPlace) g.add_place(n.id, graph.place(n.id)->position_m);
  });
  graph.for_each_edge([&](const sg::EdgeRecord& e) {
    if (graph.place(e.source) != nullptr && graph.place(e.target) != nullptr) g.add_edge(e.source, e.target);
  });
  g.finish();
  std::size_t dropped = 0, cut = 0, kept = 0;
  for (std::size_t i = 0; i < doors->size(); ++i) {
    const BypassGraph::Bypass b = g.goes_round((*doors)[i], config);
    cut += b == BypassGraph::Bypass::kCut ? 1 : 0;
    if (b == BypassGraph::Bypass::kFound)
      ++dropped;
    else
      (*doors)[kept++] = (*doors)[i];
  }
  doors->resize(kept);
  if (stats != nullptr) {
    stats->bypassed += dropped;
    stats->bypass_searches_cut += cut;
  }
  return dropped;
}

std::size_t close_place_edges(sg::SceneGraph* graph,
                              const std::function<bool(const Eigen::Vector3d&, const Eigen::Vector3d&)>& closes) {
  if (graph == nullptr) return 0;
  std::vector<std::pair<sg::NodeId, sg::NodeId>> cut;
  graph->for_each_edge([&](const sg::EdgeRecord& e) {
    const sg::PlaceAttributes* a = graph->place(e.source);
    const sg::PlaceAttributes* b = graph->place(e.target);
    if (a == nullptr || b == nullptr || (e.info.weighted && e.info.weight <= 0.0)) return;
    if (closes(a->position_m, b->position_m)) cut.emplace_back(e.source, e.target);
  });
  for (const auto& [s, t] : cut) {
    sg::EdgeAttributes* info = graph->edge_info(s, t);
    info->weighted = true;
    info->weight = 0.0;
  }
  return cut.size();
}

std::size_t cut_place_edges(const std::vector<Door>& doors, const DoorConfig& config, sg::SceneGraph* graph) {
  if (doors.empty()) return 0;
  return close_place_edges(graph, [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::any_of(doors.begin(), doors.end(), [&](const Door& d) { return door_closes_edge(d, config, a, b); });
  });
}

// DoorSet: doors bucketed by the grid cell of their midpoint (a hash of the cell into a power-of-two table).
std::size_t DoorSet::buckets_for(std::size_t max_doors) {
  std::size_t b = 16;
  while (b < 2 * max_doors) b <<= 1;
  return b;
}

memory::ArenaPlan DoorSet::plan(std::size_t max_doors) {
  memory::ArenaPlan p;
  p.add_array<Door>(max_doors);
  p.add_array<std::uint8_t>(max_doors);  // misses
  p.add_array<std::uint8_t>(max_doors);  // flags
  p.add_array<std::uint32_t>(max_doors);
  p.add_array<std::uint32_t>(buckets_for(max_doors));
  return p;
}

bool DoorSet::carve(memory::Arena& arena, std::size_t max_doors, const DoorConfig& config) {
  config_ = config;
  // A door's line reaches at most half its width plus the extension from its midpoint; one grid cell of that.
  grid_m_ = std::max(0.5, 0.5 * (config.max_width_m + 2.0 * config.cell_m) + config.cut_extension_m);
  doors_ = arena.carve_array<Door>(max_doors);
  misses_ = arena.carve_array<std::uint8_t>(max_doors);
  flags_ = arena.carve_array<std::uint8_t>(max_doors);
  next_ = arena.carve_array<std::uint32_t>(max_doors);
  buckets_ = buckets_for(max_doors);
  head_ = arena.carve_array<std::uint32_t>(buckets_);
  const bool ok = (max_doors == 0 || (doors_ != nullptr && misses_ != nullptr && flags_ != nullptr &&
                                      next_ != nullptr)) &&
                  head_ != nullptr;
  counter_.set_capacity(ok ? max_doors : 0);
  clear();
  return ok;
}

std::size_t DoorSet::bucket_of(long gx, long gy) const {
  const std::uint64_t h = memory::mix64((static_cast<std::uint64_t>(static_cast<std::uint32_t>(gx)) << 32) ^
                                        static_cast<std::uint32_t>(gy));
  return static_cast<std::size_t>(h & (buckets_ - 1));
}

void DoorSet::link(std::size_t i) {
  const Eigen::Vector2d mid = 0.5 * (doors_[i].a + doors_[i].b);
  const std::size_t b = bucket_of(static_cast<long>(std::floor(mid.x() / grid_m_)),
                                  static_cast<long>(std::floor(mid.y() / grid_m_)));
  next_[i] = head_[b];
  head_[b] = static_cast<std::uint32_t>(i);
}

void DoorSet::reindex() {
  if (head_ == nullptr) return;
  std::fill(head_, head_ + buckets_, std::numeric_limits<std::uint32_t>::max());
  for (std::size_t i = 0; i < size_; ++i) link(i);
}

void DoorSet::clear() {
  size_ = 0;
  counter_.set_in_use(0);
  reindex();
}

bool DoorSet::add(const Door& door) {
  if (!door.a.allFinite() || !door.b.allFinite() || !std::isfinite(door.z_m)) return false;
  if (size_ >= counter_.capacity()) return counter_.refuse(1);
  doors_[size_] = door;
  misses_[size_] = 0;
  link(size_++);
  counter_.set_in_use(size_);
  return true;
}

bool DoorSet::closes(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  if (size_ == 0 || !a.allFinite() || !b.allFinite()) return false;
  // Every door whose midpoint lies within one grid cell of the edge's box: their lines are the only ones that
  // can reach it. A bucket shared by two cells is read twice at most, which does not change the answer.
  const long x0 = static_cast<long>(std::floor(std::min(a.x(), b.x()) / grid_m_)) - 1;
  const long x1 = static_cast<long>(std::floor(std::max(a.x(), b.x()) / grid_m_)) + 1;
  const long y0 = static_cast<long>(std::floor(std::min(a.y(), b.y()) / grid_m_)) - 1;
  const long y1 = static_cast<long>(std::floor(std::max(a.y(), b.y()) / grid_m_)) + 1;
  if ((x1 - x0 + 1) * (y1 - y0 + 1) > static_cast<long>(buckets_)) {  // a long edge: test every door
    for (std::size_t i = 0; i < size_; ++i)
      if (door_closes_edge(doors_[i], config_, a, b)) return true;
    return false;
  }
  for (long gx = x0; gx <= x1; ++gx)
    for (long gy = y0; gy <= y1; ++gy)
      for (std::uint32_t i = head_[bucket_of(gx, gy)]; i != std::numeric_limits<std::uint32_t>::max(); i = next_[i])
        if (door_closes_edge(doors_[i], config_, a, b)) return true;
  return false;
}

}  // namespace qsg::rooms

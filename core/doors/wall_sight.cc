// Sight lines across the structural walls of the final door stage's slices.
#include "core/doors/wall_sight.h"

#include "core/doors/door_params.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace qsg::rooms {

namespace {

// The structure mask of one raster, in the caller's buffers (cells each; list holds cells indices): the walls
// thickened by repeated 4-neighbour dilation (a diamond of `steps` cells), then each 8-connected piece flooded
// through `list` (its cells stay there) and, when its bounding box's diagonal reaches min_diagonal_cells (or it
// touches the raster's edge and border_is_structure), written into `structure`, unless it is a thick island
// (diagonal below furniture_max_cells, cells over diagonal above furniture_min_width_cells). Never allocates.
struct PieceRule {
  double min_diagonal_cells = 0.0;
  double furniture_max_cells = 0.0;  // 0: no thick-island rule
  double furniture_min_width_cells = 0.0;
  bool border_is_structure = false;
};

PieceRule piece_rule(const DoorConfig& config, double cell_m, bool border_is_structure) {
  PieceRule rule;
  rule.min_diagonal_cells = config.sight_min_wall_m / cell_m;
  rule.furniture_max_cells = config.sight_furniture_max_m / cell_m;
  rule.furniture_min_width_cells = config.sight_furniture_min_width_m / cell_m;
  rule.border_is_structure = border_is_structure;
  return rule;
}

void build_structure(const DoorRaster& raster, const std::uint8_t* wall, int steps, const PieceRule& rule,
                     std::uint8_t* grown, std::uint8_t* scratch, std::uint32_t* list, std::uint8_t* structure,
                     WallSight::Slice* out) {
  const int cols = raster.cols, rows = raster.rows;
  const std::size_t cells = raster.cells();
  std::copy(wall, wall + cells, grown);
  for (int k = 0; k < steps; ++k) {
    std::copy(grown, grown + cells, scratch);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * cols + c;
        if (scratch[i] == 0) continue;
        if (c > 0) grown[i - 1] = 1;
        if (c + 1 < cols) grown[i + 1] = 1;
        if (r > 0) grown[i - cols] = 1;
        if (r + 1 < rows) grown[i + cols] = 1;
      }
  }
  std::fill(scratch, scratch + cells, std::uint8_t{0});  // now: visited
  std::fill(structure, structure + cells, std::uint8_t{0});
  out->components = out->structure_components = out->structure_cells = out->furniture_islands = 0;
  for (std::size_t start = 0; start < cells; ++start) {
    if (grown[start] == 0 || scratch[start] != 0) continue;
    int c0 = cols, c1 = -1, r0 = rows, r1 = -1;
    std::size_t size = 0;
    scratch[start] = 1;
    list[size++] = static_cast<std::uint32_t>(start);
    for (std::size_t head = 0; head < size; ++head) {
      const std::uint32_t i = list[head];
      const int c = static_cast<int>(i % static_cast<std::uint32_t>(cols));
      const int r = static_cast<int>(i / static_cast<std::uint32_t>(cols));
      c0 = std::min(c0, c);
      c1 = std::max(c1, c);
      r0 = std::min(r0, r);
      r1 = std::max(r1, r);
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= cols || rr >= rows) continue;
          const std::size_t j = static_cast<std::size_t>(rr) * cols + cc;
          if (grown[j] == 0 || scratch[j] != 0) continue;
          scratch[j] = 1;
          list[size++] = static_cast<std::uint32_t>(j);
        }
    }
    ++out->components;
    const bool at_edge = c0 == 0 || r0 == 0 || c1 == cols - 1 || r1 == rows - 1;
    const double diagonal = std::hypot(c1 - c0 + 1.0, r1 - r0 + 1.0);
    if (!(rule.border_is_structure && at_edge)) {
      if (diagonal < rule.min_diagonal_cells) continue;
      const double mean_width = static_cast<double>(size) / diagonal;
      if (diagonal < rule.furniture_max_cells && mean_width > rule.furniture_min_width_cells) {
        ++out->furniture_islands;
        continue;
      }
    }
    ++out->structure_components;
    out->structure_cells += size;
    for (std::size_t k = 0; k < size; ++k) structure[list[k]] = 1;
  }
}

const char* check_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m,
                        const DoorConfig& config, std::string* bad) {
  if (wall == nullptr) return "no wall raster";
  if (raster.cols <= 0 || raster.rows <= 0 || !(raster.cell_m > 0.0)) return "empty raster";
  if (raster.cells() > config.max_cells) return "the raster exceeds max_cells";
  if (!std::isfinite(slice_z_m)) return "the slice height is not finite";
  if (!config.validate(bad)) return bad->c_str();
  return nullptr;
}

}  // namespace

void WallSight::clear() {
  slices_.clear();
  window_set_ = false;
  copied_window_ = false;
}

bool WallSight::can_add(const DoorRaster& raster, const std::uint8_t* cells, double slice_z_m,
                        const DoorConfig& config, std::string* error) const {
  std::string bad;
  const char* why = check_slice(raster, cells, slice_z_m, config, &bad);
  if (why == nullptr && carved_) why = "carved for one window slice (set_window_slice)";
  if (why != nullptr && error != nullptr) *error = std::string("wall sight: ") + why;
  return why == nullptr;
}

bool WallSight::add_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m,
                          const DoorConfig& config, std::string* error, bool border_is_structure) {
  if (!can_add(raster, wall, slice_z_m, config, error)) return false;
  const std::size_t cells = raster.cells();
  Slice s;
  s.raster = raster;
  s.z_m = slice_z_m;
  s.owned.assign(cells, 0);
  std::vector<std::uint8_t> grown(cells), scratch(cells);
  std::vector<std::uint32_t> list(cells);
  build_structure(raster, wall, static_cast<int>(std::lround(config.sight_wall_dilation_m / raster.cell_m)),
                  piece_rule(config, raster.cell_m, border_is_structure), grown.data(), scratch.data(), list.data(),
                  s.owned.data(), &s);
  max_dz_m_ = config.cut_max_dz_m;
  slices_.push_back(std::move(s));
  return true;
}

bool WallSight::add_structure(const DoorRaster& raster, const std::uint8_t* structure, double slice_z_m,
                              const DoorConfig& config, std::string* error, bool window) {
  if (!can_add(raster, structure, slice_z_m, config, error)) return false;
  Slice s;
  s.raster = raster;
  s.z_m = slice_z_m;
  s.owned.assign(structure, structure + raster.cells());
  for (const std::uint8_t v : s.owned) s.structure_cells += v != 0 ? 1 : 0;
  max_dz_m_ = config.cut_max_dz_m;
  copied_window_ = copied_window_ || window;
  slices_.push_back(std::move(s));
  return true;
}

memory::ArenaPlan WallSight::plan(std::size_t cells) {
  memory::ArenaPlan p;
  p.add_array<std::uint8_t>(cells);
  p.add_array<std::uint8_t>(cells);
  p.add_array<std::uint32_t>(cells);
  p.add_array<std::uint8_t>(cells);
  return p;
}

bool WallSight::carve(memory::Arena& arena, std::size_t cells) {
  grown_ = arena.carve_array<std::uint8_t>(cells);
  scratch_ = arena.carve_array<std::uint8_t>(cells);
  list_ = arena.carve_array<std::uint32_t>(cells);
  structure_ = arena.carve_array<std::uint8_t>(cells);
  slices_.clear();
  carved_ = grown_ != nullptr && scratch_ != nullptr && list_ != nullptr && structure_ != nullptr;
  capacity_cells_ = carved_ ? cells : 0;
  window_set_ = false;
  door_params_table();  // built now, at start-up: validating each window slice's config then allocates nothing
  return carved_;
}

bool WallSight::set_window_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m,
                                 const DoorConfig& config) {
  window_set_ = false;
  std::string bad;  // empty unless the config is bad: no allocation on the good path
  if (!carved_ || check_slice(raster, wall, slice_z_m, config, &bad) != nullptr || raster.cells() > capacity_cells_)
    return false;
  window_.raster = raster;
  window_.z_m = slice_z_m;
  window_.window = structure_;
  build_structure(raster, wall, static_cast<int>(std::lround(config.sight_wall_dilation_m / raster.cell_m)),
                  piece_rule(config, raster.cell_m, /*border_is_structure=*/true), grown_, scratch_, list_,
                  structure_, &window_);
  max_dz_m_ = config.cut_max_dz_m;
  window_set_ = true;
  return true;
}

int WallSight::slice_of(const Eigen::Vector3d& p) const {
  if (!p.allFinite()) return -1;
  int best = -1;
  double best_dz = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < slices(); ++i) {
    const double dz = std::abs(p.z() - slice(i).z_m);
    if (dz <= max_dz_m_ && dz < best_dz) {
      best = static_cast<int>(i);
      best_dz = dz;
    }
  }
  return best;
}

namespace {
bool in_raster(const DoorRaster& r, const Eigen::Vector3d& p) {
  int c, row;
  return r.cell_of(p.x(), p.y(), &c, &row);
}
}  // namespace

bool WallSight::sees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  const int slice = slice_of(a);
  if (slice < 0 || slice_of(b) != slice) return false;
  const Slice& s = this->slice(static_cast<std::size_t>(slice));
  return in_raster(s.raster, a) && in_raster(s.raster, b) && !line_hits(s, a, b);
}

bool WallSight::crosses_structure(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  const int slice = slice_of(a);
  if (slice < 0 || slice_of(b) != slice) return false;
  const Slice& s = this->slice(static_cast<std::size_t>(slice));
  return in_raster(s.raster, a) && in_raster(s.raster, b) && line_hits(s, a, b);
}

// Every cell the segment passes through, in order (Amanatides and Woo's traversal); true at the first structure
// cell.
bool WallSight::line_hits(const Slice& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  const double x0 = (a.x() - s.raster.lo.x()) / s.raster.cell_m, y0 = (a.y() - s.raster.lo.y()) / s.raster.cell_m;
  const double x1 = (b.x() - s.raster.lo.x()) / s.raster.cell_m, y1 = (b.y() - s.raster.lo.y()) / s.raster.cell_m;
  // Callers check that both ends lie in the raster, so the walk takes at most cols + rows steps.
  long c = static_cast<long>(std::floor(x0)), r = static_cast<long>(std::floor(y0));
  const long c_end = static_cast<long>(std::floor(x1)), r_end = static_cast<long>(std::floor(y1));
  const double dx = x1 - x0, dy = y1 - y0;
  const long step_c = dx > 0.0 ? 1 : -1, step_r = dy > 0.0 ? 1 : -1;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double delta_c = dx != 0.0 ? std::abs(1.0 / dx) : kInf, delta_r = dy != 0.0 ? std::abs(1.0 / dy) : kInf;
  // Distance (in units of the segment) to the first column and row boundary.
  const auto first = [&](double from, double d, double delta) {
    return d > 0.0 ? (std::floor(from) + 1.0 - from) * delta : d < 0.0 ? (from - std::floor(from)) * delta : kInf;
  };
  double next_c = first(x0, dx, delta_c), next_r = first(y0, dy, delta_r);
  const long steps = std::labs(c_end - c) + std::labs(r_end - r);
  for (long k = 0; k <= steps; ++k) {
    if (c >= 0 && r >= 0 && c < s.raster.cols && r < s.raster.rows &&  // rounding at the raster's rim
        s.structure()[static_cast<std::size_t>(r) * s.raster.cols + static_cast<std::size_t>(c)] != 0)
      return true;
    if (next_c < next_r) {
      c += step_c;
      next_c += delta_c;
    } else {
      r += step_r;
      next_r += delta_r;
    }
  }
  return false;
}

std::size_t cut_edges_through_walls(const WallSight& sight, scene_graph::SceneGraph* graph) {
  if (sight.slices() == 0) return 0;
  return close_place_edges(graph, [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return sight.crosses_structure(a, b);
  });
}

}  // namespace qsg::rooms

// Sight lines across the structural walls of the final door stage's slices.
#include "core/rooms/wall_sight.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace qsg::rooms {

void WallSight::clear() { slices_.clear(); }

bool WallSight::add_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m,
                          const DoorConfig& config, std::string* error) {
  const auto fail = [&](const char* why) {
    if (error != nullptr) *error = std::string("wall sight: ") + why;
    return false;
  };
  if (wall == nullptr) return fail("no wall raster");
  if (raster.cols <= 0 || raster.rows <= 0 || !(raster.cell_m > 0.0)) return fail("empty raster");
  if (raster.cells() > config.max_cells) return fail("the raster exceeds max_cells");
  if (!std::isfinite(slice_z_m)) return fail("the slice height is not finite");
  std::string bad;
  if (!config.validate(&bad)) return fail(bad.c_str());
  const int cols = raster.cols, rows = raster.rows;
  const std::size_t cells = raster.cells();
  Slice s;
  s.raster = raster;
  s.z_m = slice_z_m;
  // Thickened walls: repeated 4-neighbour dilation, a diamond of radius `steps` cells.
  std::vector<std::uint8_t> grown(wall, wall + cells), next(cells);
  const int steps = static_cast<int>(std::lround(config.sight_wall_dilation_m / raster.cell_m));
  for (int k = 0; k < steps; ++k) {
    next = grown;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * cols + c;
        if (grown[i] == 0) continue;
        if (c > 0) next[i - 1] = 1;
        if (c + 1 < cols) next[i + 1] = 1;
        if (r > 0) next[i - cols] = 1;
        if (r + 1 < rows) next[i + cols] = 1;
      }
    grown.swap(next);
  }
  // 8-connected components with their bounding boxes; the long ones are structure.
  constexpr std::uint32_t kUnlabelled = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> label(cells, kUnlabelled);
  std::vector<std::uint8_t> is_structure;
  std::vector<std::uint32_t> stack;
  const double min_diagonal_cells = config.sight_min_wall_m / raster.cell_m;
  for (std::size_t start = 0; start < cells; ++start) {
    if (grown[start] == 0 || label[start] != kUnlabelled) continue;
    const std::uint32_t id = static_cast<std::uint32_t>(is_structure.size());
    int c0 = cols, c1 = -1, r0 = rows, r1 = -1;
    label[start] = id;
    stack.assign(1, static_cast<std::uint32_t>(start));
    while (!stack.empty()) {
      const std::uint32_t i = stack.back();
      stack.pop_back();
      const int c = static_cast<int>(i % cols), r = static_cast<int>(i / cols);
      c0 = std::min(c0, c);
      c1 = std::max(c1, c);
      r0 = std::min(r0, r);
      r1 = std::max(r1, r);
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= cols || rr >= rows) continue;
          const std::size_t j = static_cast<std::size_t>(rr) * cols + cc;
          if (grown[j] == 0 || label[j] != kUnlabelled) continue;
          label[j] = id;
          stack.push_back(static_cast<std::uint32_t>(j));
        }
    }
    const bool structure = std::hypot(c1 - c0 + 1.0, r1 - r0 + 1.0) >= min_diagonal_cells;
    is_structure.push_back(structure ? 1 : 0);
    if (structure) ++s.structure_components;
  }
  s.components = is_structure.size();
  s.structure.assign(cells, 0);
  for (std::size_t i = 0; i < cells; ++i)
    if (label[i] != kUnlabelled && is_structure[label[i]] != 0) {
      s.structure[i] = 1;
      ++s.structure_cells;
    }
  max_dz_m_ = config.cut_max_dz_m;
  slices_.push_back(std::move(s));
  return true;
}

int WallSight::slice_of(const Eigen::Vector3d& p) const {
  if (!p.allFinite()) return -1;
  int best = -1;
  double best_dz = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < slices_.size(); ++i) {
    const double dz = std::abs(p.z() - slices_[i].z_m);
    if (dz <= max_dz_m_ && dz < best_dz) {
      best = static_cast<int>(i);
      best_dz = dz;
    }
  }
  return best;
}

bool WallSight::structure_at(std::size_t i, int c, int r) const {
  const Slice& s = slices_[i];
  if (c < 0 || r < 0 || c >= s.raster.cols || r >= s.raster.rows) return false;
  return s.structure[static_cast<std::size_t>(r) * s.raster.cols + c] != 0;
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
  const Slice& s = slices_[static_cast<std::size_t>(slice)];
  return in_raster(s.raster, a) && in_raster(s.raster, b) && !line_hits(s, a, b);
}

bool WallSight::crosses_structure(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  const int slice = slice_of(a);
  if (slice < 0 || slice_of(b) != slice) return false;
  const Slice& s = slices_[static_cast<std::size_t>(slice)];
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
  double next_c = dx > 0.0 ? (std::floor(x0) + 1.0 - x0) * delta_c : dx < 0.0 ? (x0 - std::floor(x0)) * delta_c : kInf;
  double next_r = dy > 0.0 ? (std::floor(y0) + 1.0 - y0) * delta_r : dy < 0.0 ? (y0 - std::floor(y0)) * delta_r : kInf;
  const long steps = std::labs(c_end - c) + std::labs(r_end - r);
  for (long k = 0; k <= steps; ++k) {
    if (c >= 0 && r >= 0 && c < s.raster.cols && r < s.raster.rows &&  // rounding at the raster's rim
        s.structure[static_cast<std::size_t>(r) * s.raster.cols + static_cast<std::size_t>(c)] != 0)
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
  if (graph == nullptr || sight.slices() == 0) return 0;
  std::vector<std::pair<scene_graph::NodeId, scene_graph::NodeId>> cut;
  graph->for_each_edge([&](const scene_graph::EdgeRecord& e) {
    const scene_graph::PlaceAttributes* a = graph->place(e.source);
    const scene_graph::PlaceAttributes* b = graph->place(e.target);
    if (a == nullptr || b == nullptr || (e.info.weighted && e.info.weight <= 0.0)) return;
    if (sight.crosses_structure(a->position_m, b->position_m)) cut.emplace_back(e.source, e.target);
  });
  for (const auto& [s, t] : cut) {
    scene_graph::EdgeAttributes* info = graph->edge_info(s, t);
    info->weighted = true;
    info->weight = 0.0;
  }
  return cut.size();
}

}  // namespace qsg::rooms

#include "core/rooms/door_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace qsg::rooms {

namespace sg = scene_graph;

bool DoorConfig::validate(std::string* error) const {
  const auto fail = [&](const char* what) {
    if (error != nullptr) *error = std::string("doors: ") + what;
    return false;
  };
  if (!(cell_m > 0.0)) return fail("cell_m must be positive");
  if (!(slice_half_band_m > 0.0)) return fail("slice_half_band_m must be positive");
  if (!(min_wall_height_m >= 0.0 && min_wall_height_m <= 2.0 * slice_half_band_m))
    return fail("min_wall_height_m must lie in [0, 2 x slice_half_band_m]");
  if (!(mapped_radius_m > 0.0) || !(place_band_m >= 0.0)) return fail("mapped_radius_m and place_band_m");
  if (!(min_width_m > 0.0 && max_width_m >= min_width_m)) return fail("need 0 < min_width_m <= max_width_m");
  if (!(min_rise_m >= 0.0) || !(rise_reach_m > 0.0)) return fail("min_rise_m >= 0 and rise_reach_m > 0");
  if (!(max_off_centre >= 0.0 && max_off_centre <= 1.0)) return fail("max_off_centre must lie in [0, 1]");
  if (!(suppression_m >= 0.0)) return fail("suppression_m must not be negative");
  if (max_cells == 0) return fail("max_cells must be positive");
  if (!std::isfinite(slice_above_robot_m)) return fail("slice_above_robot_m must be finite");
  if (!(storey_bin_m > 0.0) || !(storey_min_share >= 0.0 && storey_min_share <= 1.0) ||
      !(storey_separation_m >= 0.0))
    return fail("storey_bin_m > 0, storey_min_share in [0, 1] and storey_separation_m >= 0");
  if (!(cut_extension_m >= 0.0) || !(cut_max_dz_m >= 0.0)) return fail("cut_extension_m and cut_max_dz_m >= 0");
  return true;
}

namespace {

// Zhang-Suen thinning of a 0/1 image (1: foreground), in place; the border row and column stay 0.
void thin(cv::Mat1b* img) {
  cv::Mat1b& m = *img;
  std::vector<std::pair<int, int>> marked;
  for (bool changed = true; changed;) {
    changed = false;
    for (int pass = 0; pass < 2; ++pass) {
      marked.clear();
      for (int r = 1; r + 1 < m.rows; ++r)
        for (int c = 1; c + 1 < m.cols; ++c) {
          if (m(r, c) == 0) continue;
          // Neighbours clockwise from north: p2 .. p9.
          const int p[8] = {m(r - 1, c), m(r - 1, c + 1), m(r, c + 1), m(r + 1, c + 1),
                            m(r + 1, c), m(r + 1, c - 1), m(r, c - 1), m(r - 1, c - 1)};
          int count = 0, transitions = 0;
          for (int k = 0; k < 8; ++k) {
            count += p[k];
            transitions += (p[k] == 0 && p[(k + 1) % 8] == 1) ? 1 : 0;
          }
          if (count < 2 || count > 6 || transitions != 1) continue;
          const bool remove = pass == 0 ? (p[0] * p[2] * p[4] == 0 && p[2] * p[4] * p[6] == 0)
                                        : (p[0] * p[2] * p[6] == 0 && p[0] * p[4] * p[6] == 0);
          if (remove) marked.emplace_back(r, c);
        }
      for (const auto& [r, c] : marked) m(r, c) = 0;
      changed = changed || !marked.empty();
    }
  }
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Proper intersection of segments pq and ab in the plane.
bool segments_cross(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                    const Eigen::Vector2d& b) {
  const double d1 = cross2(b - a, p - a), d2 = cross2(b - a, q - a);
  const double d3 = cross2(q - p, a - p), d4 = cross2(q - p, b - p);
  return ((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0)) && d1 != 0 && d2 != 0 && d3 != 0 && d4 != 0;
}

}  // namespace

bool detect_doors(const std::vector<Eigen::Vector3f>& surface, const std::vector<Eigen::Vector3d>& places,
                  double slice_z_m, const DoorConfig& config, std::vector<Door>* doors, DoorStats* stats,
                  std::string* error) {
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
  for (const Eigen::Vector3d& p : places)
    if (place_in_band(p)) {
      lo = lo.cwiseMin(p.head<2>());
      hi = hi.cwiseMax(p.head<2>());
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
  const int cols = static_cast<int>(cols_d), rows = static_cast<int>(rows_d);
  st.cols = static_cast<std::size_t>(cols);
  st.rows = static_cast<std::size_t>(rows);
  const auto cell_of = [&](double x, double y, int* c, int* r) {
    *c = static_cast<int>(std::floor((x - lo.x()) / config.cell_m));
    *r = static_cast<int>(std::floor((y - lo.y()) / config.cell_m));
    return *c >= 0 && *r >= 0 && *c < cols && *r < rows;
  };
  const auto centre_of = [&](int c, int r) {
    return Eigen::Vector2d(lo.x() + (c + 0.5) * config.cell_m, lo.y() + (r + 0.5) * config.cell_m);
  };

  // Walls: cells whose surface spans min_wall_height_m within the band; dilated by one cell so that the free space
  // does not leak between diagonal wall cells.
  cv::Mat1f zmin(rows, cols, std::numeric_limits<float>::infinity());
  cv::Mat1f zmax(rows, cols, -std::numeric_limits<float>::infinity());
  for (const Eigen::Vector3f& v : surface) {
    int c, r;
    if (!in_band(v) || !cell_of(v.x(), v.y(), &c, &r)) continue;
    zmin(r, c) = std::min(zmin(r, c), v.z());
    zmax(r, c) = std::max(zmax(r, c), v.z());
  }
  cv::Mat1b wall(rows, cols, std::uint8_t{0});
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (zmax(r, c) - zmin(r, c) >= config.min_wall_height_m) wall(r, c) = 255;
  cv::dilate(wall, wall, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));

  // Mapped free space: the non-wall cells within mapped_radius_m of a place near the slice that a place reaches
  // without crossing a wall (not the space behind an outer wall that the radius alone would take in).
  cv::Mat1b free(rows, cols, std::uint8_t{0});
  const int radius_px = std::max(1, static_cast<int>(std::lround(config.mapped_radius_m / config.cell_m)));
  std::vector<cv::Point> place_cells;
  for (const Eigen::Vector3d& p : places) {
    int c, r;
    if (!place_in_band(p) || !cell_of(p.x(), p.y(), &c, &r)) continue;
    cv::circle(free, cv::Point(c, r), radius_px, cv::Scalar(255), cv::FILLED);
    place_cells.emplace_back(c, r);
  }
  free.setTo(0, wall);
  {
    cv::Mat1i component;
    const int n = cv::connectedComponents(free, component, 4, CV_32S);
    std::vector<std::uint8_t> reached(static_cast<std::size_t>(n), 0);
    for (const cv::Point& q : place_cells) reached[static_cast<std::size_t>(component(q))] = 1;
    reached[0] = 0;  // the background (walls and unmapped cells)
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c)
        if (free(r, c) != 0 && reached[static_cast<std::size_t>(component(r, c))] == 0) free(r, c) = 0;
  }
  // A one-cell frame of non-free cells, so thinning and the distance transform see a closed border.
  free.row(0).setTo(0);
  free.row(rows - 1).setTo(0);
  free.col(0).setTo(0);
  free.col(cols - 1).setTo(0);
  st.wall_cells = static_cast<std::size_t>(cv::countNonZero(wall));
  st.free_cells = static_cast<std::size_t>(cv::countNonZero(free));
  if (st.free_cells == 0) return true;

  // Clearance of every free cell (metres) and the medial axis of the free space.
  cv::Mat1f clearance;
  cv::distanceTransform(free, clearance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  clearance *= static_cast<float>(config.cell_m);
  cv::Mat1b axis;
  cv::threshold(free, axis, 0, 1, cv::THRESH_BINARY);
  thin(&axis);
  st.axis_cells = static_cast<std::size_t>(cv::countNonZero(axis));

  // The first non-free cell from p along direction u (unit), within max_m; false when none.
  const auto ray = [&](const Eigen::Vector2d& p, const Eigen::Vector2d& u, double max_m, Eigen::Vector2d* hit) {
    const double step = 0.5 * config.cell_m;
    for (double t = step; t <= max_m; t += step) {
      const Eigen::Vector2d q = p + t * u;
      int c, r;
      if (!cell_of(q.x(), q.y(), &c, &r) || free(r, c) == 0) {
        *hit = q;
        return true;
      }
    }
    return false;
  };
  const auto clearance_at = [&](const Eigen::Vector2d& q) {
    int c, r;
    return cell_of(q.x(), q.y(), &c, &r) ? static_cast<double>(clearance(r, c)) : 0.0;
  };

  struct Candidate {
    Door door;
    double half_width;
  };
  std::vector<Candidate> candidates;
  const double min_half = 0.5 * config.min_width_m, max_half = 0.5 * config.max_width_m;
  constexpr int kAngles = 36;
  for (int r = 1; r + 1 < rows; ++r)
    for (int c = 1; c + 1 < cols; ++c) {
      if (axis(r, c) == 0) continue;
      const double d = clearance(r, c);
      if (d < min_half || d > max_half) continue;
      // A local minimum of clearance among its axis neighbours.
      bool minimum = true;
      for (int dr = -1; dr <= 1 && minimum; ++dr)
        for (int dc = -1; dc <= 1; ++dc)
          if ((dr != 0 || dc != 0) && axis(r + dr, c + dc) != 0 && clearance(r + dr, c + dc) < d) {
            minimum = false;
            break;
          }
      if (!minimum) continue;
      // The shortest wall-to-wall line through the cell: its ends are the jambs.
      const Eigen::Vector2d p = centre_of(c, r);
      double best = std::numeric_limits<double>::infinity();
      Eigen::Vector2d best_a = p, best_b = p;
      for (int k = 0; k < kAngles; ++k) {
        const double th = M_PI * k / kAngles;
        const Eigen::Vector2d u(std::cos(th), std::sin(th));
        Eigen::Vector2d a, b;
        if (!ray(p, u, config.max_width_m, &a) || !ray(p, -u, config.max_width_m, &b)) continue;
        const double len = (a - b).norm();
        if (len < best) {
          best = len;
          best_a = a;
          best_b = b;
        }
      }
      if (!(best >= config.min_width_m && best <= config.max_width_m + config.cell_m)) continue;
      const double da = (best_a - p).norm(), db = (best_b - p).norm();
      if (std::abs(da - db) > config.max_off_centre * (da + db)) continue;
      const Eigen::Vector2d u = (best_b - best_a).normalized();
      const Eigen::Vector2d n(-u.y(), u.x());
      // The clearance rises on both sides of the jamb-to-jamb line.
      bool opens = true;
      for (const double side : {1.0, -1.0}) {
        double peak = 0.0;
        for (double t = config.cell_m; t <= config.rise_reach_m; t += config.cell_m)
          peak = std::max(peak, clearance_at(p + side * t * n));
        opens = opens && peak >= d + config.min_rise_m;
      }
      if (!opens) continue;
      // The jambs' wall surface: the rays stopped at the walls' one-cell dilation.
      Door door;
      door.a = best_a - u * config.cell_m;
      door.b = best_b + u * config.cell_m;
      door.z_m = slice_z_m;
      candidates.push_back({door, d});
    }
  st.candidates = candidates.size();
  // Of candidates closer than suppression_m (line midpoints), the narrowest stays.
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& x, const Candidate& y) { return x.half_width < y.half_width; });
  for (const Candidate& cand : candidates) {
    const Eigen::Vector2d mid = 0.5 * (cand.door.a + cand.door.b);
    bool near = false;
    for (const Door& kept : *doors)
      if ((0.5 * (kept.a + kept.b) - mid).norm() < config.suppression_m) {
        near = true;
        break;
      }
    if (!near) doors->push_back(cand.door);
  }
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
                std::vector<Door>* doors, DoorStats* stats, std::string* error) {
  if (!config.validate(error)) return false;
  if (doors == nullptr) {
    if (error != nullptr) *error = "doors: no output";
    return false;
  }
  doors->clear();
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
    if (!detect_doors(surface, places, z, config, &found, &st, error)) return false;
    doors->insert(doors->end(), found.begin(), found.end());
    ++total.slices;
    total.cols += st.cols;
    total.rows += st.rows;
    total.wall_cells += st.wall_cells;
    total.free_cells += st.free_cells;
    total.axis_cells += st.axis_cells;
    total.candidates += st.candidates;
  }
  if (stats != nullptr) *stats = total;
  return true;
}

std::size_t cut_place_edges(const std::vector<Door>& doors, const DoorConfig& config, sg::SceneGraph* graph) {
  if (graph == nullptr || doors.empty()) return 0;
  std::vector<std::pair<sg::NodeId, sg::NodeId>> cut;
  graph->for_each_edge([&](const sg::EdgeRecord& e) {
    const sg::PlaceAttributes* a = graph->place(e.source);
    const sg::PlaceAttributes* b = graph->place(e.target);
    if (a == nullptr || b == nullptr || !a->position_m.allFinite() || !b->position_m.allFinite()) return;
    for (const Door& d : doors) {
      if (std::abs(a->position_m.z() - d.z_m) > config.cut_max_dz_m ||
          std::abs(b->position_m.z() - d.z_m) > config.cut_max_dz_m)
        continue;
      const Eigen::Vector2d u = (d.b - d.a).normalized() * config.cut_extension_m;
      if (segments_cross(a->position_m.head<2>(), b->position_m.head<2>(), d.a - u, d.b + u)) {
        cut.emplace_back(e.source, e.target);
        break;
      }
    }
  });
  for (const auto& [s, t] : cut) {
    sg::EdgeAttributes* info = graph->edge_info(s, t);
    info->weighted = true;
    info->weight = 0.0;
  }
  return cut.size();
}

}  // namespace qsg::rooms

// Exploration planning: 2.5D traversability graph from downward ray casts, room targets, A*, string pulling,
// and time parametrisation (turn in place, then drive) at the configured speed and sample rate.
#include "drivers/sim/exploration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <unordered_map>

namespace qsg::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kBodyCheckHeight_m = 0.45;
constexpr double kProbeHeight_m = 1.85;  // downward ground rays start this far above a level's floor  // centre of the body sphere above the ground (clears a stair riser)

struct Level {
  double floor_z_m = 0.0;
  double height_m = 2.5;
};

struct Node {
  int i = 0;
  int j = 0;
  float ground_z_m = 0.0f;
  float clearance_m = 0.0f;
};

class Graph {
 public:
  Graph(const world::World& world, const render::RayScene& scene, const world::FreeSpaceIndex& free_space,
        const ExplorationConfig& config)
      : config_(config) {
    const world::Aabb bounds = world::world_bounds(world);
    origin_ = bounds.min_m.head<2>() - Eigen::Vector2d::Constant(config.resolution_m);
    nx_ = static_cast<int>(std::ceil((bounds.max_m.x() - origin_.x()) / config.resolution_m)) + 2;
    ny_ = static_cast<int>(std::ceil((bounds.max_m.y() - origin_.y()) / config.resolution_m)) + 2;
    world_bottom_z_ = bounds.min_m.z() - 0.5;
    cells_.assign(static_cast<std::size_t>(nx_) * ny_, {});
    for (const Level& level : levels(world, bounds)) add_level(level, scene, free_space);
    compute_clearance();
  }

  static std::vector<Level> levels(const world::World& world, const world::Aabb& bounds) {
    std::vector<Level> out;
    for (const world::Room& r : world.rooms) {
      auto it = std::find_if(out.begin(), out.end(), [&](const Level& l) { return std::abs(l.floor_z_m - r.floor_z_m) < 0.5; });
      if (it == out.end()) out.push_back({r.floor_z_m, r.height_m});
      else it->height_m = std::min(it->height_m, r.height_m);
    }
    if (out.empty()) out.push_back({bounds.min_m.z(), std::max(0.5, bounds.size_m().z())});
    return out;
  }

  std::size_t size() const { return nodes_.size(); }
  const Node& node(int n) const { return nodes_[static_cast<std::size_t>(n)]; }
  Eigen::Vector3d position(int n) const {
    const Node& v = node(n);
    return {origin_.x() + (v.i + 0.5) * config_.resolution_m, origin_.y() + (v.j + 0.5) * config_.resolution_m,
            static_cast<double>(v.ground_z_m)};
  }

  // Nodes of the cell at (x, y) whose ground is within max_step of z (the one nearest z), or -1.
  int find(double x, double y, double z) const {
    const int i = static_cast<int>(std::floor((x - origin_.x()) / config_.resolution_m));
    const int j = static_cast<int>(std::floor((y - origin_.y()) / config_.resolution_m));
    if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return -1;
    int best = -1;
    double best_dz = config_.max_step_m;
    for (int n : cells_[cell(i, j)]) {
      const double dz = std::abs(nodes_[static_cast<std::size_t>(n)].ground_z_m - z);
      if (dz <= best_dz) {
        best_dz = dz;
        best = n;
      }
    }
    return best;
  }

  // Calls fn(neighbour, step_length_m) for each traversable neighbour (8-connected, no corner cutting).
  template <typename Fn>
  void for_each_neighbor(int n, Fn&& fn) const {
    const Node& v = node(n);
    int orth[3][3];
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) orth[dj + 1][di + 1] = (di == 0 && dj == 0) ? n : step_to(v, di, dj);
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        const int m = orth[dj + 1][di + 1];
        if ((di == 0 && dj == 0) || m < 0) continue;
        if (di != 0 && dj != 0 && (orth[1][di + 1] < 0 || orth[dj + 1][1] < 0)) continue;
        fn(m, (position(m) - position(n)).norm());
      }
    }
  }

  // Straight segment between two nodes on ground that never steps more than max_step: every cell it crosses
  // has a node at the interpolated height.
  bool line_of_sight(int a, int b) const {
    const Eigen::Vector3d pa = position(a), pb = position(b);
    const double length = (pb - pa).head<2>().norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.5 * config_.resolution_m))));
    double previous_z = pa.z();
    for (int s = 1; s <= steps; ++s) {
      const Eigen::Vector3d p = pa + (pb - pa) * (static_cast<double>(s) / steps);
      const int m = find(p.x(), p.y(), previous_z);
      if (m < 0) return false;
      previous_z = node(m).ground_z_m;
      if (std::abs(previous_z - p.z()) > config_.max_step_m) return false;
    }
    return true;
  }

 private:
  std::size_t cell(int i, int j) const { return static_cast<std::size_t>(j) * nx_ + i; }

  int step_to(const Node& v, int di, int dj) const {
    const int i = v.i + di, j = v.j + dj;
    if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return -1;
    int best = -1;
    double best_dz = config_.max_step_m;
    for (int m : cells_[cell(i, j)]) {
      const double dz = std::abs(nodes_[static_cast<std::size_t>(m)].ground_z_m - v.ground_z_m);
      if (dz <= best_dz) {
        best_dz = dz;
        best = m;
      }
    }
    return best;
  }

  // A node's clearance: the robot radius plus its distance, over traversable ground, to the nearest cell the
  // robot cannot stand on (walls, furniture, drops). Measured in the plane, so floors and ceilings do not count.
  void compute_clearance() {
    std::vector<double> distance(nodes_.size(), std::numeric_limits<double>::infinity());
    using Entry = std::pair<double, int>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
    for (std::size_t n = 0; n < nodes_.size(); ++n) {
      int neighbours = 0;
      for_each_neighbor(static_cast<int>(n), [&](int, double) { ++neighbours; });
      if (neighbours < 8) {
        distance[n] = 0.0;
        open.push({0.0, static_cast<int>(n)});
      }
    }
    while (!open.empty()) {
      const double d = open.top().first;
      const int v = open.top().second;
      open.pop();
      if (d > distance[static_cast<std::size_t>(v)]) continue;
      for_each_neighbor(v, [&](int m, double length) {
        if (d + length < distance[static_cast<std::size_t>(m)]) {
          distance[static_cast<std::size_t>(m)] = d + length;
          open.push({d + length, m});
        }
      });
    }
    for (std::size_t n = 0; n < nodes_.size(); ++n)
      nodes_[n].clearance_m = static_cast<float>(config_.robot_radius_m + 0.5 * config_.resolution_m + distance[n]);
  }

  void add_level(const Level& level, const render::RayScene& scene, const world::FreeSpaceIndex& free_space) {
    const double r = config_.robot_radius_m;
    // Probe from below door lintels (doors are at least 1.9 m high), so door openings get ground cells.
    const double top_z = level.floor_z_m + std::min(level.height_m - 0.05, kProbeHeight_m);
    const double body_z = std::max(kBodyCheckHeight_m, r + config_.max_step_m);
    for (int j = 0; j < ny_; ++j) {
      for (int i = 0; i < nx_; ++i) {
        const Eigen::Vector3d origin(origin_.x() + (i + 0.5) * config_.resolution_m,
                                     origin_.y() + (j + 0.5) * config_.resolution_m, top_z);
        if (!free_space.is_free(origin, 0.0)) continue;
        render::RayHit hit;
        if (!scene.intersect(origin, Eigen::Vector3d(0, 0, -1), 0.0, top_z - world_bottom_z_, &hit)) continue;
        if (hit.normal.z() < 0.7) continue;  // not a floor-like surface
        const double g = top_z - hit.t;
        bool duplicate = false;
        for (int n : cells_[cell(i, j)])
          if (std::abs(nodes_[static_cast<std::size_t>(n)].ground_z_m - g) < 0.05) duplicate = true;
        if (duplicate) continue;
        if (!free_space.is_free({origin.x(), origin.y(), g + body_z}, r)) continue;
        if (config_.camera_height_m > body_z && !free_space.is_free({origin.x(), origin.y(), g + config_.camera_height_m}, r))
          continue;
        cells_[cell(i, j)].push_back(static_cast<int>(nodes_.size()));
        nodes_.push_back({i, j, static_cast<float>(g), 0.0f});
      }
    }
  }

  ExplorationConfig config_;
  Eigen::Vector2d origin_;
  int nx_ = 0;
  int ny_ = 0;
  double world_bottom_z_ = 0.0;
  std::vector<Node> nodes_;
  std::vector<std::vector<int>> cells_;
};

// A* from a to b; cost grows near obstacles so paths keep to the middle of doors and corridors.
std::vector<int> astar(const Graph& g, int a, int b, const ExplorationConfig& config) {
  const std::size_t n = g.size();
  std::vector<double> cost(n, std::numeric_limits<double>::infinity());
  std::vector<int> parent(n, -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const Eigen::Vector3d goal = g.position(b);
  cost[static_cast<std::size_t>(a)] = 0.0;
  open.push({(g.position(a) - goal).norm(), a});
  while (!open.empty()) {
    const double f = open.top().first;
    const int v = open.top().second;
    open.pop();
    if (v == b) break;
    if (f - (g.position(v) - goal).norm() > cost[static_cast<std::size_t>(v)] + 1e-9) continue;  // stale entry
    g.for_each_neighbor(v, [&](int m, double length) {
      const double c = g.node(m).clearance_m;
      const double penalty = 1.0 + 3.0 * std::max(0.0, config.preferred_clearance_m - c) / config.preferred_clearance_m;
      const double next = cost[static_cast<std::size_t>(v)] + length * penalty;
      if (next < cost[static_cast<std::size_t>(m)]) {
        cost[static_cast<std::size_t>(m)] = next;
        parent[static_cast<std::size_t>(m)] = v;
        open.push({next + (g.position(m) - goal).norm(), m});
      }
    });
  }
  std::vector<int> path;
  if (a != b && parent[static_cast<std::size_t>(b)] < 0) return path;
  for (int v = b; v != -1; v = parent[static_cast<std::size_t>(v)]) path.push_back(v);
  std::reverse(path.begin(), path.end());
  return path;
}

// Keeps only the nodes where a straight segment would leave the traversable ground.
std::vector<int> string_pull(const Graph& g, const std::vector<int>& path) {
  if (path.size() < 3) return path;
  std::vector<int> out{path.front()};
  std::size_t anchor = 0;
  while (anchor + 1 < path.size()) {
    std::size_t next = anchor + 1;
    for (std::size_t k = std::min(path.size() - 1, anchor + 300); k > anchor + 1; --k) {
      if (g.line_of_sight(path[anchor], path[k])) {
        next = k;
        break;
      }
    }
    out.push_back(path[next]);
    anchor = next;
  }
  return out;
}

double wrap_angle(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a < -kPi) a += 2 * kPi;
  return a;
}

// Samples poses along a polyline: turn in place toward each segment, then drive it; spins where asked.
class Sampler {
 public:
  Sampler(const ExplorationConfig& config, replay::Trajectory* out) : config_(config), out_(out) {
    dt_ns_ = static_cast<std::int64_t>(std::llround(1e9 / config.rate_hz));
    time_ns_ = config.start_time_ns;
  }
  void start(const Eigen::Vector3d& p, double yaw) {
    position_ = p;
    yaw_ = yaw;
    emit();
  }
  void turn_to(double target_yaw) {
    const double delta = wrap_angle(target_yaw - yaw_);
    turn_by(delta);
  }
  void turn_by(double delta) {
    const double step = config_.yaw_rate_rad_s / config_.rate_hz;
    const int n = static_cast<int>(std::ceil(std::abs(delta) / step));
    const double start = yaw_;
    for (int k = 1; k <= n; ++k) {
      yaw_ = start + delta * k / n;
      emit();
    }
    yaw_ = wrap_angle(yaw_);
  }
  void drive_to(const Eigen::Vector3d& p) {
    const Eigen::Vector3d d = p - position_;
    const double horizontal = d.head<2>().norm();
    if (horizontal < 1e-6) {
      position_ = p;
      return;
    }
    // Small heading changes are taken while driving; large ones in place first.
    const double heading = std::atan2(d.y(), d.x());
    if (std::abs(wrap_angle(heading - yaw_)) > 0.15) turn_to(heading);
    const double step = config_.speed_m_s / config_.rate_hz;
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / step)));
    const Eigen::Vector3d start = position_;
    const double start_yaw = yaw_;
    const double dyaw = wrap_angle(heading - start_yaw);
    for (int k = 1; k <= n; ++k) {
      const double s = static_cast<double>(k) / n;
      position_ = start + d * s;
      yaw_ = start_yaw + dyaw * s;
      emit();
    }
    length_m_ += d.norm();
  }
  double length_m() const { return length_m_; }

 private:
  void emit() {
    replay::StampedPose pose;
    pose.time_ns = time_ns_;
    pose.world_t_body_m = position_;
    pose.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()));
    out_->push_back(pose);
    time_ns_ += dt_ns_;
  }
  ExplorationConfig config_;
  replay::Trajectory* out_;
  std::int64_t dt_ns_ = 0;
  std::int64_t time_ns_ = 0;
  Eigen::Vector3d position_ = Eigen::Vector3d::Zero();
  double yaw_ = 0.0;
  double length_m_ = 0.0;
};

// A look into a room the tour cannot enter: from `node`, facing `yaw`, `seen` of the room's samples in sight.
struct Peek {
  int node = -1;
  double yaw = 0.0;
  int seen = 0;
};

// Points spread over a room's free floor at camera height, at most kPeekSamples of them: what a look into the room
// should see.
constexpr std::size_t kPeekSamples = 32;
std::vector<Eigen::Vector3d> room_samples(const world::World& world, const world::Room& room,
                                          const world::FreeSpaceIndex& free_space, double camera_height_m) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const world::Polygon2& polygon : room.footprint_m)
    for (const Eigen::Vector2d& v : polygon) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  std::vector<Eigen::Vector3d> all;
  if (!(lo.x() <= hi.x() && lo.y() <= hi.y())) return all;
  constexpr double kStep_m = 0.25;
  const double z = room.floor_z_m + camera_height_m;
  for (double y = lo.y() + 0.5 * kStep_m; y < hi.y(); y += kStep_m)
    for (double x = lo.x() + 0.5 * kStep_m; x < hi.x(); x += kStep_m)
      if (world::room_at(world, x, y, z) == room.id && free_space.is_free({x, y, z}, 0.05)) all.emplace_back(x, y, z);
  if (all.size() <= kPeekSamples) return all;
  std::vector<Eigen::Vector3d> out;
  for (std::size_t k = 0; k < kPeekSamples; ++k) out.push_back(all[k * all.size() / kPeekSamples]);
  return out;
}

// The node of component `comp` (on a 3-cell lattice, enough to stand in front of a door) whose camera sees most of
// the samples within config.peek_range_m, nearest to them on a tie; seen == 0 when none sees any.
Peek best_peek(const Graph& graph, const std::vector<int>& component, int comp, const render::RayScene& scene,
               const std::vector<Eigen::Vector3d>& samples, const ExplorationConfig& config) {
  Peek best;
  if (samples.empty()) return best;
  Eigen::Vector2d lo = samples.front().head<2>(), hi = lo, centroid = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3d& s : samples) {
    lo = lo.cwiseMin(s.head<2>());
    hi = hi.cwiseMax(s.head<2>());
    centroid += s.head<2>();
  }
  centroid /= static_cast<double>(samples.size());
  lo.array() -= config.peek_range_m;
  hi.array() += config.peek_range_m;
  const double range2 = config.peek_range_m * config.peek_range_m;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t n = 0; n < graph.size(); ++n) {
    const Node& v = graph.node(static_cast<int>(n));
    if (component[n] != comp || v.i % 3 != 0 || v.j % 3 != 0) continue;
    const Eigen::Vector3d c = graph.position(static_cast<int>(n)) + Eigen::Vector3d(0, 0, config.camera_height_m);
    if (c.x() < lo.x() || c.y() < lo.y() || c.x() > hi.x() || c.y() > hi.y()) continue;
    int seen = 0;
    Eigen::Vector2d heading = Eigen::Vector2d::Zero();
    for (const Eigen::Vector3d& s : samples) {
      const Eigen::Vector3d d = s - c;
      const double length = d.norm();
      if (d.head<2>().squaredNorm() > range2 || length < 0.2) continue;
      render::RayHit hit;
      if (scene.intersect(c, d / length, 0.0, length - 0.05, &hit)) continue;
      ++seen;
      heading += d.head<2>() / d.head<2>().norm();
    }
    if (seen == 0) continue;
    const double distance = (c.head<2>() - centroid).norm();
    if (seen > best.seen || (seen == best.seen && distance < best_distance)) {
      best.node = static_cast<int>(n);
      best.seen = seen;
      best.yaw = std::atan2(heading.y(), heading.x());
      best_distance = distance;
    }
  }
  return best;
}

}  // namespace

Eigen::Matrix3d body_R_optical() {
  Eigen::Matrix3d r;
  // Columns: the optical x (right), y (down), z (forward) axes expressed in the body frame (x fwd, y left, z up).
  r << 0, 0, 1,  //
      -1, 0, 0,  //
      0, -1, 0;
  return r;
}

std::string ExplorationConfig::check() const {
  if (!(resolution_m > 0.01 && resolution_m <= 1.0)) return "resolution_m must be in (0.01, 1]";
  if (!(robot_radius_m > 0.0 && robot_radius_m < 2.0)) return "robot_radius_m must be in (0, 2)";
  if (!(max_step_m >= 0.0 && max_step_m < 1.0)) return "max_step_m must be in [0, 1)";
  if (!(camera_height_m > 0.0 && camera_height_m < 3.0)) return "camera_height_m must be in (0, 3)";
  if (!(speed_m_s > 0.0 && speed_m_s <= 5.0)) return "speed_m_s must be in (0, 5]";
  if (!(yaw_rate_rad_s > 0.0)) return "yaw_rate_rad_s must be positive";
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) return "rate_hz must be in (0, 1000]";
  if (!(preferred_clearance_m > 0.0)) return "preferred_clearance_m must be positive";
  if (!(peek_range_m > 0.0 && peek_range_m <= 20.0)) return "peek_range_m must be in (0, 20]";
  if (!(peek_sweep_deg >= 0.0 && peek_sweep_deg <= 180.0)) return "peek_sweep_deg must be in [0, 180]";
  if (tours < 1 || tours > 100000) return "tours must be in [1, 100000]";
  if (tours > 1 && !return_to_start) return "tours > 1 needs return_to_start";
  if (max_grid_cells < 1 || max_grid_cells > (std::size_t{1} << 28)) return "max_grid_cells must be in [1, 2^28]";
  return {};
}

void ExplorationConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "exploration: resolution %.3f m, robot radius %.2f m, max step %.2f m, camera height %.2f m, "
               "speed %.2f m/s, yaw rate %.2f rad/s, %.1f Hz, spin in rooms %s, return to start %s, %d tour(s), "
               "start room %d, look into unreachable rooms %s (range %.1f m, sweep +-%.0f deg), at most %zu grid "
               "cells\n",
               resolution_m, robot_radius_m, max_step_m, camera_height_m, speed_m_s, yaw_rate_rad_s, rate_hz,
               spin_in_rooms ? "yes" : "no", return_to_start ? "yes" : "no", tours, start_room,
               look_into_unreachable_rooms ? "yes" : "no", peek_range_m, peek_sweep_deg, max_grid_cells);
}

ExplorationResult plan_exploration(const world::World& world, const render::RayScene& scene,
                                   const world::FreeSpaceIndex& free_space, const ExplorationConfig& config) {
  ExplorationResult result;
  if (std::string bad = config.check(); !bad.empty()) {
    result.error = "exploration config: " + bad;
    return result;
  }
  if (!scene.built()) {
    result.error = "exploration: the ray scene was not built";
    return result;
  }
  if (world.rooms.empty()) {
    result.error = "exploration: the world has no rooms to visit";
    return result;
  }
  {
    // The grid Graph allocates, as it sizes it (two cells of margin each side), bounded before it exists.
    const world::Aabb bounds = world::world_bounds(world);
    const Eigen::Vector3d size = bounds.size_m();
    const double cells = (std::ceil(size.x() / config.resolution_m) + 4.0) * (std::ceil(size.y() / config.resolution_m) + 4.0);
    if (!size.allFinite() || !(cells <= static_cast<double>(config.max_grid_cells))) {
      char text[320];
      std::snprintf(text, sizeof(text),
                    "exploration: the world's x-y extent (%.6g m x %.6g m) needs %.3g grid cells at resolution_m %.3g, "
                    "more than max_grid_cells (%zu)",
                    size.x(), size.y(), cells, config.resolution_m, config.max_grid_cells);
      result.error = text;
      return result;
    }
  }
  const Graph graph(world, scene, free_space, config);
  result.graph_nodes = graph.size();

  // Best node (largest clearance) of each room, by component of the traversability graph.
  std::vector<int> component(graph.size(), -1);
  int num_components = 0;
  for (std::size_t s = 0; s < graph.size(); ++s) {
    if (component[s] >= 0) continue;
    std::vector<int> stack{static_cast<int>(s)};
    component[s] = num_components;
    while (!stack.empty()) {
      const int v = stack.back();
      stack.pop_back();
      graph.for_each_neighbor(v, [&](int m, double) {
        if (component[static_cast<std::size_t>(m)] < 0) {
          component[static_cast<std::size_t>(m)] = num_components;
          stack.push_back(m);
        }
      });
    }
    ++num_components;
  }
  std::unordered_map<std::int32_t, std::size_t> room_index;
  for (std::size_t r = 0; r < world.rooms.size(); ++r) room_index[world.rooms[r].id] = r;
  std::vector<std::vector<int>> room_nodes(world.rooms.size());
  for (std::size_t n = 0; n < graph.size(); ++n) {
    const Eigen::Vector3d p = graph.position(static_cast<int>(n));
    const std::int32_t room = world::room_at(world, p.x(), p.y(), p.z() + 0.3);
    const auto it = room_index.find(room);
    if (it != room_index.end()) room_nodes[it->second].push_back(static_cast<int>(n));
  }
  // Start room and component.
  std::size_t start = world.rooms.size();
  if (config.start_room >= 0) {
    const auto it = room_index.find(config.start_room);
    if (it == room_index.end() || room_nodes[it->second].empty()) {
      result.error = "exploration: start room " + std::to_string(config.start_room) + " has no traversable space";
      return result;
    }
    start = it->second;
  } else {
    for (std::size_t r = 0; r < world.rooms.size(); ++r) {
      if (room_nodes[r].empty()) continue;
      if (start == world.rooms.size() || world.rooms[r].id < world.rooms[start].id) start = r;
    }
  }
  if (start == world.rooms.size()) {
    result.error = "exploration: no room has traversable space for a robot of radius " +
                   std::to_string(config.robot_radius_m) + " m";
    return result;
  }
  const auto best_node = [&](std::size_t r, int comp) {
    int best = -1;
    for (int n : room_nodes[r]) {
      if (comp >= 0 && component[static_cast<std::size_t>(n)] != comp) continue;
      if (best < 0 || graph.node(n).clearance_m > graph.node(best).clearance_m) best = n;
    }
    return best;
  };
  const int start_node = best_node(start, -1);
  const int start_component = component[static_cast<std::size_t>(start_node)];
  std::vector<int> target(world.rooms.size(), -1);
  for (std::size_t r = 0; r < world.rooms.size(); ++r) {
    target[r] = best_node(r, start_component);
    if (target[r] < 0) result.unreachable_rooms.push_back(world.rooms[r].id);
  }
  target[start] = start_node;

  // Visit order: depth-first through the doors from the start room, nearest target first; rooms the door
  // graph does not reach (worlds without door records) follow in nearest-first order.
  std::vector<std::vector<std::size_t>> adjacent(world.rooms.size());
  for (const world::Door& d : world.doors) {
    const auto a = room_index.find(d.room_a), b = room_index.find(d.room_b);
    if (a == room_index.end() || b == room_index.end()) continue;
    adjacent[a->second].push_back(b->second);
    adjacent[b->second].push_back(a->second);
  }
  std::vector<bool> visited(world.rooms.size(), false);
  std::vector<std::size_t> order;
  std::function<void(std::size_t)> dfs = [&](std::size_t r) {
    visited[r] = true;
    order.push_back(r);
    std::vector<std::size_t> next = adjacent[r];
    const Eigen::Vector3d here = graph.position(target[r]);
    std::sort(next.begin(), next.end(), [&](std::size_t a, std::size_t b) {
      const double da = target[a] < 0 ? 1e300 : (graph.position(target[a]) - here).norm();
      const double db = target[b] < 0 ? 1e300 : (graph.position(target[b]) - here).norm();
      return da < db;
    });
    for (std::size_t m : next)
      if (!visited[m] && target[m] >= 0) dfs(m);
  };
  dfs(start);
  while (true) {
    const Eigen::Vector3d here = graph.position(target[order.back()]);
    std::size_t best = world.rooms.size();
    for (std::size_t r = 0; r < world.rooms.size(); ++r) {
      if (visited[r] || target[r] < 0) continue;
      if (best == world.rooms.size() ||
          (graph.position(target[r]) - here).norm() < (graph.position(target[best]) - here).norm())
        best = r;
    }
    if (best == world.rooms.size()) break;
    dfs(best);
  }

  // Looks into the rooms the tour cannot enter, each from the room its viewpoint lies in (or the visited room
  // nearest to it), nearest first.
  std::vector<Peek> peeks;
  std::vector<std::vector<std::size_t>> peeks_at(order.size());
  if (config.look_into_unreachable_rooms) {
    for (std::size_t r = 0; r < world.rooms.size(); ++r) {
      if (target[r] >= 0) continue;
      const Peek peek = best_peek(graph, component, start_component, scene,
                                  room_samples(world, world.rooms[r], free_space, config.camera_height_m), config);
      if (peek.seen == 0) continue;
      const Eigen::Vector3d at = graph.position(peek.node);
      const std::int32_t host_id = world::room_at(world, at.x(), at.y(), at.z() + 0.3);
      std::size_t host = order.size();
      for (std::size_t k = 0; k < order.size(); ++k)
        if (world.rooms[order[k]].id == host_id) host = k;
      if (host == order.size()) {  // a spot in no visited room (between rooms' footprints): the nearest visited one
        const auto distance = [&](std::size_t k) { return (graph.position(target[order[k]]) - at).norm(); };
        host = 0;
        for (std::size_t k = 1; k < order.size(); ++k)
          if (distance(k) < distance(host)) host = k;
      }
      peeks_at[host].push_back(peeks.size());
      peeks.push_back(peek);
      result.peeked_rooms.push_back(world.rooms[r].id);
    }
    for (std::size_t k = 0; k < order.size(); ++k) {
      const Eigen::Vector3d here = graph.position(target[order[k]]);
      std::sort(peeks_at[k].begin(), peeks_at[k].end(), [&](std::size_t a, std::size_t b) {
        return (graph.position(peeks[a].node) - here).norm() < (graph.position(peeks[b].node) - here).norm();
      });
    }
  }

  // Drive room to room.
  Sampler sampler(config, &result.trajectory);
  const auto camera = [&](int n) -> Eigen::Vector3d {
    return graph.position(n) + Eigen::Vector3d(0, 0, config.camera_height_m);
  };
  int at = target[order.front()];
  const auto drive = [&](int to) {
    const std::vector<int> path = string_pull(graph, astar(graph, at, to, config));
    if (path.empty()) return false;
    for (std::size_t p = 1; p < path.size(); ++p) sampler.drive_to(camera(path[p]));
    at = to;
    return true;
  };
  const char* const kNoPath = "exploration: no path between two nodes of the same component (internal error)";
  const auto look_in = [&](std::size_t k) {
    const double sweep = config.peek_sweep_deg * kPi / 180.0;
    for (std::size_t q : peeks_at[k]) {
      if (!drive(peeks[q].node)) return false;
      sampler.turn_to(peeks[q].yaw - sweep);
      sampler.turn_by(2 * sweep);
    }
    return true;
  };
  sampler.start(camera(target[order.front()]), 0.0);
  if (config.spin_in_rooms) sampler.turn_by(2 * kPi);
  result.room_order.push_back(world.rooms[order.front()].id);
  if (!look_in(0)) return result.error = kNoPath, result;
  std::vector<int> stops;
  for (std::size_t k = 1; k < order.size(); ++k) stops.push_back(target[order[k]]);
  if (config.return_to_start) stops.push_back(target[order.front()]);
  for (std::size_t k = 0; k < stops.size(); ++k) {
    if (!drive(stops[k])) return result.error = kNoPath, result;
    const bool is_room = k + 1 < stops.size() || !config.return_to_start;
    if (is_room) {
      result.room_order.push_back(world.rooms[order[k + 1]].id);
      if (config.spin_in_rooms) sampler.turn_by(2 * kPi);
      if (!look_in(k + 1)) return result.error = kNoPath, result;
    }
  }
  if (config.tours > 1 && !result.trajectory.empty()) {
    // Back at the start: face the first heading again, then walk the same tour again (times shifted by one tour).
    const Eigen::Quaterniond& q0 = result.trajectory.front().world_R_body;
    sampler.turn_to(std::atan2(2.0 * (q0.w() * q0.z() + q0.x() * q0.y()), 1.0 - 2.0 * (q0.y() * q0.y() + q0.z() * q0.z())));
    const std::size_t n = result.trajectory.size();
    const std::int64_t period_ns = result.trajectory.back().time_ns - result.trajectory.front().time_ns +
                                   static_cast<std::int64_t>(std::llround(1e9 / config.rate_hz));
    const double one_tour_m = sampler.length_m();
    result.trajectory.reserve(n * static_cast<std::size_t>(config.tours));
    for (std::int32_t tour = 1; tour < config.tours; ++tour)
      for (std::size_t i = 0; i < n; ++i) {
        replay::StampedPose p = result.trajectory[i];
        p.time_ns += tour * period_ns;
        result.trajectory.push_back(p);
      }
    result.length_m = one_tour_m * config.tours;
  } else {
    result.length_m = sampler.length_m();
  }
  result.duration_s = result.trajectory.empty()
                          ? 0.0
                          : 1e-9 * static_cast<double>(result.trajectory.back().time_ns - result.trajectory.front().time_ns);
  result.ok = true;
  return result;
}

ExplorationResult scripted_trajectory(const std::vector<Eigen::Vector3d>& waypoints_m, const ExplorationConfig& config) {
  ExplorationResult result;
  if (std::string bad = config.check(); !bad.empty()) {
    result.error = "trajectory config: " + bad;
    return result;
  }
  if (waypoints_m.empty()) {
    result.error = "scripted trajectory: no waypoints";
    return result;
  }
  for (std::size_t k = 0; k < waypoints_m.size(); ++k) {
    if (!waypoints_m[k].allFinite()) {
      result.error = "scripted trajectory: waypoint " + std::to_string(k) + " is not finite";
      return result;
    }
  }
  Sampler sampler(config, &result.trajectory);
  double yaw = 0.0;
  if (waypoints_m.size() > 1) {
    const Eigen::Vector3d d = waypoints_m[1] - waypoints_m[0];
    yaw = std::atan2(d.y(), d.x());
  }
  sampler.start(waypoints_m.front(), yaw);
  for (std::size_t k = 1; k < waypoints_m.size(); ++k) sampler.drive_to(waypoints_m[k]);
  result.length_m = sampler.length_m();
  result.duration_s = 1e-9 * static_cast<double>(result.trajectory.back().time_ns - result.trajectory.front().time_ns);
  result.ok = true;
  return result;
}

}  // namespace qsg::sim

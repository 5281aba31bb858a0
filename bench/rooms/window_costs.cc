// window_costs (issue 37, item 2): does the backend's cost per update stay flat as the building grows and as the
// tour goes on? A robot walks the corridor of a generated building (tests/rooms/synthetic_places.h's corridor plan:
// a 2 m corridor with a row of 4 m x 4 m rooms on each side, each with a door; places on a 0.5 m grid, clearance
// to the walls capped at 1.25 m) back and forth for --tour-m metres, one backend update every --step-m. As it goes,
// the places within --window-m of it enter the scene graph, active, with their edges (the frontend's places
// window), those it leaves go inactive and come back to life when it returns, and the walls within the window are
// painted into the online door stage's wall map (the plan's walls as vertex columns, 0.05 m apart, 2.5 m tall).
// Each update runs, on this thread, what the app's frontend and backend run:
//   - the nearest-place index maintenance (--index rebuild: the frontend before issue 37, the active places' k-d
//     tree rebuilt from a scan of the graph every update and every place's every 10th; incremental: the window's
//     places into the k-d tree and into the incremental all-places index, with its bounded sweep);
//   - the online door pass every 4th update (BackendStage: begin, places, wall raster, detection);
//   - the room update with its labels (BackendStage::update_rooms);
// and at the end the final stage (BackendStage::close_doors on the whole surface, then the last room update).
// Each is timed in thread CPU time. Figures per building: median, p99 and max per update over the whole tour and
// over its first and last 100 m, the final stage, and the rooms found against the plan's. JSON via bench/figures.h.
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "core/backend/backend_stage.h"
#include "core/frontend/incremental_place_index.h"
#include "core/frontend/nearest_place_index.h"
#include "core/scene_graph/scene_graph.h"
#include "tests/rooms/synthetic_places.h"

namespace {

using namespace qsg;

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

struct Options {
  std::vector<int> rooms_per_side = {6, 50};
  double tour_m = 1000.0;
  double step_m = 0.25;
  double window_m = 7.0;
  bool incremental_index = true;
  int rooms_window = -1;  // -1: the config's default
  double rooms_margin_m = -1.0;  // rooms::Config::window_room_margin_m; < 0: the config's default
  std::string json;
};

struct Sample {
  double at_m = 0.0;  // tour distance at this update
  double index_ms = 0.0, doors_ms = -1.0, rooms_ms = 0.0;
  std::size_t places = 0, active = 0, read = 0;  // places in the graph, in the window, read by the room update
  std::size_t visited = 0;  // place records the room update looked at to choose its window (UpdateResult)
};

struct Building {
  rooms::testing::GridPlan plan = rooms::testing::corridor_plan(1, 0.5);
  rooms::testing::SyntheticPlaces places;
  std::vector<std::vector<std::size_t>> edges_of;  // per place: indices into places.edges
  std::vector<float> wall;                         // x, y, z per wall vertex, sorted by x
  std::vector<float> wall_x;                       // x per wall vertex (for the window's range)
  double corridor_y = 0.0, x0 = 0.0, x1 = 0.0;
};

Building make_building(int rooms_per_side) {
  Building b;
  b.plan = rooms::testing::corridor_plan(rooms_per_side, 0.5);
  b.plan.add_to(&b.places, 1.0, Eigen::Vector2d::Zero(), 1.25);
  b.edges_of.resize(b.places.places.size());
  for (std::size_t e = 0; e < b.places.edges.size(); ++e) {
    b.edges_of[b.places.edges[e].a].push_back(e);
    b.edges_of[b.places.edges[e].b].push_back(e);
  }
  double ysum = 0.0;
  std::size_t n = 0;
  b.x0 = 1e18;
  b.x1 = -1e18;
  for (const auto& p : b.places.places) {
    if (p.room != 0) continue;
    ysum += p.position_m.y();
    ++n;
    b.x0 = std::min(b.x0, p.position_m.x());
    b.x1 = std::max(b.x1, p.position_m.x());
  }
  b.corridor_y = n > 0 ? ysum / static_cast<double>(n) : 0.0;
  // Walls: the sides of every occupied cell that face a free one, as vertex columns (as bm_rooms' door pass).
  const double cell = b.plan.cell_m();
  const int cols = static_cast<int>(std::lround(b.x1 / cell)) + 4, rows = 64;
  std::vector<std::array<float, 3>> pts;
  for (int y = -1; y < rows; ++y)
    for (int x = -1; x < cols; ++x) {
      if (b.plan.free(x, y)) continue;
      const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        if (!b.plan.free(x + dx[k], y + dy[k])) continue;
        const Eigen::Vector2d centre((x + 0.5) * cell, (y + 0.5) * cell);
        const Eigen::Vector2d normal(dx[k], dy[k]), along(-dy[k], dx[k]);
        for (double t = -0.5 * cell; t <= 0.5 * cell + 1e-9; t += 0.05) {
          const Eigen::Vector2d p = centre + 0.5 * cell * normal + t * along;
          for (double z = 0.0; z <= 2.5 + 1e-9; z += 0.1)
            pts.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(z)});
        }
      }
    }
  std::sort(pts.begin(), pts.end(), [](const auto& a, const auto& c) { return a[0] < c[0]; });
  for (const auto& p : pts) {
    b.wall.insert(b.wall.end(), p.begin(), p.end());
    b.wall_x.push_back(p[0]);
  }
  return b;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(q * static_cast<double>(v.size()))))];
}

struct Run {
  std::vector<Sample> samples;
  double final_doors_ms = 0.0, final_rooms_ms = 0.0;
  std::size_t final_rooms = 0, final_doors = 0, places = 0, expected_rooms = 0, online_rooms_last = 0;
  std::uint64_t index_failed = 0;
};

// The tour: back and forth along the corridor, one update every step_m.
bool run_tour(const Options& o, const Building& b, Run* out) {
  std::string error, warning;
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  auto backend = std::make_unique<backend::BackendStage>();
  const scene_graph::Capacities caps = scene_graph::capacities_from_budget();
  backend::BackendStage::Config bc;
  if (o.rooms_window >= 0) bc.rooms.window_updates = o.rooms_window != 0;
  if (o.rooms_margin_m >= 0.0) bc.rooms.window_room_margin_m = o.rooms_margin_m;
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) bc.perceived_labels.push_back(l);
  if (!graph->init(caps, scene_graph::arena_bytes_from_budget(), &error) ||
      !backend->init(bc, caps, 0, 0, &error, &warning)) {
    std::fprintf(stderr, "window_costs: setup: %s\n", error.c_str());
    return false;
  }
  if (!warning.empty()) std::fprintf(stderr, "window_costs: %s\n", warning.c_str());
  // The frontend reads places through a const graph: a writable access would open them (SceneGraph's open places).
  const scene_graph::SceneGraph& reader = *graph;
  const frontend::NearestPlaceCapacities ic = frontend::nearest_place_capacities_from_budget();
  auto active_index = std::make_unique<frontend::NearestPlaceIndex>();
  auto all_rebuilt = std::make_unique<frontend::NearestPlaceIndex>();
  auto all_incremental = std::make_unique<frontend::IncrementalPlaceIndex>();
  if (!active_index->init(ic, frontend::NearestPlaceIndex::plan(ic).total_bytes(), &error) ||
      !all_rebuilt->init(ic, frontend::NearestPlaceIndex::plan(ic).total_bytes(), &error) ||
      !all_incremental->init(ic, frontend::IncrementalPlaceIndex::plan(ic).total_bytes(), &error)) {
    std::fprintf(stderr, "window_costs: index: %s\n", error.c_str());
    return false;
  }
  const std::size_t n = b.places.places.size();
  std::vector<std::uint8_t> state(n, 0);  // 0 unseen, 1 active, 2 inactive
  std::vector<std::uint8_t> painted(b.wall.size() / 3, 0);
  std::vector<std::size_t> window;        // live places this update
  const double r2 = o.window_m * o.window_m;
  double x = b.x0, dir = 1.0, travelled = 0.0;
  std::uint64_t update = 0;
  for (; travelled <= o.tour_m; ++update) {
    const Eigen::Vector3d robot(x, b.corridor_y, 0.5);
    // The places window (not timed: the frontend's places cycle).
    window.clear();
    for (std::size_t i = 0; i < n; ++i) {
      const auto& p = b.places.places[i];
      const bool in = (p.position_m.head<2>() - robot.head<2>()).squaredNorm() <= r2;
      if (in) window.push_back(i);
      if (in && state[i] == 0) {
        scene_graph::PlaceAttributes attrs;
        attrs.position_m = p.position_m;
        attrs.distance_m = p.clearance_m;
        attrs.is_active = true;
        if (graph->add_place(p.id, attrs) != scene_graph::Status::kOk) return false;
        state[i] = 1;
        for (std::size_t e : b.edges_of[i]) {
          const auto& edge = b.places.edges[e];
          const std::size_t other = edge.a == i ? edge.b : edge.a;
          if (state[other] == 0) continue;
          scene_graph::EdgeAttributes info;
          info.weight = edge.weight_m;
          info.weighted = true;
          graph->add_edge(p.id, b.places.places[other].id, info);
        }
      } else if (in && state[i] == 2) {  // the writable access is what a writer of is_active goes through
        graph->place(p.id)->is_active = true;
        state[i] = 1;
      } else if (!in && state[i] == 1) {
        graph->place(p.id)->is_active = false;
        state[i] = 2;
      }
    }
    // The walls within the window (the reconstruction's painting, not timed).
    const auto lo = std::lower_bound(b.wall_x.begin(), b.wall_x.end(), static_cast<float>(x - o.window_m));
    for (std::size_t v = 3 * static_cast<std::size_t>(lo - b.wall_x.begin()); v < b.wall.size(); v += 3) {
      if (b.wall[v] > x + o.window_m) break;
      if (painted[v / 3] || (Eigen::Vector2d(b.wall[v], b.wall[v + 1]) - robot.head<2>()).squaredNorm() > r2) continue;
      painted[v / 3] = 1;
      backend->paint_wall_point(b.wall[v], b.wall[v + 1], b.wall[v + 2]);
    }
    // The robot's keyframe (the final door stage slices each storey the agents walked). Not timed.
    if (update % 4 == 0) {
      scene_graph::AgentAttributes agent;
      agent.position_m = robot;
      agent.timestamp_ns = update * 200000000ull;
      graph->add_agent(scene_graph::make_node_id('a', update / 4), 'a', agent);
    }
    Sample s;
    s.at_m = travelled;
    s.active = window.size();
    s.places = graph->num_nodes(scene_graph::NodeKind::kPlace);
    double t0 = thread_cpu_ms();
    if (o.incremental_index) {
      active_index->clear_points();
      for (std::size_t i : window) {
        const scene_graph::PlaceAttributes* a = reader.place(b.places.places[i].id);
        all_incremental->upsert(b.places.places[i].id, a->position_m);
        if (a->is_active) active_index->add_point(b.places.places[i].id, a->position_m);
      }
      active_index->build_tree();
      all_incremental->sweep(512, [&](scene_graph::NodeId id, const Eigen::Vector3d& p, Eigen::Vector3d* to) {
        const scene_graph::PlaceAttributes* a = reader.place(id);
        if (a == nullptr) return 1;
        if (a->position_m == p) return 0;
        *to = a->position_m;
        return 2;
      });
    } else {
      active_index->rebuild(*graph, true);
      if (update % 10 == 9) all_rebuilt->rebuild(*graph, false);
    }
    s.index_ms = thread_cpu_ms() - t0;
    if (backend->door_pass_due()) {
      t0 = thread_cpu_ms();
      backend->begin_door_pass(robot);
      backend->add_door_places(*graph);
      backend->rasterize_walls();
      backend->detect_doors();
      s.doors_ms = thread_cpu_ms() - t0;
    }
    t0 = thread_cpu_ms();
    const rooms::UpdateResult rr = backend->update_rooms(graph.get(), update * 200000000ull);
    s.rooms_ms = thread_cpu_ms() - t0;
    s.read = rr.places;
    s.visited = rr.places_visited;
    out->online_rooms_last = rr.rooms;
    out->samples.push_back(s);
    // Along the corridor and back.
    x += dir * o.step_m;
    travelled += o.step_m;
    if (x > b.x1) x = b.x1, dir = -1.0;
    if (x < b.x0) x = b.x0, dir = 1.0;
  }
  out->index_failed = all_incremental->failed() + active_index->dropped() + all_rebuilt->dropped();
  // The final stage on the whole surface.
  reconstruction::Mesh mesh;
  mesh.vertices.reserve(b.wall.size() / 3);
  for (std::size_t v = 0; v < b.wall.size(); v += 3) {
    reconstruction::MeshVertex mv;
    mv.x = b.wall[v];
    mv.y = b.wall[v + 1];
    mv.z = b.wall[v + 2];
    mesh.vertices.push_back(mv);
  }
  double t0 = thread_cpu_ms();
  const backend::BackendStage::FinalDoors fd = backend->close_doors(mesh, graph.get());
  out->final_doors_ms = thread_cpu_ms() - t0;
  t0 = thread_cpu_ms();
  const rooms::UpdateResult fr = backend->update_rooms(graph.get(), update * 200000000ull, /*final=*/true);
  out->final_rooms_ms = thread_cpu_ms() - t0;
  out->final_rooms = fr.rooms;
  out->final_doors = fd.doors;
  out->places = graph->num_nodes(scene_graph::NodeKind::kPlace);
  if (!fd.ok) std::fprintf(stderr, "window_costs: final doors: %s\n", fd.error.c_str());
  return true;
}

struct Stats {
  double median = 0.0, p99 = 0.0, max = 0.0;
  std::size_t n = 0;
};
template <typename Get>
Stats stats_of(const std::vector<Sample>& s, double from_m, double to_m, Get get) {
  std::vector<double> v;
  for (const Sample& x : s)
    if (x.at_m >= from_m && x.at_m < to_m && get(x) >= 0.0) v.push_back(get(x));
  Stats st;
  st.n = v.size();
  st.median = quantile(v, 0.5);
  st.p99 = quantile(v, 0.99);
  st.max = v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  return st;
}

void report(const Options& o, int rooms_per_side, const Run& run, bench::Figures* fig) {
  const std::string tag = std::to_string(2 * rooms_per_side) + "_rooms";
  const double end_m = run.samples.empty() ? 0.0 : run.samples.back().at_m;
  struct Part {
    const char* name;
    double from, to;
  } parts[] = {{"tour", 0.0, 1e18}, {"first_100m", 0.0, 100.0}, {"last_100m", end_m - 100.0, 1e18}};
  struct Stage {
    const char* name;
    double (*get)(const Sample&);
  } stages[] = {{"index", [](const Sample& s) { return s.index_ms; }},
                {"door_pass", [](const Sample& s) { return s.doors_ms; }},
                {"rooms", [](const Sample& s) { return s.rooms_ms; }},
                {"backend_update", [](const Sample& s) { return s.rooms_ms + std::max(0.0, s.doors_ms); }},
                {"places_read", [](const Sample& s) { return static_cast<double>(s.read); }},
                {"places_visited", [](const Sample& s) { return static_cast<double>(s.visited); }}};
  std::printf("%d rooms (+ corridor), %zu places, tour %.0f m, %zu updates; index %s\n", 2 * rooms_per_side,
              run.places, end_m, run.samples.size(), o.incremental_index ? "incremental" : "rebuild");
  std::printf("  %-15s %-11s %9s %9s %9s  (ms thread CPU per update; places_*: places)\n", "stage", "part",
              "median", "p99", "max");
  for (const Stage& st : stages)
    for (const Part& p : parts) {
      const Stats s = stats_of(run.samples, p.from, p.to, st.get);
      std::printf("  %-15s %-11s %9.3f %9.3f %9.3f\n", st.name, p.name, s.median, s.p99, s.max);
      const std::string name = "window_costs." + tag + "." + st.name + "." + p.name;
      const char* unit = std::string(st.name).rfind("places_", 0) == 0 ? "places" : "ms";
      fig->add(name + ".median", s.median, unit);
      fig->add(name + ".p99", s.p99, unit);
      fig->add(name + ".max", s.max, unit);
    }
  // Along the first pass: the room update's median and the places it read, per 25 m of tour.
  std::printf("  first pass, per 25 m: rooms median ms (places read)");
  for (double from = 0.0; from < std::min(end_m, 250.0); from += 25.0) {
    const Stats r = stats_of(run.samples, from, from + 25.0, [](const Sample& x) { return x.rooms_ms; });
    const Stats n = stats_of(run.samples, from, from + 25.0, [](const Sample& x) { return double(x.read); });
    std::printf(" %.1f (%.0f)", r.median, n.median);
    char bin[64];
    std::snprintf(bin, sizeof bin, "window_costs.%s.rooms.at_%03.0f_m.median", tag.c_str(), from);
    fig->add(bin, r.median, "ms");
  }
  std::printf("\n");
  std::printf("  final stage: doors %.1f ms (%zu doors), rooms %.1f ms; rooms online %zu, final %zu of %d; index "
              "refusals %llu\n",
              run.final_doors_ms, run.final_doors, run.final_rooms_ms, run.online_rooms_last, run.final_rooms,
              2 * rooms_per_side + 1, static_cast<unsigned long long>(run.index_failed));
  fig->add("window_costs." + tag + ".final_doors", run.final_doors_ms, "ms");
  fig->add("window_costs." + tag + ".final_rooms", run.final_rooms_ms, "ms");
  fig->add("window_costs." + tag + ".rooms_found_final", static_cast<double>(run.final_rooms), "rooms");
  fig->add("window_costs." + tag + ".rooms_found_online", static_cast<double>(run.online_rooms_last), "rooms");
  fig->add("window_costs." + tag + ".rooms_expected", 2.0 * rooms_per_side + 1.0, "rooms");
  fig->add("window_costs." + tag + ".places", static_cast<double>(run.places), "places");
}

int usage() {
  std::fprintf(stderr,
               "usage: window_costs [--rooms-per-side 6,50] [--tour-m 1000] [--step-m 0.25] [--window-m 7]\n"
               "                    [--index rebuild|incremental] [--rooms-window 0|1] [--rooms-margin-m M|inf]\n"
               "                    [--json FILE]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    const char* v = argv[++i];
    if (a == "--rooms-per-side") {
      o.rooms_per_side.clear();
      for (const char* p = v; *p != '\0';) {
        char* end = nullptr;
        const long k = std::strtol(p, &end, 10);
        if (end == p || k < 1 || k > 60) return usage();
        o.rooms_per_side.push_back(static_cast<int>(k));
        p = *end == ',' ? end + 1 : end;
      }
    } else if (a == "--tour-m") {
      o.tour_m = std::atof(v);
    } else if (a == "--step-m") {
      o.step_m = std::atof(v);
    } else if (a == "--window-m") {
      o.window_m = std::atof(v);
    } else if (a == "--index") {
      if (std::string(v) != "rebuild" && std::string(v) != "incremental") return usage();
      o.incremental_index = std::string(v) == "incremental";
    } else if (a == "--rooms-window") {
      o.rooms_window = std::atoi(v) != 0 ? 1 : 0;
    } else if (a == "--rooms-margin-m") {
      o.rooms_margin_m = std::strtod(v, nullptr);
      if (!(o.rooms_margin_m >= 0.0)) return usage();
    } else if (a == "--json") {
      o.json = v;
    } else {
      return usage();
    }
  }
  if (!(o.step_m > 0.0) || !(o.tour_m > 0.0) || !(o.window_m > 0.0)) return usage();
  char conditions[320];
  const double margin_m = o.rooms_margin_m >= 0.0 ? o.rooms_margin_m : rooms::Config{}.window_room_margin_m;
  std::snprintf(conditions, sizeof conditions,
                "corridor buildings, places on a 0.5 m grid, tour %.0f m, step %.2f m, window %.1f m, index %s, "
                "rooms window %d, rooms margin %.1f m, thread CPU time",
                o.tour_m, o.step_m, o.window_m, o.incremental_index ? "incremental" : "rebuild", o.rooms_window,
                margin_m);
  bench::Figures fig(conditions);
  for (int rps : o.rooms_per_side) {
    const Building b = make_building(rps);
    Run run;
    if (!run_tour(o, b, &run)) return 1;
    report(o, rps, run, &fig);
  }
  if (!o.json.empty() && !fig.write(o.json)) return 1;
  return 0;
}

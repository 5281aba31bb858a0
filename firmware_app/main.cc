// qsg_app: the onboard program. Until the perception pipeline lands it builds a scene graph of a generated
// building through core/ (places, rooms, objects, agent keyframes, building), inside the board's budget,
// writes it as Spark-DSG JSON and prints a summary with every store's usage.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "budgets/budget_table.h"
#include "core/scene_graph/spark_dsg_json.h"

namespace {

using namespace qsg::scene_graph;

struct Options {
  std::string output = "qsg_scene_graph.json";
  std::string input;  // when set: read this Spark-DSG file instead of generating
  int rooms_x = 4;
  int rooms_y = 3;
  unsigned seed = 1;
};

void usage() {
  std::printf(
      "usage: qsg_app [--output FILE] [--input SPARK_DSG_JSON] [--rooms NX NY] [--seed N]\n"
      "  Builds a scene graph of a generated building (NX x NY rooms, default 4 x 3) or reads one,\n"
      "  writes it as Spark-DSG JSON (default qsg_scene_graph.json) and prints a summary.\n");
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto need = [&](int n) {
      if (i + n >= argc) {
        std::fprintf(stderr, "qsg_app: %s needs %d value(s)\n", a.c_str(), n);
        return false;
      }
      return true;
    };
    if (a == "--output" && need(1)) {
      o.output = argv[++i];
    } else if (a == "--input" && need(1)) {
      o.input = argv[++i];
    } else if (a == "--rooms" && need(2)) {
      o.rooms_x = std::atoi(argv[++i]);
      o.rooms_y = std::atoi(argv[++i]);
      if (o.rooms_x < 1 || o.rooms_y < 1 || o.rooms_x * o.rooms_y > 400) {
        std::fprintf(stderr, "qsg_app: --rooms wants 1..400 rooms in all\n");
        return false;
      }
    } else if (a == "--seed" && need(1)) {
      o.seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    } else if (a == "--help" || a == "-h") {
      usage();
      std::exit(0);
    } else {
      std::fprintf(stderr, "qsg_app: unknown or incomplete argument '%s'\n", a.c_str());
      usage();
      return false;
    }
  }
  return true;
}

// Rooms of 5 m x 4 m on a grid; places on a 1 m lattice inside each room with their clearance to the
// walls; doors as places between neighbouring rooms; a few objects per room; a lawn-mower trajectory.
int generate_building(SceneGraph& g, const Options& o) {
  constexpr double kRoomW = 5.0, kRoomD = 4.0, kHeight = 1.0;
  static const char* const kObjectLabels[] = {"chair", "table", "sofa", "bed", "sink", "refrigerator"};
  std::mt19937 rng(o.seed);
  int failures = 0;
  const auto check = [&](Status s) {
    if (s != Status::kOk) ++failures;
  };
  std::uint64_t place_index = 0, object_index = 0, agent_index = 0;
  const NodeId building = make_node_id(kBuildingPrefix, 0);
  BuildingAttributes b;
  b.name.assign("B(0)", 4);
  b.position_m = {o.rooms_x * kRoomW / 2, o.rooms_y * kRoomD / 2, kHeight};
  check(g.add_building(building, b));

  const auto room_id = [&](int rx, int ry) { return make_node_id(kRoomPrefix, static_cast<std::uint64_t>(ry * o.rooms_x + rx)); };
  const auto place_id = [&](int rx, int ry, int ix, int iy) {
    return make_node_id(kPlacePrefix, static_cast<std::uint64_t>(((ry * o.rooms_x + rx) * 8 + iy) * 8 + ix));
  };
  for (int ry = 0; ry < o.rooms_y; ++ry) {
    for (int rx = 0; rx < o.rooms_x; ++rx) {
      const double x0 = rx * kRoomW, y0 = ry * kRoomD;
      RoomAttributes r;
      const std::string name = "R(" + std::to_string(ry * o.rooms_x + rx) + ")";
      r.name.assign(name.data(), name.size());
      r.position_m = {x0 + kRoomW / 2, y0 + kRoomD / 2, kHeight};
      r.semantic_label = static_cast<std::uint32_t>(rng() % 7);
      check(g.add_room(room_id(rx, ry), r));
      check(g.add_edge(building, room_id(rx, ry)));
      for (int iy = 0; iy < 3; ++iy) {
        for (int ix = 0; ix < 4; ++ix) {
          const double px = x0 + 1.0 + ix, py = y0 + 1.0 + iy;
          const double clearance = std::min(std::min(px - x0, x0 + kRoomW - px), std::min(py - y0, y0 + kRoomD - py));
          PlaceAttributes p;
          p.position_m = {px, py, kHeight};
          p.distance_m = clearance;
          p.num_basis_points = 2;
          p.is_active = true;
          const NodeId id = place_id(rx, ry, ix, iy);
          ++place_index;
          check(g.add_place(id, p));
          check(g.add_edge(room_id(rx, ry), id));
          if (ix > 0) check(g.add_edge(place_id(rx, ry, ix - 1, iy), id, {clearance, true}));
          if (iy > 0) check(g.add_edge(place_id(rx, ry, ix, iy - 1), id, {clearance, true}));
        }
      }
      // Doors to the east and north neighbours: the rooms touch, and the door places join their place graphs.
      if (rx > 0) {
        check(g.add_edge(room_id(rx - 1, ry), room_id(rx, ry)));
        check(g.add_edge(place_id(rx - 1, ry, 3, 1), place_id(rx, ry, 0, 1), {0.5, true}));
      }
      if (ry > 0) {
        check(g.add_edge(room_id(rx, ry - 1), room_id(rx, ry)));
        check(g.add_edge(place_id(rx, ry - 1, 1, 2), place_id(rx, ry, 1, 0), {0.5, true}));
      }
      const int num_objects = 2 + static_cast<int>(rng() % 3);
      for (int k = 0; k < num_objects; ++k) {
        const int label = static_cast<int>(rng() % 6);
        ObjectAttributes obj;
        const int ix = static_cast<int>(rng() % 4), iy = static_cast<int>(rng() % 3);
        const Eigen::Vector3d c(x0 + 1.0 + ix + 0.3, y0 + 1.0 + iy + 0.2, 0.4);
        obj.position_m = c;
        obj.semantic_label = static_cast<std::uint32_t>(label);
        const std::string oname = std::string(kObjectLabels[label]) + "_" + std::to_string(object_index);
        obj.name.assign(oname.data(), std::min<std::size_t>(oname.size(), 31));
        obj.bounding_box = BoundingBox::aabb(c - Eigen::Vector3d(0.3, 0.3, 0.4), c + Eigen::Vector3d(0.3, 0.3, 0.4));
        const NodeId oid = make_node_id(kObjectPrefix, object_index++);
        check(g.add_object(oid, obj));
        for (std::uint32_t v = 0; v < 50; ++v) g.append_mesh_connection(oid, static_cast<std::uint32_t>(object_index * 1000 + v));
        check(g.add_edge(oid, place_id(rx, ry, ix, iy)));
      }
    }
  }
  // Keyframes every 0.5 m along each row of places, parented to the place beneath.
  NodeId previous = kNoNode;
  for (int ry = 0; ry < o.rooms_y; ++ry) {
    for (int step = 0; step < o.rooms_x * 8; ++step) {
      const int col = ry % 2 == 0 ? step : o.rooms_x * 8 - 1 - step;
      const int rx = col / 8, ix = (col % 8) / 2;
      AgentAttributes a;
      a.position_m = {rx * kRoomW + 1.0 + ix + 0.5 * (col % 2), ry * kRoomD + 2.0, 0.5};
      a.timestamp_ns = agent_index * 500000000ULL;
      const NodeId aid = make_node_id(kDefaultAgentPrefix, agent_index++);
      check(g.add_agent(aid, kDefaultAgentPrefix, a));
      check(g.add_edge(aid, place_id(rx, ry, ix, 1)));
      if (previous != kNoNode) check(g.add_edge(previous, aid));
      previous = aid;
    }
  }
  return failures;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (!parse(argc, argv, options)) return 2;
  std::printf("qsg_app: board %s (%s)\n", qsg::budgets::active::kBoard, qsg::budgets::active::kTable.description);

  const Capacities capacities = capacities_from_budget();
  capacities.print(stdout);
  SceneGraph graph;
  std::string error;
  const auto t0 = std::chrono::steady_clock::now();
  if (!graph.init(capacities, arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "qsg_app: start-up failed: %s\n", error.c_str());
    return 1;
  }
  const auto t1 = std::chrono::steady_clock::now();
  if (!options.input.empty()) {
    const JsonImportResult r = read_spark_dsg_json_file(options.input, graph);
    if (!r.ok) {
      std::fprintf(stderr, "qsg_app: %s\n", r.error.c_str());
      return 1;
    }
  } else if (const int failures = generate_building(graph, options); failures != 0) {
    std::fprintf(stderr, "qsg_app: %d scene-graph insertions were refused\n", failures);
    return 1;
  }
  const auto t2 = std::chrono::steady_clock::now();
  if (!write_spark_dsg_json_file(graph, options.output, &error)) {
    std::fprintf(stderr, "qsg_app: %s\n", error.c_str());
    return 1;
  }
  const auto t3 = std::chrono::steady_clock::now();
  const auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };

  std::printf("scene graph: %zu nodes (objects %zu, agents %zu, places %zu, rooms %zu, buildings %zu), "
              "%zu edges (%zu intra-layer, %zu inter-layer)\n",
              graph.num_nodes(), graph.num_nodes(NodeKind::kObject), graph.num_nodes(NodeKind::kAgent),
              graph.num_nodes(NodeKind::kPlace), graph.num_nodes(NodeKind::kRoom), graph.num_nodes(NodeKind::kBuilding),
              graph.num_edges(), graph.num_layer_edges(false), graph.num_layer_edges(true));
  std::printf("timing: arena carve %.2f ms, %s %.2f ms, Spark-DSG JSON write %.2f ms\n", ms(t0, t1),
              options.input.empty() ? "build" : "read", ms(t1, t2), ms(t2, t3));
  std::printf("memory:\n");
  graph.for_each_resource([](const qsg::memory::ResourceStats& s) {
    std::printf("  ");
    s.print(stdout);
  });
  std::printf("wrote %s\n", options.output.c_str());
  return 0;
}

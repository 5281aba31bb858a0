// Rooms evaluation: benchmark floor plans (IPA, plain and furnished) extruded to 3D and generated two-floor buildings
// are explored by the simulated robot (ground-truth poses, or drifting ones with --odometry sim|vio, noise-free
// depth), reconstructed (TSDF) and run through the frontend (places) every keyframe, then the room finder runs once
// on the final graph. Scored with the benchmark's max-overlap precision and recall (mean over rooms and
// area-weighted) against the ground truth, in the world frame (bench/rooms/room_score.h).
//
// How estimated rooms become pixel sets (documented in the report): the free cells of a 2D raster (the floor plan's
// own pixels, 0.05 m; for generated buildings a 0.05 m raster of each floor's room footprints) are labelled by a
// multi-source breadth-first wavefront (8-connected, through free cells only) started from the cell of every place
// that has a room, so every free cell takes the room of the place geodesically nearest to it; cells farther than
// --max-reach-m from every place stay unlabelled (not seen). Scoring is restricted to cells that are free and
// inside a ground-truth room: |r_e| counts r_e's cells there, |r_g| all of r_g's free cells (unlabelled included,
// so unexplored space lowers recall).
//
// Peers, scored the same way: on the IPA plans, classical 2D segmentations of the complete plan (distance transform
// at two thresholds, morphological); on every plan and generated building, Hydra's room clustering
// (rooms::Config::paper(), the paper's plateau seeding, without our door stage) on the same explored places, the
// peer that saw what our robot saw. Each total prints ours over the peer.
//
// Room parameters come from the command line (--seeding plateau|persistence, --min-component, --alpha,
// --min-persistence-m, ...); --cache-dir saves each run's frontend graph and reuses it, so a parameter sweep
// explores each plan once.
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "bench/rooms/room_score.h"
#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "core/frontend/frontend.h"
#include "core/params/params.h"
#include "core/places/places_params.h"
#include "core/doors/door_params.h"
#include "core/rooms/rooms_params.h"
#include "core/neural_tree/room_classifier.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/doors/door_detector.h"
#include "core/doors/online_doors.h"
#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/floor_plan_import.h"
#include "bench/rooms/floor_plan_rooms.h"
#include "drivers/world/world_query.h"

#ifndef QSG_SHARED_DATA_DIR
#define QSG_SHARED_DATA_DIR "../shared/data"
#endif

namespace {

using namespace qsg;
namespace sg = scene_graph;
using bench::label_from_places;
using bench::Raster;
using bench::score;
using bench::truth_near;

struct Options {
  std::string plans_dir = std::string(QSG_SHARED_DATA_DIR) + "/floorplans/ipa";
  std::vector<std::string> maps{"lab_ipa", "Freiburg52_scan", "lab_c_scan", "lab_intel", "office_a", "office_e"};
  std::vector<std::string> variants{"plain", "furnished"};
  int generated = 2;          // two-floor generated buildings (seeds 1..N)
  int generated_rooms = 12;
  // Room labels alone on this many more generated two-floor buildings (seeds 1001..1000+N), on their ground-truth
  // rooms and objects: no exploration, so it is cheap enough to score hundreds of rooms.
  int label_buildings = 0;
  int width = 320;
  int height = 240;
  double hfov_deg = 90.0;
  double rate_hz = 2.0;       // keyframes per second along the tour
  double max_reach_m = 3.0;   // free cells farther (geodesically) from every place stay unlabelled
  double robot_radius_m = sim::ExplorationConfig{}.robot_radius_m;  // doors narrower than twice this stay shut
  // --look-into-unreachable 0|1: the tour looks into the rooms it cannot enter (sim::ExplorationConfig). Cached
  // explorations made with it on are named "<plan>.peek", so one made without is never read back as if made with it.
  bool look_into_unreachable = sim::ExplorationConfig{}.look_into_unreachable_rooms;
  // --furniture-height-m H: the furnished plans' furniture (occupied there, free in the plain plan) extruded to H
  // instead of the walls' 2.5 m (the benchmark's own use: furniture as floor-to-ceiling posts). 0: the benchmark's.
  double furniture_height_m = 0.0;
  // The stages' settings, each set by --set section.key=value from its parameter table (core/params): places
  // (places::Config, e.g. places.merge_revisited_within_m), rooms (rooms::Config) and doors (rooms::DoorConfig).
  places::Config places;
  rooms::Config rooms;
  std::string json_path;
  // Tuning aid: the frontend's graph of each run is saved here (Spark-DSG JSON) and read back on the next run
  // instead of exploring again, so room parameters can be swept in seconds. Empty: always explore.
  std::string cache_dir;
  // --images DIR: per plan (per floor of a generated building), a PNG of the estimated rooms beside the ground truth
  std::string images_dir;
  // --dump-places DIR: per plan (per floor of a generated building), a text file of its places and place-place
  // edges with their estimated and ground-truth rooms, for offline study of the room finder
  // (bench/rooms/finder_sandbox.py reads it).
  std::string dump_dir;
  // --door-oracle-m C (IPA plans): before the room finder's scored run, every place-place edge between two
  // ground-truth rooms gets clearance C, a perfect door and opening detector. The score is then the bound such a
  // cue would give the room finder, not the room finder's own. Negative: off.
  double door_oracle_m = -1.0;
  // --doors 1: doors and openings detected on the robot's own surface (rooms::find_doors, one slice per storey the
  // robot walked) close the place edges that cross them before the room finder runs, as the app does when a run
  // finishes.
  bool doors = true;
  // --doors online: the door stage the app runs during a run instead (rooms::OnlineDoors): the loop paints each
  // re-meshed block into the wall map, every --online-every N-th frontend update runs a window pass around the
  // robot, and the room finder reads the online doors (no final stage). The doors are cached beside the graph.
  bool online_doors = false;
  int online_every = 4;
  rooms::DoorConfig door;
  // --odometry gt|sim|vio, --odometry-seed N: the poses the map is built from (scored in the world frame). Caches
  // explored with drifting odometry are named "<plan>.odom-<level>-<seed>".
  bench::OdometryOption odometry;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    const std::size_t comma = s.find(',', pos);
    const std::string item = s.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    if (!item.empty()) out.push_back(item);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

// The stage settings --set reaches, from their parameter tables: one declaration per setting (core/params).
const params::Schema<Options>& eval_schema() {
  static const params::Schema<Options> schema = [] {
    params::Schema<Options> s;
    s.section("places", places::params_table(), [](Options& o) -> places::Config& { return o.places; });
    s.section("rooms", rooms::params_table(), [](Options& o) -> rooms::Config& { return o.rooms; });
    s.section("doors", rooms::door_params_table(), [](Options& o) -> rooms::DoorConfig& { return o.door; });
    return s;
  }();
  return schema;
}

// The hand-written flags of plain Config fields are gone (--alpha, --door-min-width-m, ...): an unknown flag that
// names a table key (dashes for underscores, without a "door-" prefix) gets the --set it now is.
std::string retired_flag_hint(const std::string& flag) {
  if (flag.rfind("--", 0) != 0) return {};
  std::string key = flag.substr(2);
  for (char& c : key)
    if (c == '-') c = '_';
  for (const std::string& candidate : {key, key.rfind("door_", 0) == 0 ? key.substr(5) : std::string()})
    for (const params::Section& section : eval_schema().sections())
      if (!candidate.empty() && section.find(candidate) != nullptr)
        return " (now --set " + section.name + "." + candidate + "=VALUE)";
  return " (stage settings: --set SECTION.KEY=VALUE, listed by --help)";
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h" || i + 1 >= argc) return false;
    if (const int odometry = bench::parse_odometry_flag(argc, argv, &i, &o->odometry)) {
      if (odometry < 0) return false;
      continue;
    }
    const std::string v = argv[++i];
    char* end = nullptr;
    double* number = nullptr;
    if (a == "--plans-dir") o->plans_dir = v;
    else if (a == "--maps") o->maps = v == "none" ? std::vector<std::string>{} : split(v);
    else if (a == "--variants") o->variants = split(v);
    else if (a == "--json") o->json_path = v;
    else if (a == "--cache-dir") o->cache_dir = v;
    else if (a == "--images") o->images_dir = v;
    else if (a == "--dump-places") o->dump_dir = v;
    else if (a == "--door-oracle-m") number = &o->door_oracle_m;
    else if (a == "--doors") {
      o->online_doors = v == "online";
      o->doors = !o->online_doors && std::atoi(v.c_str()) != 0;
    } else if (a == "--online-every") o->online_every = std::max(1, std::atoi(v.c_str()));
    else if (a == "--sight-cut-edges") {  // the final stage's written closures and the room finder's read ones
      o->door.sight_cut_edges = std::atoi(v.c_str()) != 0;
      o->rooms.close_edges_through_walls = o->door.sight_cut_edges;
    }
    else if (a == "--generated") o->generated = std::atoi(v.c_str());
    else if (a == "--generated-rooms") o->generated_rooms = std::atoi(v.c_str());
    else if (a == "--label-buildings") o->label_buildings = std::atoi(v.c_str());
    else if (a == "--size") {
      if (std::sscanf(v.c_str(), "%dx%d", &o->width, &o->height) != 2) return false;
    } else if (a == "--hfov-deg") number = &o->hfov_deg;
    else if (a == "--rate-hz") number = &o->rate_hz;
    else if (a == "--max-reach-m") number = &o->max_reach_m;
    else if (a == "--robot-radius-m") number = &o->robot_radius_m;
    else if (a == "--look-into-unreachable") o->look_into_unreachable = std::atoi(v.c_str()) != 0;
    else if (a == "--furniture-height-m") number = &o->furniture_height_m;
    else if (a == "--set") {
      std::string error;
      if (!params::set(eval_schema(), o, v, &error)) {
        std::fprintf(stderr, "--set %s\n", error.c_str());
        return false;
      }
    }
    else {
      std::fprintf(stderr, "unknown option %s%s\n", a.c_str(), retired_flag_hint(a).c_str());
      return false;
    }
    if (number != nullptr) {
      *number = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0') {
        std::fprintf(stderr, "option %s: bad value '%s'\n", a.c_str(), v.c_str());
        return false;
      }
    }
  }
  for (const std::string& v : o->variants)
    if (v != "plain" && v != "furnished") return false;
  if (const std::string bad = params::check(eval_schema(), *o); !bad.empty()) {
    std::fprintf(stderr, "%s\n", bad.c_str());
    return false;
  }
  return o->width > 0 && o->height > 0 && o->rate_hz > 0 && o->rooms.check().empty() &&
         o->places.check().empty();
}

double ratio(double a, double b) { return b > 0.0 ? a / b : 0.0; }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// One line per place, "P id x y z clearance room truth plan_clearance" (room: the parent's node id, 0 without one;
// truth: the ground-truth room of its cell as the oracle takes it, 0: none; plan_clearance: the horizontal distance
// from its cell to the plan's nearest occupied cell, the 2D clearance a map-based method sees), and per place-place
// edge "E id id weight" (weight -1 when unweighted), and per door the room finder read "D ax ay bx by z" (jamb to
// jamb in plan, the slice's height).
bool dump_places(const sg::SceneGraph& g, const Raster& ras, const std::string& path,
                 const std::vector<rooms::Door>& doors, double z_min_m = -1e9, double z_max_m = 1e9) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    std::fprintf(stderr, "--dump-places: cannot write %s\n", path.c_str());
    return false;
  }
  // Distance of every free cell to the plan's nearest occupied cell.
  cv::Mat free_mask(ras.rows, ras.cols, CV_8U), distance_px;
  for (int r = 0; r < ras.rows; ++r)
    for (int c = 0; c < ras.cols; ++c) free_mask.at<std::uint8_t>(r, c) = ras.free[ras.idx(c, r)] ? 255 : 0;
  cv::distanceTransform(free_mask, distance_px, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kPlace) return;
    const sg::PlaceAttributes* a = g.place(n.id);
    if (a->position_m.z() < z_min_m || a->position_m.z() >= z_max_m) return;
    int c, r;
    const bool inside = ras.cell_of(a->position_m, &c, &r);
    const std::int32_t truth = inside ? truth_near(ras, c, r) : 0;
    const double plan_clearance = inside ? distance_px.at<float>(r, c) * ras.res_m : 0.0;
    std::fprintf(f, "P %llu %.6f %.6f %.6f %.6f %llu %d %.6f\n", static_cast<unsigned long long>(n.id),
                 a->position_m.x(), a->position_m.y(), a->position_m.z(), a->distance_m,
                 static_cast<unsigned long long>(n.parent == sg::kNoNode ? 0 : n.parent), truth, plan_clearance);
    g.for_each_neighbor(n.id, [&](sg::NodeId other, const sg::EdgeRecord& e) {
      const sg::PlaceAttributes* b = g.place(other);
      if (other > n.id && b != nullptr && b->position_m.z() >= z_min_m && b->position_m.z() < z_max_m)
        std::fprintf(f, "E %llu %llu %.6f\n", static_cast<unsigned long long>(n.id),
                     static_cast<unsigned long long>(other), e.info.weighted ? e.info.weight : -1.0);
    });
  });
  for (const rooms::Door& d : doors)
    if (d.z_m >= z_min_m && d.z_m < z_max_m)
      std::fprintf(f, "D %.6f %.6f %.6f %.6f %.6f\n", d.a.x(), d.a.y(), d.b.x(), d.b.y(), d.z_m);
  return std::fclose(f) == 0;
}

// --door-oracle-m: every place-place edge whose ends lie in two different ground-truth rooms gets clearance
// clearance_m, and the rooms (and building) of the earlier run leave the graph so the finder can run again.
// Returns the number of edges changed.
std::size_t apply_door_oracle(const Raster& ras, double clearance_m, sg::SceneGraph* g) {
  std::map<sg::NodeId, std::int32_t> truth;
  std::vector<sg::NodeId> remove;
  g->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind == sg::NodeKind::kRoom || n.kind == sg::NodeKind::kBuilding) remove.push_back(n.id);
    if (n.kind != sg::NodeKind::kPlace) return;
    int c, r;
    truth[n.id] = ras.cell_of(g->place(n.id)->position_m, &c, &r) ? truth_near(ras, c, r) : 0;
  });
  for (sg::NodeId id : remove) g->remove_node(id);
  std::vector<std::pair<sg::NodeId, sg::NodeId>> doors;
  for (const auto& entry : truth) {
    const sg::NodeId id = entry.first;
    const std::int32_t t = entry.second;  // a plain variable: C++17 lambdas cannot capture structured bindings
    if (t <= 0) continue;
    g->for_each_neighbor(id, [&](sg::NodeId other, const sg::EdgeRecord&) {
      const auto o = truth.find(other);
      if (other > id && o != truth.end() && o->second > 0 && o->second != t) doors.emplace_back(id, other);
    });
  }
  for (const auto& [a, b] : doors) {
    sg::EdgeAttributes* e = g->edge_info(a, b);
    e->weighted = true;
    e->weight = clearance_m;
  }
  return doors.size();
}

using Score = bench::RoomSegmentationScore;

// Left: the estimated rooms, right: the ground truth, each room a colour from its id (black: occupied, grey: free but
// unlabelled).
void write_image(const Raster& ras, const std::string& path, const std::vector<rooms::Door>& doors = {}) {
  cv::Mat out(ras.rows, 2 * ras.cols + 10, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto colour = [](std::int32_t id) {
    const std::uint32_t h = static_cast<std::uint32_t>(id) * 2654435761u;
    return cv::Vec3b(static_cast<std::uint8_t>(60 + (h & 0x7f)), static_cast<std::uint8_t>(60 + ((h >> 8) & 0x7f)),
                     static_cast<std::uint8_t>(60 + ((h >> 16) & 0x7f)));
  };
  for (int r = 0; r < ras.rows; ++r)
    for (int c = 0; c < ras.cols; ++c) {
      const std::size_t k = ras.idx(c, r);
      const cv::Vec3b free_grey(200, 200, 200);
      out.at<cv::Vec3b>(r, c) = !ras.free[k] ? cv::Vec3b(0, 0, 0) : ras.estimate[k] > 0 ? colour(ras.estimate[k]) : free_grey;
      out.at<cv::Vec3b>(r, ras.cols + 10 + c) =
          !ras.free[k] ? cv::Vec3b(0, 0, 0) : ras.truth[k] > 0 ? colour(ras.truth[k] + 1000) : free_grey;
    }
  // Doors found on the robot's surface (--doors), in red on both halves.
  for (const rooms::Door& d : doors) {
    const auto px = [&](const Eigen::Vector2d& p, int offset) {
      return cv::Point(static_cast<int>(std::floor((p.x() - ras.origin_m.x()) / ras.res_m)) + offset,
                       ras.rows - 1 - static_cast<int>(std::floor((p.y() - ras.origin_m.y()) / ras.res_m)));
    };
    for (const int offset : {0, ras.cols + 10}) cv::line(out, px(d.a, offset), px(d.b, offset), cv::Scalar(0, 0, 255), 2);
  }
  if (!cv::imwrite(path, out)) std::fprintf(stderr, "cannot write %s\n", path.c_str());
}


struct RunStats {
  std::size_t keyframes = 0, places = 0, rooms = 0;
  double tour_m = 0.0, rooms_ms = 0.0, dilation_m = 0.0, wall_s = 0.0;
  std::size_t unreachable = 0;
  std::size_t peeked = 0;                     // unreachable rooms the tour looked into
  std::vector<std::int32_t> unreachable_ids;  // world rooms outside the start's free-space component
  std::vector<rooms::Door> doors;             // --doors: the doors found on the robot's surface
  std::size_t door_edges_closed = 0;
  // ... and those edges as they were before (the Hydra peer runs on the graph without the door stage).
  std::vector<std::pair<std::pair<sg::NodeId, sg::NodeId>, sg::EdgeAttributes>> uncut_edges;
  double door_ms = 0.0;                       // the door stage's wall time (find_doors + cut_place_edges)
  std::vector<rooms::Door> online_doors;      // --doors online: the DoorSet when the exploration ended
  std::vector<double> pass_ms;                // ... each window pass's wall time
  std::size_t wall_tiles = 0;                 // ... the wall map's tiles in use
  std::size_t passes_climbing = 0;            // ... passes skipped on stairs
  std::size_t doors_added = 0;                // ... doors new to the set, summed over passes
  std::size_t doors_dropped = 0;              // ... doors dropped (online_misses_to_drop missed passes)
  std::size_t doors_kept_missed = 0;          // ... kept doors a pass missed, still kept
  std::size_t doors_bypassed = 0;             // ... found doors the window's places went round (not kept)
  // The doors the room finder read (final stage, or online), against the ground truth (IPA plans): a door whose two
  // sides lie in two ground-truth rooms separates rooms; one with both sides in the same room is a false door (it
  // can only split that room); unknown: a side in no room (outside, or unlabelled free space).
  std::size_t doors_between = 0, doors_inside = 0, doors_unknown = 0;
  // The room finder's sight lines (the final door stage's; with --doors online the last window pass's), and the
  // rooms it merged.
  std::shared_ptr<rooms::WallSight> sight;
  std::size_t visible_merges = 0;
};

// --doors online: the last window pass's sight lines (raster and structure mask), cached beside the doors as lo.x
// lo.y cell_m z (doubles), cols rows (int32), then cols x rows bytes.
bool write_window(const rooms::DoorRaster& r, const std::uint8_t* structure, double z, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  const double head[4] = {r.lo.x(), r.lo.y(), r.cell_m, z};
  const std::int32_t size[2] = {r.cols, r.rows};
  const bool ok = std::fwrite(head, sizeof(head), 1, f) == 1 && std::fwrite(size, sizeof(size), 1, f) == 1 &&
                  std::fwrite(structure, 1, r.cells(), f) == r.cells();
  return std::fclose(f) == 0 && ok;
}

bool read_window(const std::string& path, rooms::DoorRaster* r, std::vector<std::uint8_t>* structure, double* z) {
  std::ifstream in(path, std::ios::binary);
  double head[4];
  std::int32_t size[2];
  if (!in.read(reinterpret_cast<char*>(head), sizeof(head)) || !in.read(reinterpret_cast<char*>(size), sizeof(size)))
    return false;
  if (size[0] <= 0 || size[1] <= 0 || size[0] > 100000 || size[1] > 100000 || !(head[2] > 0.0)) return false;
  r->lo = Eigen::Vector2d(head[0], head[1]);
  r->cell_m = head[2];
  r->cols = size[0];
  r->rows = size[1];
  *z = head[3];
  structure->resize(r->cells());
  return static_cast<bool>(
      in.read(reinterpret_cast<char*>(structure->data()), static_cast<std::streamsize>(r->cells())));
}

// --doors online: a run's online doors, cached beside its graph as 5 doubles a door (a.x a.y b.x b.y z).
bool write_doors(const std::vector<rooms::Door>& doors, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  bool ok = true;
  for (const rooms::Door& d : doors) {
    const double v[5] = {d.a.x(), d.a.y(), d.b.x(), d.b.y(), d.z_m};
    ok = ok && std::fwrite(v, sizeof(double), 5, f) == 5;
  }
  return std::fclose(f) == 0 && ok;
}

bool read_doors(const std::string& path, std::vector<rooms::Door>* doors) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  doors->clear();
  double v[5];
  while (in.read(reinterpret_cast<char*>(v), sizeof(v))) {
    rooms::Door d;
    d.a = Eigen::Vector2d(v[0], v[1]);
    d.b = Eigen::Vector2d(v[2], v[3]);
    d.z_m = v[4];
    doors->push_back(d);
  }
  return in.eof() && in.gcount() == 0;
}

// The classical 2D segmentations of the complete plan (IPA plans), scored like ours: the peers that see everything.
struct Peers {
  Score distance, distance_plateau, erosion;
  double distance_level_m = 0.0, distance_plateau_level_m = 0.0, erosion_level_m = 0.0;
  // Hydra's room clustering (rooms::Config::paper(): one plateau dilation for the graph, 15-place components, no
  // extent split) on the same explored places, without the door stage (the paper has none): the peer that sees what
  // our robot saw. Not run with --door-oracle-m.
  Score hydra;
  bool has_hydra = false;
  double hydra_dilation_m = 0.0;
};

// The robot's surface: the vertices of its reconstructed mesh (archive and active window), as float x y z triples in
// a raw file beside the cached graph.
bool write_surface(const std::vector<Eigen::Vector3f>& surface, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  const bool ok = surface.empty() || std::fwrite(surface.data(), sizeof(Eigen::Vector3f), surface.size(), f) == surface.size();
  return std::fclose(f) == 0 && ok;
}

bool read_surface(const std::string& path, std::vector<Eigen::Vector3f>* surface) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return false;
  const std::streamsize bytes = in.tellg();
  if (bytes < 0 || bytes % static_cast<std::streamsize>(sizeof(Eigen::Vector3f)) != 0) return false;
  surface->resize(static_cast<std::size_t>(bytes) / sizeof(Eigen::Vector3f));
  in.seekg(0);
  return static_cast<bool>(in.read(reinterpret_cast<char*>(surface->data()), bytes));
}

bool run_rooms(const Options& opt, const std::string& name, sg::SceneGraph* graph, RunStats* stats);

// The room finder reading the online doors (--doors online), or plain run_rooms.
bool run_rooms_with_doors(const Options& opt, const std::string& name, sg::SceneGraph* graph, RunStats* stats);

// --doors: detect doors on the robot's surface and close the place edges that cross them.
bool apply_doors(const Options& opt, const std::string& name, const std::vector<Eigen::Vector3f>& surface,
                 sg::SceneGraph* graph, RunStats* stats) {
  if (!opt.doors) return true;
  std::vector<rooms::Door>* found = &stats->doors;
  if (surface.empty()) {
    std::fprintf(stderr, "%s: --doors needs the robot's surface (a cache without .surface.f32 files: explore again)\n",
                 name.c_str());
    return false;
  }
  rooms::DoorStats ds;
  std::string error;
  const auto t0 = std::chrono::steady_clock::now();
  stats->sight = std::make_shared<rooms::WallSight>();
  if (!rooms::find_doors(surface, *graph, opt.door, found, &ds, &error, stats->sight.get())) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), error.c_str());
    return false;
  }
  std::vector<std::pair<std::pair<sg::NodeId, sg::NodeId>, sg::EdgeAttributes>> before;
  graph->for_each_edge([&](const sg::EdgeRecord& e) {
    if (graph->place(e.source) != nullptr && graph->place(e.target) != nullptr)
      before.push_back({{e.source, e.target}, e.info});
  });
  stats->door_edges_closed = rooms::cut_place_edges(*found, opt.door, graph);
  const std::size_t through_walls =
      opt.door.sight_cut_edges ? rooms::cut_edges_through_walls(*stats->sight, graph) : 0;
  stats->uncut_edges.clear();
  for (const auto& [ends, info] : before) {
    const sg::EdgeAttributes* now = graph->edge_info(ends.first, ends.second);
    if (now != nullptr && (now->weighted != info.weighted || now->weight != info.weight))
      stats->uncut_edges.push_back({ends, info});
  }
  stats->door_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  %s: doors: %zu (%zu candidates, %zu gone round by the places) in %zu storey slice(s), %zu place "
              "edges closed, %zu more through walls, %.0f ms\n",
              name.c_str(), found->size(), ds.candidates, ds.bypassed, ds.slices, stats->door_edges_closed,
              through_walls, stats->door_ms);
  return true;
}

// Explores, reconstructs, runs the frontend every keyframe, the door stage (--doors) and the room finder at the end.
// *surface: the robot's mesh vertices (from the cache when the graph comes from there; empty when the cache has
// none). world_seed seeds the odometry's drift (--odometry).
bool run_pipeline(const Options& opt, const world::World& w, std::uint64_t world_seed, const std::string& plan_key,
                  sg::SceneGraph* graph, std::vector<Eigen::Vector3f>* surface, RunStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  const std::string odometry_key =
      opt.odometry.ground_truth()
          ? std::string()
          : std::string(".odom-") + sim::to_string(opt.odometry.level) + "-" + std::to_string(opt.odometry.seed);
  const std::string key = plan_key + (opt.look_into_unreachable ? ".peek" : "") + odometry_key;
  const std::string cache_path = opt.cache_dir.empty() ? "" : opt.cache_dir + "/" + key + ".json";
  const std::string surface_path = opt.cache_dir.empty() ? "" : opt.cache_dir + "/" + key + ".surface.f32";
  // The online doors depend on the pass settings, so those name the file: a cache explored with other settings is
  // not read back as if it were this one (the --door-* detector flags are not in the name: change them in a new
  // cache dir).
  char online_settings[96];
  std::snprintf(online_settings, sizeof online_settings, ".every%d.misses%d.match%.2f", opt.online_every,
                opt.door.online_misses_to_drop, opt.door.online_match_m);
  const std::string doors_path =
      opt.cache_dir.empty() ? "" : opt.cache_dir + "/" + key + ".online_doors" + online_settings + ".f64";
  sim::ExplorationConfig ec;
  ec.robot_radius_m = opt.robot_radius_m;
  ec.look_into_unreachable_rooms = opt.look_into_unreachable;
  sim::SimCamera::Config cc;
  cc.intrinsics = bench::camera_of_fov(opt.width, opt.height, opt.hfov_deg);
  cc.rate_hz = opt.rate_hz;
  bench::SimTour sim_tour;
  std::string error;
  if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &sim_tour, &error)) {
    std::fprintf(stderr, "%s: %s\n", w.name.c_str(), error.c_str());
    return false;
  }
  bench::set_odometry(opt.odometry, world_seed, &sim_tour);
  const sim::ExplorationResult& tour = sim_tour.tour;
  stats->tour_m = tour.length_m;
  stats->unreachable = tour.unreachable_rooms.size();
  stats->unreachable_ids = tour.unreachable_rooms;
  stats->peeked = tour.peeked_rooms.size();
  if (!cache_path.empty() && std::ifstream(cache_path).good()) {
    const sg::JsonImportResult in = sg::read_spark_dsg_json_file(cache_path, *graph);
    if (!in.ok) {
      std::fprintf(stderr, "%s: %s\n", cache_path.c_str(), in.error.c_str());
      return false;
    }
    if (!read_surface(surface_path, surface)) surface->clear();
    if (opt.online_doors && !read_doors(doors_path, &stats->online_doors)) {
      std::fprintf(stderr, "%s: --doors online needs %s (a cache made without --doors online, or with other online settings: "
                   "explore again in a new cache dir)\n",
                   w.name.c_str(), doors_path.c_str());
      return false;
    }
    if (opt.online_doors) {
      // The last window's sight lines (caches from before they existed have none: no sight lines).
      rooms::DoorRaster window;
      std::vector<std::uint8_t> structure;
      double slice_z = 0.0;
      if (read_window(doors_path + ".sight", &window, &structure, &slice_z)) {
        stats->sight = std::make_shared<rooms::WallSight>();
        if (!stats->sight->add_structure(window, structure.data(), slice_z, opt.door, &error, /*window=*/true))
          std::fprintf(stderr, "%s: online sight lines: %s\n", w.name.c_str(), error.c_str());
      } else {
        std::printf("  %s: no %s.sight in the cache: the online rooms without sight lines\n", w.name.c_str(),
                    doors_path.c_str());
      }
    }
    if (!apply_doors(opt, w.name, *surface, graph, stats)) return false;
    const bool ok = run_rooms_with_doors(opt, w.name, graph, stats);
    stats->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return ok;
  }
  auto tsdf = std::make_unique<reconstruction::SemanticTsdf>();
  if (!tsdf->init(reconstruction::Config{}, reconstruction::capacities_from_budget(),
                  budgets::active::reconstruction::kArenaBytes, &error)) {
    std::fprintf(stderr, "tsdf: %s\n", error.c_str());
    return false;
  }
  auto fe = std::make_unique<frontend::Frontend>();
  frontend::Config fc;
  fc.places = opt.places;
  if (!fe->init(fc, &error)) {
    std::fprintf(stderr, "frontend: %s\n", error.c_str());
    return false;
  }
  // --doors online: the app's online door stage, sized by the board's "doors" arena.
  std::unique_ptr<rooms::OnlineDoors> online;
  std::vector<std::uint32_t> painted_stamp;
  std::vector<memory::Index3> painted_block;
  if (opt.online_doors) {
    online = std::make_unique<rooms::OnlineDoors>();
    if (!online->init(opt.door, rooms::OnlineDoorCapacities::from_budget(), budgets::active::doors::kArenaBytes,
                      &error)) {
      std::fprintf(stderr, "doors: %s\n", error.c_str());
      return false;
    }
    painted_stamp.assign(tsdf->block_slots(), 0u);
    painted_block.assign(tsdf->block_slots(), memory::Index3{});
  }
  const auto pass = [&](const Eigen::Vector3d& robot) {
    const auto t0 = std::chrono::steady_clock::now();
    online->begin_pass(robot);
    online->add_places(*graph);
    online->rasterize();
    const rooms::PassResult pr = online->detect();
    if (pr.climbing) ++stats->passes_climbing;
    if (!pr.ran) return;
    stats->doors_added += pr.added;
    stats->doors_dropped += pr.removed;
    stats->doors_kept_missed += pr.missed;
    stats->doors_bypassed += pr.bypassed;
    stats->pass_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  };
  auto frame = std::make_unique<messages::RgbdFrame>();
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  std::uint64_t t_last = 0;
  std::size_t frontend_updates = 0;
  stats->keyframes = bench::for_each_posed_frame(
      sim_tour, *frame,
      [&](const messages::RgbdFrame& f, const Eigen::Isometry3d& T, std::int64_t t_ns, const Eigen::Isometry3d&) {
        tsdf->process(f, T);
        if (online) online->wall_map().repaint(*tsdf, painted_stamp.data(), painted_block.data(), painted_stamp.size());
        fe->add_keyframe(graph, static_cast<std::uint64_t>(t_ns), T);
        fe->update(*tsdf, T.translation(), static_cast<std::uint64_t>(t_ns), graph, frontend::Deadline{});
        if (online && frontend_updates++ % static_cast<std::size_t>(opt.online_every) == 0) pass(T.translation());
        last = T.translation();
        t_last = static_cast<std::uint64_t>(t_ns);
      });
  for (int i = 0; i < 100; ++i)
    if (fe->update(*tsdf, last, t_last, graph, frontend::Deadline{}).places_complete) break;
  if (online) {
    pass(last);  // the latest places, as the app's last backend update sees them
    for (std::size_t i = 0; i < online->doors().size(); ++i) stats->online_doors.push_back(online->doors()[i]);
    // The last pass's window sight lines, as the app's room finder reads them (OnlineDoors::sight).
    const rooms::WallSight& window = online->sight();
    if (window.slices() > 0) {
      stats->sight = std::make_shared<rooms::WallSight>();
      if (!stats->sight->add_structure(window.raster(0), window.structure(0), window.slice_z(0), opt.door, &error,
                                       /*window=*/true))
        std::fprintf(stderr, "%s: online sight lines: %s\n", w.name.c_str(), error.c_str());
      if (!doors_path.empty() &&
          !write_window(window.raster(0), window.structure(0), window.slice_z(0), doors_path + ".sight"))
        std::fprintf(stderr, "cache: cannot write %s.sight\n", doors_path.c_str());
    }
    stats->wall_tiles = online->wall_map().tile_stats().in_use;
    std::sort(stats->pass_ms.begin(), stats->pass_ms.end());
    std::printf("  %s: online doors: %zu after %zu window passes (median %.1f ms, max %.1f ms; %zu skipped on stairs), "
                "%zu wall tiles; over the passes %zu doors added, %zu dropped, %zu kept through a miss, %zu found doors "
                "gone round by the places\n",
                w.name.c_str(), stats->online_doors.size(), stats->pass_ms.size(),
                stats->pass_ms.empty() ? 0.0 : stats->pass_ms[stats->pass_ms.size() / 2],
                stats->pass_ms.empty() ? 0.0 : stats->pass_ms.back(), stats->passes_climbing, stats->wall_tiles,
                stats->doors_added, stats->doors_dropped, stats->doors_kept_missed, stats->doors_bypassed);
    if (!doors_path.empty() && !write_doors(stats->online_doors, doors_path))
      std::fprintf(stderr, "cache: cannot write %s\n", doors_path.c_str());
  }
  {
    reconstruction::Mesh mesh;
    tsdf->extract_full_mesh(&mesh);
    surface->clear();
    surface->reserve(mesh.vertices.size());
    for (const reconstruction::MeshVertex& v : mesh.vertices) surface->emplace_back(v.x, v.y, v.z);
  }
  if (!cache_path.empty() && !sg::write_spark_dsg_json_file(*graph, cache_path, &error))
    std::fprintf(stderr, "cache: %s\n", error.c_str());
  if (!surface_path.empty() && !write_surface(*surface, surface_path))
    std::fprintf(stderr, "cache: cannot write %s\n", surface_path.c_str());
  if (!apply_doors(opt, w.name, *surface, graph, stats)) return false;
  const bool ok = run_rooms_with_doors(opt, w.name, graph, stats);
  stats->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return ok;
}

bool run_rooms(const Options& opt, const std::string& name, sg::SceneGraph* graph, RunStats* stats,
               const rooms::DoorSet* doors);

bool run_rooms_with_doors(const Options& opt, const std::string& name, sg::SceneGraph* graph, RunStats* stats) {
  if (!opt.online_doors) return run_rooms(opt, name, graph, stats, nullptr);
  memory::Arena arena;
  rooms::DoorSet set;
  const memory::ArenaPlan plan = rooms::DoorSet::plan(std::max<std::size_t>(1, stats->online_doors.size()));
  std::string error;
  if (!arena.create("online_doors", plan, plan.total_bytes(), &error) ||
      !set.carve(arena, std::max<std::size_t>(1, stats->online_doors.size()), opt.door)) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), error.c_str());
    return false;
  }
  for (const rooms::Door& d : stats->online_doors) set.add(d);
  return run_rooms(opt, name, graph, stats, &set);
}

bool run_rooms(const Options& opt, const std::string& name, sg::SceneGraph* graph, RunStats* stats) {
  return run_rooms(opt, name, graph, stats, nullptr);
}

// The room finder on the final graph (five updates, the median time reported); `doors` closes the place edges
// through them (--doors online).
bool run_rooms(const Options& opt, const std::string& name, sg::SceneGraph* graph, RunStats* stats,
               const rooms::DoorSet* doors) {
  std::string error;
  const std::uint64_t time_ns = 0;  // room timestamps do not matter here

  auto finder = std::make_unique<rooms::RoomFinder>();
  if (!finder->init(opt.rooms, rooms::Capacities::from_scene_graph(graph->capacities()), 0, &error)) {
    std::fprintf(stderr, "rooms: %s\n", error.c_str());
    return false;
  }
  std::vector<double> ms;
  rooms::UpdateResult r;
  // Sight lines: the final door stage's, or with the online doors the last window pass's (as the app reads them).
  const rooms::WallSight* sight = stats->sight ? stats->sight.get() : nullptr;
  for (int i = 0; i < 5; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    r = finder->update(graph, time_ns, doors, sight);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::printf("  %s: Betti curve (delta m: components):", name.c_str());
  for (std::size_t i = 0; i < finder->curve_size(); i += 5) std::printf(" %.2f:%u", finder->dilation_at(i), finder->betti_at(i));
  std::printf("\n");
  if (sight != nullptr)
    std::printf("  %s: sight lines: %zu rooms merged into a room they see (%zu of them near the boundary only; %zu "
                "room pairs tested; %zu place pairs in two rooms touching in sight, %zu dropped), %zu open place "
                "edges read as closed through walls\n",
                name.c_str(), r.visible_merges, r.visible_near_merges, r.visible_pairs, r.visible_touching_pairs,
                r.visible_touching_dropped, r.edges_through_walls);
  stats->visible_merges = r.visible_merges;
  stats->places = r.places;
  stats->rooms = r.rooms;
  stats->rooms_ms = median(ms);
  stats->dilation_m = r.dilation_m;
  if (r.outcome != rooms::Outcome::kOk)
    std::fprintf(stderr, "%s: rooms: %s (%zu places)\n", name.c_str(), rooms::to_string(r.outcome), r.places);
  return true;
}

// The Hydra peer (Peers::hydra): the door stage's cuts undone and our rooms removed, then the paper's room
// clustering on the same graph. The graph is left with the peer's rooms, so call it after everything that reads ours.
bool run_hydra_peer(const std::string& name, const RunStats& st, sg::SceneGraph* graph, double* dilation_m) {
  for (const auto& [ends, info] : st.uncut_edges)
    if (sg::EdgeAttributes* e = graph->edge_info(ends.first, ends.second)) *e = info;
  std::vector<sg::NodeId> ours;
  graph->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind == sg::NodeKind::kRoom || n.kind == sg::NodeKind::kBuilding) ours.push_back(n.id);
  });
  for (const sg::NodeId id : ours) graph->remove_node(id);
  auto finder = std::make_unique<rooms::RoomFinder>();
  std::string error;
  if (!finder->init(rooms::Config::paper(), rooms::Capacities::from_scene_graph(graph->capacities()), 0, &error)) {
    std::fprintf(stderr, "%s: Hydra peer: %s\n", name.c_str(), error.c_str());
    return false;
  }
  const rooms::UpdateResult r = finder->update(graph, 0, nullptr);
  *dilation_m = r.dilation_m;
  if (r.outcome != rooms::Outcome::kOk)
    std::fprintf(stderr, "%s: Hydra peer: %s (%zu places)\n", name.c_str(), rooms::to_string(r.outcome), r.places);
  return true;
}

void print_line(const std::string& name, const Score& s, const RunStats& st) {
  std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | places %zu, delta* %.2f m, "
              "rooms update %.2f ms, %zu keyframes, tour %.0f m, %zu unreachable (%zu looked into), %.0f s\n",
              name.c_str(), s.precision_mean, s.recall_mean, s.precision_area, s.recall_area, s.rooms_found,
              s.rooms_truth, st.places, st.dilation_m, st.rooms_ms, st.keyframes, st.tour_m, st.unreachable,
              st.peeked, st.wall_s);
  std::fflush(stdout);
}

// *peers: the classical distance-transform (its level by the most regions, and by the alpha plateau of their curve)
// and morphological segmentations of the complete plan (the benchmark's own occupancy image, furniture included in
// the furnished variant), scored the same way.
void print_peer(const std::string& name, const Score& s, const char* level_name, double level_m) {
  std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | complete plan, %s %.2f m\n",
              name.c_str(), s.precision_mean, s.recall_mean, s.precision_area, s.recall_area, s.rooms_found,
              s.rooms_truth, level_name, level_m);
}

// Each door against the ground truth (RunStats::doors_between / doors_inside / doors_unknown): the first free cell
// with a ground-truth room on each side of the line's midpoint, along its normal from 0.15 m to 1 m out.
void check_doors(const Raster& ras, const std::vector<rooms::Door>& doors, RunStats* st) {
  for (const rooms::Door& d : doors) {
    const Eigen::Vector2d mid = 0.5 * (d.a + d.b);
    const Eigen::Vector2d u = (d.b - d.a).normalized();
    const Eigen::Vector2d n(-u.y(), u.x());
    std::int32_t side[2] = {0, 0};
    for (int k = 0; k < 2; ++k)
      for (double t = 0.15; t <= 1.0 + 1e-9 && side[k] == 0; t += ras.res_m) {
        const Eigen::Vector2d p = mid + (k == 0 ? t : -t) * n;
        int c, r;
        if (!ras.cell_of(Eigen::Vector3d(p.x(), p.y(), 0.0), &c, &r)) break;
        if (ras.free[ras.idx(c, r)] && ras.truth[ras.idx(c, r)] > 0) side[k] = ras.truth[ras.idx(c, r)];
      }
    if (side[0] == 0 || side[1] == 0) ++st->doors_unknown;
    else if (side[0] == side[1]) ++st->doors_inside;
    else ++st->doors_between;
  }
}

bool eval_plan(const Options& opt, const std::string& map, bool furnished, Score* out, RunStats* st,
               Score* reachable, Score* oracle, Peers* peers) {
  const std::string occ_path = opt.plans_dir + "/" + map + (furnished ? "_furnitures" : "") + ".png";
  const std::string gt_path = world::floor_plan_gt_path(occ_path);
  world::FloorPlanConfig fc;
  fc.furniture_height_m = furnished ? opt.furniture_height_m : 0.0;
  const world::WorldResult wr =
      fc.furniture_height_m > 0.0
          ? world::import_furnished_floor_plan_files(opt.plans_dir + "/" + map + ".png", occ_path, gt_path, fc)
          : world::import_floor_plan_files(occ_path, gt_path, fc);
  if (!wr.ok) {
    std::fprintf(stderr, "%s\n", wr.error.c_str());
    return false;
  }
  auto graph = std::make_unique<sg::SceneGraph>();
  std::string error;
  if (!graph->init(sg::capacities_from_budget(), sg::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "scene graph: %s\n", error.c_str());
    return false;
  }
  char furniture_key[32] = "";
  if (fc.furniture_height_m > 0.0) std::snprintf(furniture_key, sizeof(furniture_key), "_h%.2f", fc.furniture_height_m);
  std::vector<Eigen::Vector3f> surface;
  if (!run_pipeline(opt, wr.world, 0, map + (furnished ? "_furnished" : "_plain") + furniture_key, graph.get(),
                    &surface, st))
    return false;
  // Ground truth straight from the benchmark's image: 8-connected white regions of more than 100 px.
  bench::PlanRaster plan;
  std::string read_error;
  if (!bench::read_plan_raster(occ_path, gt_path, fc, &plan, &read_error)) {
    std::fprintf(stderr, "%s\n", read_error.c_str());
    return false;
  }
  Raster ras;
  ras.cols = plan.cols;
  ras.rows = plan.rows;
  ras.res_m = fc.resolution_m_per_px;
  ras.free = std::move(plan.free);
  ras.truth = std::move(plan.truth);
  if (peers != nullptr) {
    bench::DistanceSegmentationConfig dc;
    dc.resolution_m = ras.res_m;
    bench::MorphologicalSegmentationConfig mc;
    mc.resolution_m = ras.res_m;
    bench::DistanceSegmentationConfig dpc = dc;
    dpc.level = bench::DistanceSegmentationConfig::Level::kPlateau;
    bench::PlanSegmentation by_distance, by_distance_plateau, by_erosion;
    const char* why = nullptr;
    if (!bench::segment_by_distance_transform(ras.free, ras.cols, ras.rows, dc, &by_distance, &why) ||
        !bench::segment_by_distance_transform(ras.free, ras.cols, ras.rows, dpc, &by_distance_plateau, &why) ||
        !bench::segment_by_erosion(ras.free, ras.cols, ras.rows, mc, &by_erosion, &why)) {
      std::fprintf(stderr, "%s: %s\n", map.c_str(), why);
      return false;
    }
    peers->distance = bench::score_room_segmentation(ras.free, ras.truth, by_distance.labels);
    peers->distance_plateau = bench::score_room_segmentation(ras.free, ras.truth, by_distance_plateau.labels);
    peers->erosion = bench::score_room_segmentation(ras.free, ras.truth, by_erosion.labels);
    peers->distance_level_m = by_distance.level_m;
    peers->distance_plateau_level_m = by_distance_plateau.level_m;
    peers->erosion_level_m = by_erosion.level_m;
  }
  if (opt.door_oracle_m >= 0.0) {
    const std::size_t doors = apply_door_oracle(ras, opt.door_oracle_m, graph.get());
    std::printf("  %s: door oracle: %zu place edges between ground-truth rooms set to %.2f m\n", map.c_str(), doors,
                opt.door_oracle_m);
    if (!run_rooms(opt, map, graph.get(), st)) return false;
  }
  if (oracle != nullptr) {
    label_from_places(*graph, -1e9, 1e9, opt.max_reach_m, &ras, /*oracle=*/true);
    *oracle = score(ras);
  }
  label_from_places(*graph, -1e9, 1e9, opt.max_reach_m, &ras);
  *out = score(ras);
  check_doors(ras, opt.online_doors ? st->online_doors : st->doors, st);
  if (!opt.dump_dir.empty()) {
    const std::string stem = opt.dump_dir + "/" + map + (furnished ? "_furnished" : "_plain");
    dump_places(*graph, ras, stem + ".txt", opt.online_doors ? st->online_doors : st->doors);
    if (!surface.empty() && !write_surface(surface, stem + ".surface.f32"))
      std::fprintf(stderr, "--dump-places: cannot write %s.surface.f32\n", stem.c_str());
  }
  if (!opt.images_dir.empty())
    write_image(ras, opt.images_dir + "/" + map + (furnished ? "_furnished" : "_plain") + "_rooms.png", st->doors);
  // The same score over the rooms the robot could enter: ground-truth rooms the tour could not reach (closed doors
  // in the scan, or doors narrower than the robot) are left out. Each unreachable world room is the ground-truth
  // region holding most of its footprint's cells.
  if (reachable != nullptr) {
    std::set<std::int32_t> excluded;
    for (const std::int32_t id : st->unreachable_ids) {
      const world::Room* room = nullptr;
      for (const world::Room& candidate : wr.world.rooms)
        if (candidate.id == id) room = &candidate;
      if (room == nullptr) continue;
      std::map<std::int32_t, int> votes;
      for (int r = 0; r < ras.rows; ++r)
        for (int c = 0; c < ras.cols; ++c) {
          const std::int32_t t = ras.truth[ras.idx(c, r)];
          if (t <= 0) continue;
          for (const world::Polygon2& poly : room->footprint_m)
            if (world::point_in_polygon(poly, ras.center_of(c, r))) ++votes[t];
        }
      if (!votes.empty())
        excluded.insert(std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
                          return a.second < b.second;
                        })->first);
    }
    Raster masked = ras;
    for (std::int32_t& t : masked.truth)
      if (excluded.count(t) != 0) t = 0;
    *reachable = score(masked);
  }
  if (peers != nullptr && opt.door_oracle_m < 0.0) {
    if (!run_hydra_peer(map, *st, graph.get(), &peers->hydra_dilation_m)) return false;
    label_from_places(*graph, -1e9, 1e9, opt.max_reach_m, &ras);
    peers->hydra = score(ras);
    peers->has_hydra = true;
  }
  return true;
}

// Room labels on a generated building (whose rooms have known types): the room classifier (the neural tree blended
// with its LR head) labels the graph's rooms as the app does (objects in the room of the place they hang from,
// room-room edges), and each estimated room is scored against the ground-truth room that holds most of its places.
struct LabelScore {
  std::size_t rooms = 0, correct = 0, unknown = 0;
  std::map<std::string, std::size_t> confusions;  // "truth -> predicted"
  std::size_t truth_rooms = 0, truth_correct = 0;  // the classifier on the world's own rooms and objects
  std::size_t truth_unknown = 0;  // rooms the classifier left "unknown" (no objects, or below min_probability)
  std::map<std::string, std::size_t> truth_confusions;
  std::map<std::string, std::pair<std::size_t, std::size_t>> truth_per_type;  // type -> (correct, rooms)
  // Objects inside a ground-truth room with a parent place, and those whose parent place is in the same room
  // (the room the classifier then sees the object in follows that place).
  std::size_t objects = 0, objects_in_own_room = 0;
};

neural_tree::RoomClassifier& shared_classifier() {
  static neural_tree::RoomClassifier classifier;
  static bool tried = false;
  if (!tried) {
    tried = true;
    std::string error;
    if (!classifier.init(&error)) std::fprintf(stderr, "room labels: %s\n", error.c_str());
  }
  return classifier;
}

// The same classifier on the generator's ground truth (room footprints, object boxes, doors as room-room edges):
// what the labels can reach when rooms and objects are perfect.
void label_truth_rooms(const world::World& w, LabelScore* out) {
  neural_tree::RoomClassifier& classifier = shared_classifier();
  if (!classifier.ready()) return;
  neural_tree::ObjectRoomGraph input;
  std::map<std::int32_t, int> node_of_room;
  for (const world::Room& room : w.rooms) {
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e9), hi = -lo;
    for (const world::Polygon2& poly : room.footprint_m)
      for (const Eigen::Vector2d& v : poly) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
    const Eigen::Vector2d c = 0.5 * (lo + hi);
    node_of_room[room.id] = input.add_room(Eigen::Vector3d(c.x(), c.y(), room.floor_z_m + 0.5 * room.height_m),
                                           Eigen::Vector3d(hi.x() - lo.x(), hi.y() - lo.y(), room.height_m));
  }
  for (const world::Object& o : w.objects) {
    const auto room = node_of_room.find(o.room_id);
    if (room == node_of_room.end()) continue;
    const Eigen::Vector3d extent = o.box.world_R_box.toRotationMatrix().cwiseAbs() * (2.0 * o.box.half_extents_m);
    input.add_object(room->second, classifier.word_index(o.label, extent), o.box.center_m, extent);
  }
  for (const world::Door& d : w.doors) {
    const auto a = node_of_room.find(d.room_a), b = node_of_room.find(d.room_b);
    if (a != node_of_room.end() && b != node_of_room.end()) input.add_edge(a->second, b->second);
  }
  std::string error;
  if (!classifier.classify(input, &error)) return;
  for (const neural_tree::RoomPrediction& p : classifier.predictions())
    for (const world::Room& room : w.rooms)
      if (node_of_room[room.id] == p.node) {
        const std::string want = semantics::room_label_name(room.label);
        ++out->truth_rooms;
        out->truth_correct += p.label == room.label ? 1 : 0;
        out->truth_unknown += p.label == semantics::kRoomUnknown ? 1 : 0;
        auto& per_type = out->truth_per_type[want];
        ++per_type.second;
        per_type.first += p.label == room.label ? 1 : 0;
        if (p.label != room.label) ++out->truth_confusions[want + " -> " + semantics::room_label_name(p.label)];
      }
}

bool label_rooms(const world::World& w, const sg::SceneGraph& g, LabelScore* out) {
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kObject || n.parent == sg::kNoNode || g.place(n.parent) == nullptr) return;
    const Eigen::Vector3d& o = g.object(n.id)->position_m;
    const Eigen::Vector3d& p = g.place(n.parent)->position_m;
    const std::int32_t t = world::room_at(w, o.x(), o.y(), o.z());
    if (t < 0) return;
    ++out->objects;
    out->objects_in_own_room += world::room_at(w, p.x(), p.y(), p.z()) == t ? 1 : 0;
  });
  neural_tree::RoomClassifier& classifier = shared_classifier();
  std::string error;
  if (!classifier.ready()) return false;
  neural_tree::ObjectRoomGraph input;
  std::map<sg::NodeId, int> node_of_room;
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kRoom) return;
    const sg::RoomAttributes* a = g.room(n.id);
    const bool box = a->bounding_box.type != sg::BoundingBox::Type::kInvalid;
    node_of_room[n.id] = input.add_room(
        a->position_m, box ? Eigen::Vector3d(a->bounding_box.max_m - a->bounding_box.min_m) : Eigen::Vector3d::Zero());
  });
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kObject || n.parent == sg::kNoNode) return;
    const auto room = node_of_room.find(g.parent(n.parent));
    if (room == node_of_room.end()) return;
    const sg::ObjectAttributes* o = g.object(n.id);
    const Eigen::Vector3d size = o->bounding_box.max_m - o->bounding_box.min_m;
    input.add_object(room->second, classifier.word_index(static_cast<semantics::Label>(o->semantic_label), size),
                     o->position_m, size);
  });
  g.for_each_edge([&](const sg::EdgeRecord& e) {
    const auto a = node_of_room.find(e.source), b = node_of_room.find(e.target);
    if (a != node_of_room.end() && b != node_of_room.end()) input.add_edge(a->second, b->second);
  });
  if (!classifier.classify(input, &error)) {
    std::fprintf(stderr, "room labels: %s\n", error.c_str());
    return false;
  }
  std::map<int, semantics::RoomLabel> predicted;
  for (const neural_tree::RoomPrediction& p : classifier.predictions()) predicted[p.node] = p.label;
  std::map<std::int32_t, semantics::RoomLabel> truth_label;
  for (const world::Room& room : w.rooms) truth_label[room.id] = room.label;
  for (const auto& [room_id, node] : node_of_room) {
    std::map<std::int32_t, int> votes;
    g.for_each_child(room_id, [&](sg::NodeId child) {
      if (sg::node_prefix(child) != sg::kPlacePrefix) return;
      const Eigen::Vector3d& p = g.place(child)->position_m;
      const std::int32_t t = world::room_at(w, p.x(), p.y(), p.z());
      if (t >= 0) ++votes[t];
    });
    if (votes.empty()) continue;
    const std::int32_t truth = std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
                                 return a.second < b.second;
                               })->first;
    const semantics::RoomLabel want = truth_label[truth], got = predicted[node];
    ++out->rooms;
    out->correct += got == want ? 1 : 0;
    out->unknown += got == semantics::kRoomUnknown ? 1 : 0;
    if (got != want)
      ++out->confusions[std::string(semantics::room_label_name(want)) + " -> " + semantics::room_label_name(got)];
  }
  return true;
}

bool eval_generated(const Options& opt, std::uint64_t seed, Score* out, RunStats* st, LabelScore* labels,
                    Score* oracle, Score* hydra) {
  world::BuildingConfig bc;
  bc.seed = seed;
  bc.num_rooms = opt.generated_rooms;
  bc.two_floors = true;
  world::World w = world::generate_building(bc);
  w.name = "generated_two_floor_" + std::to_string(seed);
  auto graph = std::make_unique<sg::SceneGraph>();
  std::string error;
  if (!graph->init(sg::capacities_from_budget(), sg::arena_bytes_from_budget(), &error)) return false;
  std::vector<Eigen::Vector3f> surface;
  if (!run_pipeline(opt, w, seed, w.name, graph.get(), &surface, st)) return false;
  label_rooms(w, *graph, labels);
  label_truth_rooms(w, labels);
  std::vector<bench::FloorRaster> floor_rasters = bench::generated_floor_rasters(w, bc);
  Score total, bound;
  for (bench::FloorRaster& f : floor_rasters) {
    Raster& ras = f.raster;
    const double z_lo = f.z_min_m, z_hi = f.z_max_m;
    label_from_places(*graph, z_lo, z_hi, opt.max_reach_m, &ras, /*oracle=*/true);
    bound.add(score(ras));
    label_from_places(*graph, z_lo, z_hi, opt.max_reach_m, &ras);
    total.add(score(ras));
    const std::string stem = w.name + "_floor" + std::to_string(f.floor_index);
    if (!opt.dump_dir.empty())
      dump_places(*graph, ras, opt.dump_dir + "/" + stem + ".txt", opt.online_doors ? st->online_doors : st->doors,
                  z_lo, z_hi);
    if (!opt.images_dir.empty()) write_image(ras, opt.images_dir + "/" + stem + "_rooms.png", st->doors);
  }
  *out = total;
  *oracle = bound;
  if (hydra != nullptr) {
    double dilation_m = 0.0;
    if (!run_hydra_peer(w.name, *st, graph.get(), &dilation_m)) return false;
    *hydra = bench::score_generated_rooms(*graph, &floor_rasters, opt.max_reach_m);
  }
  return true;
}

}  // namespace

const char kDetails[] = R"(
Rooms of the app's pipeline on the IPA floor plans (extruded, plain and furnished) and generated buildings against
the simulator's ground truth, scored as the room-segmentation benchmark does (bench/rooms/floor_plan_rooms.h: mean
and area precision and recall; rooms_eval.*, rooms_eval.ipa.<set>.*).
Exploration and caches:
  --cache-dir DIR keeps each explored graph so room parameters (--set rooms.seeding=plateau,
  --set rooms.min_component_size=N, ...) can be swept in seconds; a cache holds what that build's simulator and
  pipeline explored: make a new one after changing them (and for any --set places.*). The
  tour visits every room it can enter and looks into each room it cannot from the reachable spot that sees most of
  it (sim::ExplorationConfig::look_into_unreachable_rooms; --look-into-unreachable 0 turns it off; caches explored
  with it on are named <plan>.peek); each plan's line counts the unreachable rooms and those looked into, and a
  second line scores only the rooms the tour could reach.
  --furniture-height-m H extrudes the furnished plans' furniture to H instead of the walls' 2.5 m and reports that
  set as furnished_low (the benchmark's own use, and the targets, keep furniture as 2.5 m posts).
Bounds and peers, beside every score:
  the oracle bound (each observed place given its ground-truth room, same rasterization and score: the gap to it is
  the room finder's); on the IPA plans three peers on the complete plan: Bormann et al.'s distance-transform
  segmentation (peer_distance), the same with the threshold chosen per map by the paper's alpha plateau rule over
  [0.5, 1.2] m (peer_distance_plateau), their morphological segmentation (peer_morphological), and ours over theirs
  (...peer_<method>.ours_over_peer.*); on every plan and building Hydra's own room clustering
  (rooms::Config::paper(), the door stage's cuts undone) on the same explored places (peer_hydra, ours over it in
  "ALL peer Hydra"; not run with --door-oracle-m).
Settings: every field of places::Config, rooms::Config and rooms::DoorConfig is --set places.KEY=V,
  rooms.KEY=V or doors.KEY=V (listed below, from their parameter tables); e.g. the room finder's extent split
  (rooms.split_by_extent, rooms.split_min_extent_m, ...), corridor merge (rooms.merge_corridors,
  rooms.corridor_min_neighbours, rooms.corridor_min_open_edges), visibility merge (rooms.merge_visible,
  rooms.visible_min_share, rooms.visible_samples, rooms.visible_local_radius_m 0: off, ...) and touching spheres
  (rooms.visible_touching, rooms.visible_touch_max_clearance_m). Each plan prints the rooms merged (and of them by the boundary test only), the pairs
  tested, the touching place pairs found and dropped, and the open place edges read as closed through walls.
Doors (rooms::DoorConfig): by default the door stage runs as the app's does when a run finishes
  (rooms::find_doors on the robot's own mesh, cached beside each graph as .surface.f32, then cut_place_edges);
  --doors 0 turns it off; --set doors.KEY=V sets DoorConfig, among them doors.bypass_max_m (0: off),
  doors.bypass_extension_m and doors.bypass_max_edge_m (a door the places graph goes round is dropped; each
  plan's doors line counts them). The same slices give the room finder its sight lines (rooms::WallSight):
  doors.sight_min_wall_m, doors.sight_wall_dilation_m, doors.sight_furniture_max_m and
  doors.sight_furniture_min_width_m (thick islands as furniture; 0: off) set what is structure, --sight-cut-edges
  0|1 (doors.sight_cut_edges and rooms.close_edges_through_walls together) the closing of place edges
  that cross it. Each door the room finder read is judged by the ground-truth rooms on its two sides (the first room
  cell 0.15 to 1 m out along its normal): between two rooms, inside one room (a false door) or unknown
  (rooms_eval.ipa.<set>.doors_{between_rooms,inside_a_room,inside_a_room_share}).
  --doors online runs the app's online stage instead: the exploration paints each re-meshed block into the wall map
  and every --online-every N-th frontend update (4, as the app) runs a window pass around the robot
  (doors.online_misses_to_drop and doors.online_match_m, 2 and 0.5 m as the app); the room finder reads the final
  door set and the last pass's sight lines (cached as .sight) and, as in the app, does not merge by visibility
  there (a window's sight lines lowered precision). It writes .online_doors_*,
  online_doors_{added,dropped}_per_pass, online_door_pass_ms_{median,p99,max} and online_wall_tiles_max, and
  caches the doors as .online_doors.every<N>.misses<M>.match<X>.f64 (a cache explored with other online settings is
  refused; change the doors.* detector settings in a new cache dir).
  --door-oracle-m C cuts every place edge between two ground-truth rooms before the scored run on the IPA plans:
  the bound a perfect door and opening detector gives the seeding (add --set rooms.min_persistence_m=9
  --set rooms.min_dilation_m=0.1 --set rooms.split_by_extent=false: one room per connected piece of the cut graph
  with at least rooms.min_component_size places).
Pictures and dumps: --images DIR draws each plan (doors in red); --dump-places DIR writes each plan's (and each
  generated floor's) places and place edges with their estimated and ground-truth rooms and the doors read (D
  lines), which rooms/finder_sandbox.py DIR reads: a Python mirror of the room finder (persistence seeding,
  closed-off regions, flood fill, extent split, corridor merge; close to the C++, not exact) with a per-place proxy
  score, to try a room-finder idea in under a second (--no-extent-split, --no-corridor-merge mirror the settings).
Labels: the neural tree's room labels are scored on the generated buildings; --label-buildings N scores them on N
  more generated buildings' own rooms and objects (no exploration), per room type.
What each setting earned: bench/results/rooms.md.
)";

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    std::fprintf(stderr,
                 "usage: %s [--plans-dir DIR] [--maps a,b|none] [--variants plain,furnished] [--generated N] "
                 "[--generated-rooms N] [--label-buildings N] [--size WxH] [--hfov-deg D] [--rate-hz R] [--max-reach-m M] "
                 "[--robot-radius-m R] [--look-into-unreachable 0|1] [--furniture-height-m H] [--cache-dir DIR] "
                 "[--images DIR] [--dump-places DIR] [--door-oracle-m C] [--doors 0|1|online] [--online-every N] "
                 "[--sight-cut-edges 0|1] [--set SECTION.KEY=VALUE ...] %s "
                 "[--json FILE]\n%s",
                 argv[0], bench::odometry_usage(), kDetails);
    std::fprintf(stderr, "--set SECTION.KEY=VALUE: each setting of the stages (range; origin): doc\n");
    params::print_help(eval_schema().sections(), stderr);
    return 2;
  }
  // The output directories are made here, so a typo is one clear error at start-up rather than a missed cache.
  for (const std::string* dir : {&opt.cache_dir, &opt.images_dir, &opt.dump_dir}) {
    if (dir->empty()) continue;
    std::error_code ec;
    std::filesystem::create_directories(*dir, ec);
    if (ec || !std::filesystem::is_directory(*dir)) {
      std::fprintf(stderr, "cannot make directory '%s': %s\n", dir->c_str(),
                   ec ? ec.message().c_str() : "a file is in the way");
      return 2;
    }
  }
  params::print(eval_schema(), opt, stdout);
  if (opt.doors) {
    std::string door_error;
    if (!opt.door.validate(&door_error)) {
      std::fprintf(stderr, "%s\n", door_error.c_str());
      return 2;
    }
    std::printf("doors: found on the robot's surface, %.2f m above its height on each storey, widths %.2f .. %.2f m, "
                "clearance rise %.2f m within %.2f m, dropped where the places go round within %.2f m "
                "(--door-bypass-max-m 0: off); crossing place edges closed (--doors 0: off)\n",
                opt.door.slice_above_robot_m, opt.door.min_width_m, opt.door.max_width_m, opt.door.min_rise_m,
                opt.door.rise_reach_m, opt.door.bypass_max_m);
  } else if (opt.online_doors) {
    std::string door_error;
    if (!opt.door.validate(&door_error)) {
      std::fprintf(stderr, "%s\n", door_error.c_str());
      return 2;
    }
    std::printf("doors: online (the app's window passes during the run, every %d. frontend update; no final stage)\n",
                opt.online_every);
  } else {
    std::printf("doors: off\n");
  }
  if (opt.door_oracle_m >= 0.0)
    std::printf("DOOR ORACLE: on the IPA plans every place edge between two ground-truth rooms has clearance %.2f m; "
                "the scores are the bound a perfect door and opening cue gives the room finder\n",
                opt.door_oracle_m);
  std::printf("camera %dx%d, %.0f deg hfov, %.1f Hz keyframes, %s, noise-free depth; labels reach "
              "%.1f m from places; robot radius %.2f m, %s\n",
              opt.width, opt.height, opt.hfov_deg, opt.rate_hz, opt.odometry.describe().c_str(), opt.max_reach_m,
              opt.robot_radius_m,
              opt.look_into_unreachable ? "the tour looks into rooms it cannot enter" : "no looks into rooms");
  char cond[1536];
  std::snprintf(cond, sizeof(cond),
                "sim camera %dx%d %.0f deg hfov %.1f Hz, %s, noise-free depth, robot radius %.2f m%s, "
                "TSDF 0.1 m, frontend every keyframe, rooms seeding %s alpha %.2f persistence %.2f m [%.2f, %.2f] m "
                "min %u",
                opt.width, opt.height, opt.hfov_deg, opt.rate_hz, opt.odometry.describe().c_str(), opt.robot_radius_m,
                opt.look_into_unreachable ? ", looks into unreachable rooms" : "", rooms::to_string(opt.rooms.seeding),
                opt.rooms.plateau_alpha, opt.rooms.min_persistence_m, opt.rooms.min_dilation_m,
                opt.rooms.max_dilation_m, opt.rooms.min_component_size);
  if (opt.rooms.split_by_extent)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", extent split saturation %.2f m [%.2f, %.2f] m persistence %.2f m min %u",
                  opt.rooms.extent_saturation_m, opt.rooms.split_min_extent_m, opt.rooms.split_max_extent_m,
                  opt.rooms.split_min_persistence_m, opt.rooms.split_min_component_size);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no extent split");
  if (opt.rooms.merge_corridors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", corridor merge >= %u rooms >= %u open edges", opt.rooms.corridor_min_neighbours,
                  opt.rooms.corridor_min_open_edges);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no corridor merge");
  if (opt.rooms.merge_visible && opt.doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", visibility merge >= %.2f of %u x %u sight lines (near the boundary: %.2f m, >= %.2f; rooms "
                  "whose places' spheres touch in sight adjacent: %s) past walls >= %.1f m (dilated %.2f m; islands "
                  "< %.1f m wider than %.2f m are furniture)",
                  opt.rooms.visible_min_share, opt.rooms.visible_samples, opt.rooms.visible_samples,
                  opt.rooms.visible_local_radius_m, opt.rooms.visible_local_min_share,
                  opt.rooms.visible_touching ? "yes" : "no", opt.door.sight_min_wall_m, opt.door.sight_wall_dilation_m,
                  opt.door.sight_furniture_max_m, opt.door.sight_furniture_min_width_m);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no visibility merge");
  if (opt.rooms.close_edges_through_walls && opt.online_doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", place edges through walls read as closed in the last online window");
  else if (opt.door.sight_cut_edges && opt.doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", place edges through walls closed");
  if (opt.door_oracle_m >= 0.0)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", door oracle %.2f m", opt.door_oracle_m);
  if (opt.doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", doors on the robot's surface (slice +%.2f m, widths %.2f-%.2f m, rise %.2f m in %.2f m, "
                  "dropped where the places go round within %.2f m in steps <= %.2f m, line +%.2f m)",
                  opt.door.slice_above_robot_m, opt.door.min_width_m, opt.door.max_width_m, opt.door.min_rise_m,
                  opt.door.rise_reach_m, opt.door.bypass_max_m, opt.door.bypass_max_edge_m,
                  opt.door.bypass_extension_m);
  else if (opt.online_doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", online doors every %d. frontend update (window passes, slice +%.2f m, dropped where the "
                  "window's places go round within %.2f m)",
                  opt.online_every, opt.door.slice_above_robot_m, opt.door.bypass_max_m);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no doors");
  bench::Figures figures(cond);
  const auto add = [&](const std::string& prefix, const Score& s) {
    figures.add(prefix + ".precision_mean", s.precision_mean, "fraction");
    figures.add(prefix + ".recall_mean", s.recall_mean, "fraction");
    figures.add(prefix + ".precision_area", s.precision_area, "fraction");
    figures.add(prefix + ".recall_area", s.recall_area, "fraction");
    figures.add(prefix + ".rooms_found", static_cast<double>(s.rooms_found), "rooms");
    figures.add(prefix + ".rooms_truth", static_cast<double>(s.rooms_truth), "rooms");
  };
  // A peer's totals, printed and added with ours over it: "ALL peer <short> (<set>)", figures
  // rooms_eval.<set>.peer_<name>[.ours_over_peer.*].
  const auto add_peer_total = [&](const std::string& set, const char* name, const char* short_name, const char* what,
                                  const Score& overall, const Score& peer) {
    const std::size_t dot = set.find('.');
    const std::string shown = dot == std::string::npos ? set : set.substr(dot + 1);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (%s; ours over it: P %.3f R %.3f "
                "area P %.3f)\n",
                ("ALL peer " + std::string(short_name) + " (" + shown + ")").c_str(), peer.precision_mean,
                peer.recall_mean, peer.precision_area, peer.recall_area, peer.rooms_found, peer.rooms_truth, what,
                ratio(overall.precision_mean, peer.precision_mean), ratio(overall.recall_mean, peer.recall_mean),
                ratio(overall.precision_area, peer.precision_area));
    const std::string prefix = "rooms_eval." + set + ".peer_" + name;
    add(prefix, peer);
    figures.add(prefix + ".ours_over_peer.precision_mean", ratio(overall.precision_mean, peer.precision_mean),
                "ratio");
    figures.add(prefix + ".ours_over_peer.recall_mean", ratio(overall.recall_mean, peer.recall_mean), "ratio");
    figures.add(prefix + ".ours_over_peer.precision_area", ratio(overall.precision_area, peer.precision_area),
                "ratio");
  };
  int failures = 0;
  std::vector<double> rooms_ms, door_ms;
  // Per run: the door stage's doors, closed edges and time (--doors).
  std::vector<double> pass_ms;
  std::size_t wall_tiles_max = 0, doors_added = 0, doors_dropped = 0;
  const auto add_doors = [&](const std::string& prefix, const RunStats& st) {
    if (opt.online_doors) {
      figures.add(prefix + ".online_doors", static_cast<double>(st.online_doors.size()), "doors");
      pass_ms.insert(pass_ms.end(), st.pass_ms.begin(), st.pass_ms.end());
      wall_tiles_max = std::max(wall_tiles_max, st.wall_tiles);
      doors_added += st.doors_added;
      doors_dropped += st.doors_dropped;
    }
    if (!opt.doors) return;
    figures.add(prefix + ".doors", static_cast<double>(st.doors.size()), "doors");
    figures.add(prefix + ".door_edges_closed", static_cast<double>(st.door_edges_closed), "edges");
    door_ms.push_back(st.door_ms);
  };
  for (const std::string& plan_variant : opt.variants) {
    if (opt.maps.empty()) break;
    const bool furnished = plan_variant == "furnished";
    // Printed and figure name: "furnished_low" when the furniture stands at --furniture-height-m.
    const std::string variant = furnished && opt.furniture_height_m > 0.0 ? "furnished_low" : plan_variant;
    if (variant == "furnished_low")
      std::printf("furnished_low: the furnished plans with their furniture extruded to %.2f m, not to the walls' "
                  "%.2f m\n", opt.furniture_height_m, world::FloorPlanConfig{}.wall_height_m);
    Score overall, overall_reachable, overall_oracle, overall_distance, overall_distance_plateau, overall_erosion;
    Score overall_hydra;
    std::size_t hydra_plans = 0;
    std::size_t doors_between = 0, doors_inside = 0, doors_unknown = 0;
    for (const std::string& map : opt.maps) {
      Score s, reachable, oracle;
      Peers peers;
      RunStats st;
      if (!eval_plan(opt, map, furnished, &s, &st, &reachable, &oracle, &peers)) {
        ++failures;
        continue;
      }
      print_line(map + " (" + variant + ")", s, st);
      if (opt.doors || opt.online_doors) {
        std::printf("  doors against the ground truth: %zu between two rooms, %zu inside one room, %zu unknown\n",
                    st.doors_between, st.doors_inside, st.doors_unknown);
        doors_between += st.doors_between;
        doors_inside += st.doors_inside;
        doors_unknown += st.doors_unknown;
      }
      print_peer("  peer: distance transform", peers.distance, "threshold", peers.distance_level_m);
      print_peer("  peer: distance, PH plateau", peers.distance_plateau, "threshold", peers.distance_plateau_level_m);
      print_peer("  peer: morphological", peers.erosion, "deepest erosion", peers.erosion_level_m);
      if (peers.has_hydra) {
        std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | our graph, no doors, delta* "
                    "%.2f m\n",
                    "  peer: Hydra room clustering", peers.hydra.precision_mean, peers.hydra.recall_mean,
                    peers.hydra.precision_area, peers.hydra.recall_area, peers.hydra.rooms_found,
                    peers.hydra.rooms_truth, peers.hydra_dilation_m);
        add("rooms_eval.ipa." + variant + "." + map + ".peer_hydra", peers.hydra);
        overall_hydra.add(peers.hydra);
        ++hydra_plans;
      }
      add("rooms_eval.ipa." + variant + "." + map, s);
      add("rooms_eval.ipa." + variant + "." + map + ".peer_distance_transform", peers.distance);
      add("rooms_eval.ipa." + variant + "." + map + ".peer_distance_plateau", peers.distance_plateau);
      add("rooms_eval.ipa." + variant + "." + map + ".peer_morphological", peers.erosion);
      overall_distance.add(peers.distance);
      overall_distance_plateau.add(peers.distance_plateau);
      overall_erosion.add(peers.erosion);
      rooms_ms.push_back(st.rooms_ms);
      add_doors("rooms_eval.ipa." + variant + "." + map, st);
      overall.add(s);
      overall_reachable.add(reachable);
      overall_oracle.add(oracle);
    }
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (means pooled over all rooms)\n",
                ("ALL (" + variant + ")").c_str(), overall.precision_mean, overall.recall_mean, overall.precision_area,
                overall.recall_area, overall.rooms_found, overall.rooms_truth);
    if (opt.doors || opt.online_doors) {
      const std::size_t judged = doors_between + doors_inside;
      const double inside_share = judged > 0 ? static_cast<double>(doors_inside) / static_cast<double>(judged) : 0.0;
      std::printf("%-30s %zu between two ground-truth rooms, %zu inside one room (%.1f %% of those judged), %zu "
                  "unknown\n",
                  ("ALL doors (" + variant + ")").c_str(), doors_between, doors_inside, 100.0 * inside_share,
                  doors_unknown);
      const std::string prefix = "rooms_eval.ipa." + variant + (opt.online_doors ? ".online_doors" : ".doors");
      figures.add(prefix + "_between_rooms", static_cast<double>(doors_between), "doors");
      figures.add(prefix + "_inside_a_room", static_cast<double>(doors_inside), "doors");
      figures.add(prefix + "_inside_a_room_share", inside_share, "ratio");
    }
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (rooms the tour could reach)\n",
                ("ALL reachable (" + variant + ")").c_str(), overall_reachable.precision_mean,
                overall_reachable.recall_mean, overall_reachable.precision_area, overall_reachable.recall_area,
                overall_reachable.rooms_found, overall_reachable.rooms_truth);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (bound: each place in its "
                "ground-truth room)\n",
                ("ALL oracle (" + variant + ")").c_str(), overall_oracle.precision_mean, overall_oracle.recall_mean,
                overall_oracle.precision_area, overall_oracle.recall_area, overall_oracle.rooms_found,
                overall_oracle.rooms_truth);
    add_peer_total("ipa." + variant, "distance_transform", "dist", "the complete plan", overall, overall_distance);
    add_peer_total("ipa." + variant, "distance_plateau", "dist PH", "the complete plan", overall,
                   overall_distance_plateau);
    add_peer_total("ipa." + variant, "morphological", "morph", "the complete plan", overall, overall_erosion);
    if (hydra_plans > 0)
      add_peer_total("ipa." + variant, "hydra", "Hydra", "the paper's room clustering on our graph, no doors",
                     overall, overall_hydra);
    add("rooms_eval.ipa." + variant + ".all", overall);
    add("rooms_eval.ipa." + variant + ".oracle", overall_oracle);
    add("rooms_eval.ipa." + variant + ".reachable", overall_reachable);
  }
  Score generated, generated_oracle, generated_hydra;
  LabelScore labels;
  for (int seed = 1; seed <= opt.generated; ++seed) {
    Score s, oracle, hydra;
    RunStats st;
    if (!eval_generated(opt, static_cast<std::uint64_t>(seed), &s, &st, &labels, &oracle, &hydra)) {
      ++failures;
      continue;
    }
    print_line("generated two-floor seed " + std::to_string(seed), s, st);
    add("rooms_eval.generated_two_floor.seed" + std::to_string(seed), s);
    rooms_ms.push_back(st.rooms_ms);
    add_doors("rooms_eval.generated_two_floor.seed" + std::to_string(seed), st);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | our graph, no doors\n",
                "  peer: Hydra room clustering", hydra.precision_mean, hydra.recall_mean, hydra.precision_area,
                hydra.recall_area, hydra.rooms_found, hydra.rooms_truth);
    add("rooms_eval.generated_two_floor.seed" + std::to_string(seed) + ".peer_hydra", hydra);
    generated.add(s);
    generated_oracle.add(oracle);
    generated_hydra.add(hydra);
  }
  if (opt.generated > 0) {
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu\n", "ALL generated two-floor",
                generated.precision_mean, generated.recall_mean, generated.precision_area, generated.recall_area,
                generated.rooms_found, generated.rooms_truth);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (bound: each place in its "
                "ground-truth room)\n",
                "ALL generated oracle", generated_oracle.precision_mean, generated_oracle.recall_mean,
                generated_oracle.precision_area, generated_oracle.recall_area, generated_oracle.rooms_found,
                generated_oracle.rooms_truth);
    add_peer_total("generated_two_floor", "hydra", "Hydra", "the paper's room clustering on our graph, no doors",
                   generated, generated_hydra);
    add("rooms_eval.generated_two_floor.all", generated);
    add("rooms_eval.generated_two_floor.oracle", generated_oracle);
    const double accuracy = labels.rooms > 0 ? static_cast<double>(labels.correct) / labels.rooms : 0.0;
    std::printf("room labels (room classifier, generated two-floor): %zu of %zu estimated rooms correct (%.1f %%), %zu "
                "unknown; each room scored against the ground-truth room holding most of its places\n",
                labels.correct, labels.rooms, 100.0 * accuracy, labels.unknown);
    const std::size_t labelled = labels.rooms - labels.unknown;
    std::printf("  of the %zu labelled (not unknown), %zu correct (%.1f %%)\n", labelled, labels.correct,
                labelled > 0 ? 100.0 * labels.correct / labelled : 0.0);
    for (const auto& [pair, n] : labels.confusions) std::printf("  wrong: %s x %zu\n", pair.c_str(), n);
    std::printf("  objects whose parent place is in their own ground-truth room: %zu of %zu (%.1f %%)\n",
                labels.objects_in_own_room, labels.objects,
                labels.objects > 0 ? 100.0 * labels.objects_in_own_room / labels.objects : 0.0);
    std::printf("room labels on the ground-truth rooms and objects of the same buildings: %zu of %zu (%.1f %%)\n",
                labels.truth_correct, labels.truth_rooms,
                labels.truth_rooms > 0 ? 100.0 * labels.truth_correct / labels.truth_rooms : 0.0);
    figures.add("rooms_eval.generated_two_floor.label_accuracy", accuracy, "fraction");
    figures.add("rooms_eval.generated_two_floor.labelled_rooms", static_cast<double>(labels.rooms), "rooms");
    figures.add("rooms_eval.generated_two_floor.objects_in_own_room",
                labels.objects > 0 ? static_cast<double>(labels.objects_in_own_room) / labels.objects : 0.0, "fraction");
  }
  if (opt.label_buildings > 0) {
    LabelScore truth;
    for (int i = 1; i <= opt.label_buildings; ++i) {
      world::BuildingConfig bc;
      bc.seed = static_cast<std::uint64_t>(1000 + i);
      bc.num_rooms = opt.generated_rooms;
      bc.two_floors = true;
      label_truth_rooms(world::generate_building(bc), &truth);
    }
    const double accuracy = truth.truth_rooms > 0 ? static_cast<double>(truth.truth_correct) / truth.truth_rooms : 0.0;
    std::printf("room labels on the ground-truth rooms and objects of %d generated two-floor buildings (seeds "
                "1001..%d): %zu of %zu (%.1f %%)\n",
                opt.label_buildings, 1000 + opt.label_buildings, truth.truth_correct, truth.truth_rooms,
                100.0 * accuracy);
    const std::size_t labelled = truth.truth_rooms - truth.truth_unknown;
    std::printf("  %zu left unknown; of the %zu labelled, %zu correct (%.1f %%)\n", truth.truth_unknown, labelled,
                truth.truth_correct, labelled > 0 ? 100.0 * truth.truth_correct / labelled : 0.0);
    figures.add("rooms_eval.generated_truth.unknown_rooms", static_cast<double>(truth.truth_unknown), "rooms");
    figures.add("rooms_eval.generated_truth.labelled_precision",
                labelled > 0 ? static_cast<double>(truth.truth_correct) / labelled : 0.0, "fraction");
    for (const auto& [type, n] : truth.truth_per_type)
      std::printf("  %-14s %3zu of %3zu\n", type.c_str(), n.first, n.second);
    for (const auto& [pair, n] : truth.truth_confusions) std::printf("  wrong: %s x %zu\n", pair.c_str(), n);
    figures.add("rooms_eval.generated_truth.label_accuracy", accuracy, "fraction");
    figures.add("rooms_eval.generated_truth.labelled_rooms", static_cast<double>(truth.truth_rooms), "rooms");
  }
  if (!rooms_ms.empty()) figures.add("rooms_eval.rooms_update_ms_median", median(rooms_ms), "ms");
  if (!door_ms.empty()) figures.add("rooms_eval.door_stage_ms_median", median(door_ms), "ms");
  if (!pass_ms.empty()) {
    std::sort(pass_ms.begin(), pass_ms.end());
    figures.add("rooms_eval.online_door_pass_ms_median", pass_ms[pass_ms.size() / 2], "ms");
    figures.add("rooms_eval.online_door_pass_ms_p99", pass_ms[pass_ms.size() * 99 / 100], "ms");
    figures.add("rooms_eval.online_door_pass_ms_max", pass_ms.back(), "ms");
    figures.add("rooms_eval.online_wall_tiles_max", static_cast<double>(wall_tiles_max), "tiles");
    // Churn: doors that came and went during the runs (a door a pass adds and a later one drops made the rooms
    // flicker in between).
    figures.add("rooms_eval.online_doors_added_per_pass", static_cast<double>(doors_added) / pass_ms.size(), "doors");
    figures.add("rooms_eval.online_doors_dropped_per_pass", static_cast<double>(doors_dropped) / pass_ms.size(),
                "doors");
    std::printf("online door passes: %zu, median %.1f ms, p99 %.1f ms, max %.1f ms; wall tiles at most %zu; doors "
                "added %zu, dropped %zu over the passes\n",
                pass_ms.size(), pass_ms[pass_ms.size() / 2], pass_ms[pass_ms.size() * 99 / 100], pass_ms.back(),
                wall_tiles_max, doors_added, doors_dropped);
  }
  if (!opt.json_path.empty() && !figures.write(opt.json_path)) return 1;
  return failures == 0 ? 0 : 1;
}

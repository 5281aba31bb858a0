// rooms_eval's command line and help (rooms_eval_options.h).
#include "bench/rooms/rooms_eval_options.h"

#include <cstdio>
#include <cstdlib>

#include "core/doors/door_params.h"
#include "core/places/places_params.h"
#include "core/rooms/rooms_params.h"

namespace qsg::bench {
namespace {

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

}  // namespace

// The stage settings --set reaches, from their parameter tables: one declaration per setting (core/params).
const params::Schema<RoomsEvalOptions>& rooms_eval_schema() {
  static const params::Schema<RoomsEvalOptions> schema = [] {
    params::Schema<RoomsEvalOptions> s;
    s.section("places", places::params_table(), [](RoomsEvalOptions& o) -> places::Config& { return o.places; });
    s.section("rooms", rooms::params_table(), [](RoomsEvalOptions& o) -> rooms::Config& { return o.rooms; });
    s.section("doors", rooms::door_params_table(), [](RoomsEvalOptions& o) -> rooms::DoorConfig& { return o.door; });
    return s;
  }();
  return schema;
}

namespace {

// The hand-written flags of plain Config fields are gone (--alpha, --door-min-width-m, ...): an unknown flag that
// names a table key (dashes for underscores, without a "door-" prefix) gets the --set it now is.
std::string retired_flag_hint(const std::string& flag) {
  if (flag.rfind("--", 0) != 0) return {};
  std::string key = flag.substr(2);
  for (char& c : key)
    if (c == '-') c = '_';
  for (const std::string& candidate : {key, key.rfind("door_", 0) == 0 ? key.substr(5) : std::string()})
    for (const params::Section& section : rooms_eval_schema().sections())
      if (!candidate.empty() && section.find(candidate) != nullptr)
        return " (now --set " + section.name + "." + candidate + "=VALUE)";
  return " (stage settings: --set SECTION.KEY=VALUE, listed by --help)";
}

}  // namespace

bool parse_rooms_eval(int argc, char** argv, RoomsEvalOptions* o) {
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
      if (!params::set(rooms_eval_schema(), o, v, &error)) {
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
  if (const std::string bad = params::check(rooms_eval_schema(), *o); !bad.empty()) {
    std::fprintf(stderr, "%s\n", bad.c_str());
    return false;
  }
  return o->width > 0 && o->height > 0 && o->rate_hz > 0 && o->rooms.check().empty() &&
         o->places.check().empty();
}

static const char kDetails[] = R"(
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

void print_rooms_eval_usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--plans-dir DIR] [--maps a,b|none] [--variants plain,furnished] [--generated N] "
               "[--generated-rooms N] [--label-buildings N] [--size WxH] [--hfov-deg D] [--rate-hz R] [--max-reach-m M] "
               "[--robot-radius-m R] [--look-into-unreachable 0|1] [--furniture-height-m H] [--cache-dir DIR] "
               "[--images DIR] [--dump-places DIR] [--door-oracle-m C] [--doors 0|1|online] [--online-every N] "
               "[--sight-cut-edges 0|1] [--set SECTION.KEY=VALUE ...] %s "
               "[--json FILE]\n%s",
               argv0, bench::odometry_usage(), kDetails);
  std::fprintf(stderr, "--set SECTION.KEY=VALUE: each setting of the stages (range; origin): doc\n");
  params::print_help(rooms_eval_schema().sections(), stderr);
}

}  // namespace qsg::bench

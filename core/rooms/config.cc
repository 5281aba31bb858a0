// The room finder's settings: the paper's, their checks and their printed form; the finder's store sizes.
#include "core/rooms/config.h"

#include <cmath>

#include "core/rooms/rooms_params.h"

namespace qsg::rooms {

namespace sg = scene_graph;

namespace {
constexpr std::size_t kMaxCurveSamples = 100000;
constexpr std::size_t kMaxSlots = std::numeric_limits<std::uint32_t>::max() / 2;
}  // namespace

Config Config::paper() {
  Config c;
  c.seeding = Seeding::kPlateau;
  c.min_component_size = 15;
  c.plateau_alpha = 0.5;
  c.split_by_extent = false;
  c.seed_closed_regions = false;
  c.merge_corridors = false;
  return c;
}

std::size_t Config::curve_samples() const {
  if (!(dilation_step_m > 0.0) || !(max_dilation_m >= min_dilation_m)) return 0;
  return static_cast<std::size_t>(std::floor((max_dilation_m - min_dilation_m) / dilation_step_m + 1e-6)) + 1;
}

const char* to_string(Seeding seeding) {
  return seeding == Seeding::kPersistence ? "persistence" : "plateau";
}

std::string Config::check() const {
  // Each field within its declared range (rooms_params.cc), whatever its switch; then the rules between fields.
  if (std::string why = params::check(params_table(), *this, "rooms"); !why.empty()) return why;
  if (!(max_dilation_m >= min_dilation_m))
    return "rooms.max_dilation_m: must be >= min_dilation_m, got " + std::to_string(max_dilation_m);
  if (curve_samples() > kMaxCurveSamples)
    return "rooms.dilation_step_m: " + std::to_string(curve_samples()) + " samples over [d-, d+], at most " +
           std::to_string(kMaxCurveSamples);
  if (!(split_max_extent_m >= split_min_extent_m))
    return "rooms.split_max_extent_m: must be >= split_min_extent_m, got " + std::to_string(split_max_extent_m);
  if (merge_corridors && corridor_min_neighbours < 2)
    return "rooms.corridor_min_neighbours: must be >= 2 (1 would merge every room with its corridor)";
  if (merge_corridors && corridor_min_open_edges < 1)
    return "rooms.corridor_min_open_edges: must be >= 1 with merge_corridors (0 would merge through doors)";
  if (merge_visible && visible_local_radius_m > 0.0 && !(visible_local_min_share > 0.0))
    return "rooms.visible_local_min_share: must be > 0 with visible_local_radius_m > 0, got " +
           std::to_string(visible_local_min_share);
  if (merge_visible && visible_local_radius_m > 0.0 && visible_local_min_places < 1)
    return "rooms.visible_local_min_places: must be >= 1 with visible_local_radius_m > 0";
  // The table's bound is a double, which cannot hold 2^56 - 1 exactly.
  if (building_index > sg::kIndexMask) return "rooms.building_index: larger than a node index";
  return "";
}

void Config::print(std::FILE* out) const {
  params::print(params::sections_of("rooms", params_table()), this, out);  // every field, from the table
}

Capacities Capacities::from_scene_graph(const sg::Capacities& graph) {
  Capacities c;
  c.places = graph.place_nodes;
  c.place_edges = graph.edges;
  c.rooms = graph.room_nodes;
  return c;
}

std::string Capacities::check() const {
  if (places == 0) return "rooms capacities.places: must be > 0";
  if (places >= kMaxSlots) return "rooms capacities.places: too large";
  if (place_edges >= kMaxSlots) return "rooms capacities.place_edges: too large";
  if (rooms == 0) return "rooms capacities.rooms: must be > 0";
  if (rooms >= (1u << 24)) return "rooms capacities.rooms: at most 2^24 - 1 (the corridor merge packs two slots)";
  return "";
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out, "rooms capacities: places %zu, place_edges %zu, rooms %zu\n", places, place_edges, rooms);
}

}  // namespace qsg::rooms

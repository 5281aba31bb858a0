// The room finder's settings: the paper's, their checks and their printed form; the finder's store sizes.
#include "core/rooms/config.h"

#include <cmath>

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
  if (seeding != Seeding::kPlateau && seeding != Seeding::kPersistence) return "rooms.seeding: unknown value";
  if (!(max_door_clearance_m >= 0.0)) return "rooms.max_door_clearance_m: must be >= 0 (inf: no limit)";
  if (!(window_room_margin_m >= 0.0)) return "rooms.window_room_margin_m: must be >= 0 (inf: whole rooms)";
  if (!std::isfinite(min_persistence_m) || min_persistence_m < 0.0)
    return "rooms.min_persistence_m: must be finite and >= 0, got " + std::to_string(min_persistence_m);
  if (!std::isfinite(min_dilation_m) || min_dilation_m < 0.0)
    return "rooms.min_dilation_m: must be finite and >= 0, got " + std::to_string(min_dilation_m);
  if (!std::isfinite(max_dilation_m) || max_dilation_m < min_dilation_m)
    return "rooms.max_dilation_m: must be finite and >= min_dilation_m, got " + std::to_string(max_dilation_m);
  if (!std::isfinite(dilation_step_m) || dilation_step_m <= 0.0)
    return "rooms.dilation_step_m: must be > 0, got " + std::to_string(dilation_step_m);
  if (curve_samples() > kMaxCurveSamples)
    return "rooms.dilation_step_m: " + std::to_string(curve_samples()) + " samples over [d-, d+], at most " +
           std::to_string(kMaxCurveSamples);
  if (min_component_size < 1) return "rooms.min_component_size: must be >= 1";
  if (!(plateau_alpha >= 0.0 && plateau_alpha <= 1.0))
    return "rooms.plateau_alpha: must be in [0, 1], got " + std::to_string(plateau_alpha);
  if (!std::isfinite(extent_saturation_m) || extent_saturation_m < 0.0)
    return "rooms.extent_saturation_m: must be finite and >= 0, got " + std::to_string(extent_saturation_m);
  if (!std::isfinite(split_min_extent_m) || split_min_extent_m < 0.0)
    return "rooms.split_min_extent_m: must be finite and >= 0, got " + std::to_string(split_min_extent_m);
  if (!std::isfinite(split_max_extent_m) || split_max_extent_m < split_min_extent_m)
    return "rooms.split_max_extent_m: must be finite and >= split_min_extent_m, got " +
           std::to_string(split_max_extent_m);
  if (!std::isfinite(split_min_persistence_m) || split_min_persistence_m < 0.0)
    return "rooms.split_min_persistence_m: must be finite and >= 0, got " + std::to_string(split_min_persistence_m);
  if (split_min_component_size < 1) return "rooms.split_min_component_size: must be >= 1";
  if (merge_corridors && corridor_min_neighbours < 2)
    return "rooms.corridor_min_neighbours: must be >= 2 (1 would merge every room with its corridor)";
  if (merge_corridors && (corridor_min_open_edges < 1 || corridor_min_open_edges > 65535))
    return "rooms.corridor_min_open_edges: must be in [1, 65535] (0 would merge through doors; counts saturate at "
           "65535)";
  if (merge_visible && !(visible_min_share > 0.0 && visible_min_share <= 1.0))
    return "rooms.visible_min_share: must be in (0, 1], got " + std::to_string(visible_min_share);
  if (merge_visible && (visible_samples < 1 || visible_samples > kMaxVisibleSamples))
    return "rooms.visible_samples: must be in [1, " + std::to_string(kMaxVisibleSamples) + "], got " +
           std::to_string(visible_samples);
  if (merge_visible && visible_max_rounds < 1) return "rooms.visible_max_rounds: must be >= 1";
  if (merge_visible && !(std::isfinite(visible_local_radius_m) && visible_local_radius_m >= 0.0))
    return "rooms.visible_local_radius_m: must be finite and >= 0, got " + std::to_string(visible_local_radius_m);
  if (merge_visible && visible_local_radius_m > 0.0 &&
      !(visible_local_min_share > 0.0 && visible_local_min_share <= 1.0))
    return "rooms.visible_local_min_share: must be in (0, 1], got " + std::to_string(visible_local_min_share);
  if (merge_visible && visible_local_radius_m > 0.0 && visible_local_min_places < 1)
    return "rooms.visible_local_min_places: must be >= 1";
  if (merge_visible && visible_touching &&
      !(std::isfinite(visible_touch_max_clearance_m) && visible_touch_max_clearance_m > 0.0))
    return "rooms.visible_touch_max_clearance_m: must be finite and > 0, got " +
           std::to_string(visible_touch_max_clearance_m);
  if (building_index > sg::kIndexMask) return "rooms.building_index: larger than a node index";
  return "";
}

void Config::print(std::FILE* out) const {
  std::fprintf(out,
               "rooms: seeding %s, dilation [%.3f, %.3f] m step %.3f m (%zu samples), min_component_size %u places, "
               "plateau_alpha %.2f, min_persistence_m %.2f, max_door_clearance_m %.2f, building B(%llu)\n",
               to_string(seeding), min_dilation_m, max_dilation_m, dilation_step_m, curve_samples(),
               min_component_size, plateau_alpha, min_persistence_m, max_door_clearance_m,
               static_cast<unsigned long long>(building_index));
  if (split_by_extent)
    std::fprintf(out,
                 "rooms: split by extent: saturation %.2f m, extent [%.2f, %.2f] m, min_persistence %.2f m, "
                 "min_component_size %u places\n",
                 extent_saturation_m, split_min_extent_m, split_max_extent_m, split_min_persistence_m,
                 split_min_component_size);
  else
    std::fprintf(out, "rooms: split by extent off\n");
  std::fprintf(out, "rooms: closed-off regions seed rooms: %s\n", seed_closed_regions ? "on" : "off");
  std::fprintf(out, "rooms: updates during the run over the active window and its rooms: %s (margin %.2f m)\n",
               window_updates ? "on" : "off", window_room_margin_m);
  if (merge_corridors)
    std::fprintf(out, "rooms: corridor merge: rooms touching >= %u rooms, through >= %u open place edges\n",
                 corridor_min_neighbours, corridor_min_open_edges);
  else
    std::fprintf(out, "rooms: corridor merge off\n");
  if (merge_visible)
    std::fprintf(out,
                 "rooms: visibility merge (with sight lines): >= %.2f of %u x %u sight lines clear, <= %u rounds; "
                 "near the boundary (%.2f m, >= %u places a side): >= %.2f; rooms whose places' spheres touch in "
                 "sight adjacent: %s\n",
                 visible_min_share, visible_samples, visible_samples, visible_max_rounds, visible_local_radius_m,
                 visible_local_min_places, visible_local_min_share, visible_touching ? "yes" : "no");
  else
    std::fprintf(out, "rooms: visibility merge off\n");
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

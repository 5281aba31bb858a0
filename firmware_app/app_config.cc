// Loading and checking the app's configuration.
#include "firmware_app/app_config.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <tuple>
#include <type_traits>
#include <vector>
#include <nlohmann/json.hpp>

#include "core/json/json_guard.h"

namespace qsg::app {

const char* to_string(Driver d) {
  switch (d) {
    case Driver::kSim: return "sim";
    case Driver::kReplay: return "replay";
    case Driver::kV4l2: return "v4l2";
  }
  return "?";
}

AppConfig::AppConfig() {
  // The simulated quadruped's defaults: a 12-room building, a 320x240 camera at 10 Hz at 0.5 m height.
  building.num_rooms = 12;
  exploration.camera_height_m = 0.5;
  camera.rate_hz = 10.0;
  camera.pitch_rad = 0.15;
  // A listed frame file that is missing is counted and skipped (drivers' missing_files), not a start-up error.
  replay.check_files_at_open = false;
}

namespace {

using Json = nlohmann::json;
// A key's reader: checks the type, assigns; false with a message otherwise.
using Reader = std::function<bool(const Json&, std::string*)>;

// Integers must be JSON integers within the field's type (get<int>() turned 4294967296 into 0 and 1.5 into 1);
// floating-point fields must fit their type (1e39 is not a float).
template <typename T>
Reader number(T* out) {
  return [out](const Json& v, std::string* why) {
    if constexpr (std::is_integral_v<T>) {
      const std::string range = "[" + std::to_string(std::numeric_limits<T>::min()) + ", " +
                                std::to_string(std::numeric_limits<T>::max()) + "]";
      if (!v.is_number_integer()) {
        *why = "expected an integer in " + range + (v.is_number() ? ", got " + v.dump() : std::string());
        return false;
      }
      bool fits = false;
      if (v.is_number_unsigned()) {
        fits = v.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max());
      } else {
        const std::int64_t i = v.get<std::int64_t>();
        fits = i >= 0 ? static_cast<std::uint64_t>(i) <= static_cast<std::uint64_t>(std::numeric_limits<T>::max())
                      : std::is_signed_v<T> && i >= static_cast<std::int64_t>(std::numeric_limits<T>::min());
      }
      if (!fits) return *why = "expected an integer in " + range + ", got " + v.dump(), false;
      *out = v.get<T>();
    } else {
      if (!v.is_number()) return *why = "expected a number", false;
      const double d = v.get<double>();
      if (!(std::abs(d) <= static_cast<double>(std::numeric_limits<T>::max())))
        return *why = "expected a number within the range of its type, got " + v.dump(), false;
      *out = static_cast<T>(d);
    }
    return true;
  };
}
Reader boolean(bool* out) {
  return [out](const Json& v, std::string* why) {
    if (!v.is_boolean()) return *why = "expected true or false", false;
    *out = v.get<bool>();
    return true;
  };
}
Reader text(std::string* out) {
  return [out](const Json& v, std::string* why) {
    if (!v.is_string()) return *why = "expected a string", false;
    *out = v.get<std::string>();
    return true;
  };
}

// A count read as a JSON number: a whole number in [lo, hi] (false for NaN and fractions).
bool whole_number_in(double v, double lo, double hi) { return v >= lo && v <= hi && v == std::floor(v); }

bool read_section(const Json& section, const std::string& prefix, const std::map<std::string, Reader>& keys,
                  std::string* error) {
  if (!section.is_object()) return *error = prefix + ": expected an object", false;
  for (auto it = section.begin(); it != section.end(); ++it) {
    const auto key = keys.find(it.key());
    if (key == keys.end()) return *error = prefix + "." + it.key() + ": unknown key", false;
    std::string why;
    if (!key->second(it.value(), &why)) return *error = prefix + "." + it.key() + ": " + why, false;
  }
  return true;
}

}  // namespace

bool AppConfig::load(const std::string& path, std::string* error) {
  std::ifstream in(path);
  if (!in) return *error = "config '" + path + "': cannot open", false;
  // Whole-line // comments are allowed (nlohmann-json 3.7 on JetPack 5 cannot skip comments itself).
  std::string text_without_comments, line;
  while (std::getline(in, line)) {
    const std::size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line.compare(first, 2, "//") == 0) line.clear();
    text_without_comments += line + "\n";
  }
  // Duplicated keys are errors (the JSON library would keep the last silently), and so is nesting past 32 levels.
  Json doc;
  if (json_guard::ParseFailure f; !json_guard::parse(text_without_comments, json_guard::Limits{}, &doc, &f)) {
    using Kind = json_guard::ParseFailure::Kind;
    if (f.kind == Kind::kDuplicateKey || f.kind == Kind::kTooDeep) return *error = "config '" + path + "': " + f.message, false;
    return *error = "config '" + path + "': not valid JSON: " + f.message, false;
  }
  std::string driver_name = to_string(driver);
  const std::map<std::string, Reader> top = {
      {"driver", text(&driver_name)},
      {"replay_path", text(&replay_path)},
      {"output_dir", text(&output_dir)},
      {"duration_s", number(&duration_s)},
      {"lockstep", boolean(&lockstep)},
      {"snapshot_interval_s", number(&snapshot_interval_s)},
      {"telemetry_interval_s", number(&telemetry_interval_s)},
      {"telemetry_stores", boolean(&telemetry_stores)},
      {"lock_memory", boolean(&lock_memory)},
      {"ground_truth_labels", boolean(&ground_truth_labels)},
      {"fault_plan", text(&fault_plan)},
      {"world_path", text(&world_path)},
      {"building", [&](const Json& v, std::string* why) {
         return read_section(v, "building",
                             {{"seed", number(&building.seed)},
                              {"num_rooms", number(&building.num_rooms)},
                              {"two_floors", boolean(&building.two_floors)},
                              {"furnish", boolean(&building.furnish)}},
                             why);
       }},
      {"exploration", [&](const Json& v, std::string* why) {
         double tours = exploration.tours;
         if (!read_section(v, "exploration",
                           {{"camera_height_m", number(&exploration.camera_height_m)},
                            {"speed_m_s", number(&exploration.speed_m_s)},
                            {"spin_in_rooms", boolean(&exploration.spin_in_rooms)},
                            {"return_to_start", boolean(&exploration.return_to_start)},
                            {"rate_hz", number(&exploration.rate_hz)},
                            {"tours", number(&tours)}},
                           why))
           return false;
         if (!whole_number_in(tours, 1.0, 100000.0)) return *why = "exploration.tours: expected an integer 1 .. 100000", false;
         exploration.tours = static_cast<std::int32_t>(tours);
         return true;
       }},
      {"camera", [&](const Json& v, std::string* why) {
         int width = camera.intrinsics.width, height = camera.intrinsics.height;
         const bool ok = read_section(v, "camera",
                                      {{"width", number(&width)},
                                       {"height", number(&height)},
                                       {"rate_hz", number(&camera.rate_hz)},
                                       {"pitch_rad", number(&camera.pitch_rad)}},
                                      why);
         if (ok && (width != camera.intrinsics.width || height != camera.intrinsics.height)) {
           const double f = 525.0 * width / 640.0;  // a 58 degree horizontal field of view, RealSense-like
           camera.intrinsics = {width, height, f, f, 0.5 * width - 0.5, 0.5 * height - 0.5};
         }
         return ok;
       }},
      {"reconstruction", [&](const Json& v, std::string* why) {
         return read_section(v, "reconstruction",
                             {{"voxel_size_m", number(&reconstruction.voxel_size_m)},
                              {"truncation_voxels", number(&reconstruction.truncation_voxels)},
                              {"max_range_m", number(&reconstruction.max_range_m)},
                              {"window_radius_m", number(&reconstruction.window_radius_m)},
                              {"archive_resolution_m", number(&reconstruction.archive_resolution_m)},
                              {"integration_threads", number(&reconstruction.integration_threads)}},
                             why);
       }},
      {"places", [&](const Json& v, std::string* why) {
         places::Config& pc = frontend.places;
         return read_section(v, "places",
                             {{"voxel_factor", number(&pc.voxel_factor)},
                              {"max_distance_m", number(&pc.max_distance_m)},
                              {"min_clearance_m", number(&pc.min_clearance_m)},
                              {"min_basis_angle_rad", number(&pc.min_basis_angle_rad)},
                              {"place_resolution_m", number(&pc.place_resolution_m)},
                              {"window_radius_m", number(&pc.window_radius_m)},
                              {"unobserved_is_obstacle", boolean(&pc.unobserved_is_obstacle)},
                              {"unobserved_obstacle_above_m", number(&pc.unobserved_obstacle_above_m)},
                              {"signed_surface_seeds", boolean(&pc.signed_surface_seeds)},
                              {"correct_projective_distance", boolean(&pc.correct_projective_distance)},
                              {"bridge_max_fragment_places", number(&pc.bridge_max_fragment_places)},
                              {"hold_distant_fragments", boolean(&pc.hold_distant_fragments)},
                              {"bridge_path_search", boolean(&pc.bridge_path_search)},
                              {"merge_revisited_within_m", number(&pc.merge_revisited_within_m)}},
                             why);
       }},
      {"rooms", [&](const Json& v, std::string* why) {
         std::string seeding = rooms::to_string(rooms.seeding);
         double min_component = rooms.min_component_size;
         double split_min_component = rooms.split_min_component_size;
         double corridor_neighbours = rooms.corridor_min_neighbours;
         double corridor_edges = rooms.corridor_min_open_edges;
         double visible_samples = rooms.visible_samples;
         double visible_rounds = rooms.visible_max_rounds;
         double visible_local_places = rooms.visible_local_min_places;
         const bool ok = read_section(v, "rooms",
                                      {{"seeding", text(&seeding)},
                                       {"min_persistence_m", number(&rooms.min_persistence_m)},
                                       {"min_component_size", number(&min_component)},
                                       {"plateau_alpha", number(&rooms.plateau_alpha)},
                                       {"min_dilation_m", number(&rooms.min_dilation_m)},
                                       {"max_dilation_m", number(&rooms.max_dilation_m)},
                                       {"split_by_extent", boolean(&rooms.split_by_extent)},
                                       {"extent_saturation_m", number(&rooms.extent_saturation_m)},
                                       {"split_min_extent_m", number(&rooms.split_min_extent_m)},
                                       {"split_max_extent_m", number(&rooms.split_max_extent_m)},
                                       {"split_min_persistence_m", number(&rooms.split_min_persistence_m)},
                                       {"split_min_component_size", number(&split_min_component)},
                                       {"merge_corridors", boolean(&rooms.merge_corridors)},
                                       {"corridor_min_neighbours", number(&corridor_neighbours)},
                                       {"corridor_min_open_edges", number(&corridor_edges)},
                                       {"merge_visible", boolean(&rooms.merge_visible)},
                                       {"close_edges_through_walls", boolean(&rooms.close_edges_through_walls)},
                                       {"visible_min_share", number(&rooms.visible_min_share)},
                                       {"visible_samples", number(&visible_samples)},
                                       {"visible_local_radius_m", number(&rooms.visible_local_radius_m)},
                                       {"visible_local_min_share", number(&rooms.visible_local_min_share)},
                                       {"visible_local_min_places", number(&visible_local_places)},
                                       {"visible_touching", boolean(&rooms.visible_touching)},
                                       {"visible_touch_max_clearance_m",
                                        number(&rooms.visible_touch_max_clearance_m)},
                                       {"visible_max_rounds", number(&visible_rounds)}},
                                      why);
         if (!ok) return false;
         if (seeding == "plateau") rooms.seeding = rooms::Seeding::kPlateau;
         else if (seeding == "persistence") rooms.seeding = rooms::Seeding::kPersistence;
         else return *why = "rooms.seeding: expected plateau or persistence, got '" + seeding + "'", false;
         if (!(min_component >= 1.0 && min_component <= 1e6))
           return *why = "rooms.min_component_size: expected 1 .. 1000000", false;
         rooms.min_component_size = static_cast<std::uint32_t>(min_component);
         if (!(split_min_component >= 1.0 && split_min_component <= 1e6))
           return *why = "rooms.split_min_component_size: expected 1 .. 1000000", false;
         rooms.split_min_component_size = static_cast<std::uint32_t>(split_min_component);
         // Whole numbers only; the range itself is rooms::Config::check's (with the rest of the rooms section).
         for (const auto& [value, field, out] :
              {std::tuple{corridor_neighbours, "corridor_min_neighbours", &rooms.corridor_min_neighbours},
               std::tuple{corridor_edges, "corridor_min_open_edges", &rooms.corridor_min_open_edges},
               std::tuple{visible_samples, "visible_samples", &rooms.visible_samples},
               std::tuple{visible_rounds, "visible_max_rounds", &rooms.visible_max_rounds},
               std::tuple{visible_local_places, "visible_local_min_places", &rooms.visible_local_min_places}}) {
           if (!whole_number_in(value, 0.0, 1e6))
             return *why = std::string("rooms.") + field + ": expected a whole number 0 .. 1000000", false;
           *out = static_cast<std::uint32_t>(value);
         }
         return true;
       }},
      {"doors", [&](const Json& v, std::string* why) {
         double every_n = doors_online_every_n;
         double misses = doors.online_misses_to_drop;
         if (!read_section(v, "doors",
                             {{"at_finish", boolean(&doors_at_finish)},
                              {"online", boolean(&doors_online)},
                              {"online_every_n_updates", number(&every_n)},
                              {"online_misses_to_drop", number(&misses)},
                              {"slice_above_robot_m", number(&doors.slice_above_robot_m)},
                              {"min_width_m", number(&doors.min_width_m)},
                              {"max_width_m", number(&doors.max_width_m)},
                              {"min_rise_m", number(&doors.min_rise_m)},
                              {"rise_reach_m", number(&doors.rise_reach_m)},
                              {"bypass_max_m", number(&doors.bypass_max_m)},
                              {"bypass_extension_m", number(&doors.bypass_extension_m)},
                              {"bypass_max_edge_m", number(&doors.bypass_max_edge_m)},
                              {"sight_min_wall_m", number(&doors.sight_min_wall_m)},
                              {"sight_wall_dilation_m", number(&doors.sight_wall_dilation_m)},
                              {"sight_furniture_max_m", number(&doors.sight_furniture_max_m)},
                              {"sight_furniture_min_width_m", number(&doors.sight_furniture_min_width_m)},
                              {"sight_cut_edges", boolean(&doors.sight_cut_edges)}},
                             why))
           return false;
         if (!whole_number_in(every_n, 1.0, 1e6))
           return *why = "doors.online_every_n_updates: expected an integer 1 .. 1000000", false;
         doors_online_every_n = static_cast<std::uint32_t>(every_n);
         if (!whole_number_in(misses, 1.0, 255.0))
           return *why = "doors.online_misses_to_drop: expected an integer 1 .. 255", false;
         doors.online_misses_to_drop = static_cast<int>(misses);
         return true;
       }},
      {"loop_closure", [&](const Json& v, std::string* why) {
         LoopClosure& lc = loop_closure;
         double min_inliers = lc.detector.registration.min_inliers;
         if (!read_section(v, "loop_closure",
                           {{"enabled", boolean(&lc.enabled)},
                            {"horizon_s", number(&lc.horizon_s)},
                            {"describe_every_m", number(&lc.describe_every_m)},
                            {"solve_interval_s", number(&lc.solve_interval_s)},
                            {"radius_m", number(&lc.descriptor.radius_m)},
                            {"places_threshold", number(&lc.detector.places_threshold)},
                            {"objects_threshold", number(&lc.detector.objects_threshold)},
                            {"min_time_separation_s", number(&lc.detector.min_time_separation_s)},
                            {"ratio", number(&lc.detector.ratio)},
                            {"noise_bound_m", number(&lc.detector.registration.noise_bound_m)},
                            {"min_inliers", number(&min_inliers)},
                            {"propose_unrefined_objects", boolean(&lc.detector.propose_unrefined_objects)},
                            {"sigma_position_m", number(&lc.deformation.sigma_position_m)}},
                           why))
           return false;
         if (!whole_number_in(min_inliers, 2.0, 256.0))
           return *why = "loop_closure.min_inliers: expected an integer 2 .. 256", false;
         lc.detector.registration.min_inliers = static_cast<std::uint32_t>(min_inliers);
         return true;
       }},
      {"frontend", [&](const Json& v, std::string* why) {
         return read_section(v, "frontend", {{"connect_interlayer", boolean(&frontend.connect_interlayer)}}, why);
       }},
      {"agents", [&](const Json& v, std::string* why) {
         agents::Config& a = frontend.agents;
         return read_section(v, "agents",
                             {{"min_translation_m", number(&a.min_translation_m)},
                              {"min_rotation_rad", number(&a.min_rotation_rad)},
                              {"max_interval_s", number(&a.max_interval_s)},
                              {"fold_at_fraction", number(&a.fold_at_fraction)}},
                             why);
       }},
      {"keyframes", [&](const Json& v, std::string* why) {
         return read_section(v, "keyframes",
                             {{"min_interval_s", number(&keyframes.min_interval_s)},
                              {"max_interval_s", number(&keyframes.max_interval_s)},
                              {"min_translation_m", number(&keyframes.min_translation_m)},
                              {"min_rotation_rad", number(&keyframes.min_rotation_rad)}},
                             why);
       }},
      {"replay", [&](const Json& v, std::string* why) {
         return read_section(v, "replay",
                             {{"format", text(&replay.format)},
                              {"calibration", text(&replay.calibration)},
                              {"fx", number(&replay.fx)},
                              {"fy", number(&replay.fy)},
                              {"cx", number(&replay.cx)},
                              {"cy", number(&replay.cy)},
                              {"depth_scale_m", number(&replay.depth_scale_m)},
                              {"frame_period_s", number(&replay.frame_period_s)},
                              {"check_files_at_open", boolean(&replay.check_files_at_open)}},
                             why);
       }},
      {"v4l2", [&](const Json& v, std::string* why) {
         return read_section(v, "v4l2",
                             {{"depth_device", text(&v4l2.depth_device)},
                              {"colour_device", text(&v4l2.colour_device)},
                              {"width", number(&v4l2.width)},
                              {"height", number(&v4l2.height)},
                              {"fx", number(&v4l2.fx)},
                              {"fy", number(&v4l2.fy)},
                              {"cx", number(&v4l2.cx)},
                              {"cy", number(&v4l2.cy)},
                              {"depth_scale_m", number(&v4l2.depth_scale_m)}},
                             why);
       }},
      {"odometry", [&](const Json& v, std::string* why) {
         std::string source = to_string(odometry.source);
         double seed = static_cast<double>(odometry.seed), port = odometry.stream_port;
         std::vector<double> t(odometry.body_t_camera_m, odometry.body_t_camera_m + 3);
         std::vector<double> q(odometry.body_q_camera_xyzw, odometry.body_q_camera_xyzw + 4);
         const auto vector_of = [](std::vector<double>* out, std::size_t n) -> Reader {
           return [out, n](const Json& j, std::string* w) {
             if (!j.is_array() || j.size() != n) return *w = "expected an array of " + std::to_string(n) + " numbers", false;
             for (std::size_t i = 0; i < n; ++i) {
               if (!j[i].is_number()) return *w = "expected an array of " + std::to_string(n) + " numbers", false;
               (*out)[i] = j[i].get<double>();
             }
             return true;
           };
         };
         runtime::PoseBufferConfig& b = odometry.buffer;
         if (!read_section(v, "odometry",
                           {{"source", text(&source)},
                            {"translation_sigma_m_per_sqrt_m", number(&odometry.translation_sigma_m_per_sqrt_m)},
                            {"yaw_sigma_rad_per_sqrt_m", number(&odometry.yaw_sigma_rad_per_sqrt_m)},
                            {"scale_bias", number(&odometry.scale_bias)},
                            {"yaw_bias_rad_per_m", number(&odometry.yaw_bias_rad_per_m)},
                            {"seed", number(&seed)},
                            {"tum_path", text(&odometry.tum_path)},
                            {"stream_transport", text(&odometry.stream_transport)},
                            {"stream_bind_address", text(&odometry.stream_bind_address)},
                            {"stream_port", number(&port)},
                            {"stream_unix_path", text(&odometry.stream_unix_path)},
                            {"silence_fault_s", number(&odometry.silence_fault_s)},
                            {"body_t_camera_m", vector_of(&t, 3)},
                            {"body_q_camera_xyzw", vector_of(&q, 4)},
                            {"max_gap_s", number(&b.max_gap_s)},
                            {"max_time_jump_s", number(&b.max_time_jump_s)},
                            {"max_speed_m_per_s", number(&b.max_speed_m_per_s)}},
                           why))
           return false;
         if (!odometry_source_from_string(source, &odometry.source))
           return *why = "odometry.source: expected auto, sim_drift, ground_truth, tum, stream or static, got '" +
                         source + "'", false;
         if (!whole_number_in(seed, 0.0, 9007199254740992.0))
           return *why = "odometry.seed: expected a non-negative integer", false;
         if (!whole_number_in(port, 0.0, 65535.0)) return *why = "odometry.stream_port: expected an integer 0 .. 65535", false;
         odometry.seed = static_cast<std::uint64_t>(seed);
         odometry.stream_port = static_cast<int>(port);
         std::copy(t.begin(), t.end(), odometry.body_t_camera_m);
         std::copy(q.begin(), q.end(), odometry.body_q_camera_xyzw);
         return true;
       }},
      {"segmentation", [&](const Json& v, std::string* why) {
         return read_section(v, "segmentation",
                             {{"model_path", text(&segmentation.model_path)},
                              {"label_map_path", text(&segmentation.label_map_path)},
                              {"deadline_s", number(&segmentation.deadline_s)},
                              {"min_interval_s", number(&segmentation.min_interval_s)},
                              {"min_confidence", number(&segmentation.min_confidence)},
                              {"backend", text(&segmentation.backend)},
                              {"target", text(&segmentation.target)},
                              {"fallback_to_cpu", boolean(&segmentation.fallback_to_cpu)},
                              {"opencv_threads", number(&segmentation.opencv_threads)}},
                             why);
       }},
      {"room_labels", [&](const Json& v, std::string* why) {
         return read_section(v, "room_labels", {{"weights_path", text(&room_weights_path)}}, why);
       }},
      {"gpio", [&](const Json& v, std::string* why) {
         return read_section(v, "gpio",
                             {{"chip", text(&gpio.chip)},
                              {"heartbeat_line", number(&gpio.heartbeat_line)},
                              {"trigger_line", number(&gpio.trigger_line)},
                              {"pause_line", number(&gpio.pause_line)},
                              {"trigger_width_s", number(&gpio.trigger_width_s)},
                              {"pause_debounce_s", number(&gpio.pause_debounce_s)}},
                             why);
       }},
      {"scheduler", [&](const Json& v, std::string* why) {
         return read_section(v, "scheduler", {{"tick_hz", number(&scheduler.tick_hz)}}, why);
       }},
  };
  std::string why;
  if (!read_section(doc, "config", top, &why)) return *error = "config '" + path + "': " + why, false;
  if (driver_name == "sim") driver = Driver::kSim;
  else if (driver_name == "replay") driver = Driver::kReplay;
  else if (driver_name == "v4l2") driver = Driver::kV4l2;
  else return *error = "config '" + path + "': driver: expected sim, replay or v4l2, got '" + driver_name + "'", false;
  const std::string bad = check();
  if (!bad.empty()) return *error = "config '" + path + "': " + bad, false;
  return true;
}

const char* to_string(OdometrySourceKind k) {
  switch (k) {
    case OdometrySourceKind::kAuto: return "auto";
    case OdometrySourceKind::kSimDrift: return "sim_drift";
    case OdometrySourceKind::kGroundTruth: return "ground_truth";
    case OdometrySourceKind::kTum: return "tum";
    case OdometrySourceKind::kStream: return "stream";
    case OdometrySourceKind::kStatic: return "static";
  }
  return "?";
}

bool odometry_source_from_string(const std::string& name, OdometrySourceKind* out) {
  for (OdometrySourceKind k : {OdometrySourceKind::kAuto, OdometrySourceKind::kSimDrift, OdometrySourceKind::kGroundTruth,
                               OdometrySourceKind::kTum, OdometrySourceKind::kStream, OdometrySourceKind::kStatic})
    if (name == to_string(k)) return *out = k, true;
  return false;
}

std::string AppConfig::check() const {
  if (driver == Driver::kReplay && replay_path.empty()) return "driver replay needs replay_path";
  if (const std::string r = replay.check(); !r.empty()) return "replay." + r;
  // Every section is checked whatever the driver: a bad value waiting in an unused section fails on the day the
  // section is used, far from the file that set it.
  if (v4l2.width < 16 || v4l2.height < 16 || v4l2.width > 640 || v4l2.height > 480)
    return "v4l2: width x height must be within 16x16 .. 640x480";
  if (!(v4l2.depth_scale_m > 0.0 && v4l2.depth_scale_m <= 1.0)) return "v4l2.depth_scale_m must be in (0, 1]";
  for (double f : {v4l2.fx, v4l2.fy})
    if (!(f == 0.0 || (f >= 1.0 && f <= 100000.0))) return "v4l2.fx and v4l2.fy must be 0 (default) or in [1, 100000]";
  if (!(v4l2.cx >= 0.0 && v4l2.cx <= v4l2.width && v4l2.cy >= 0.0 && v4l2.cy <= v4l2.height))
    return "v4l2.cx and v4l2.cy must be 0 (default) or within the image";
  if (output_dir.empty()) return "output_dir must not be empty";
  if (!segmentation.model_path.empty() && segmentation.label_map_path.empty())
    return "segmentation.label_map_path must be set with a model";
  if (!(segmentation.deadline_s > 0.0 && segmentation.deadline_s <= 60.0)) return "segmentation.deadline_s must be in (0, 60]";
  if (!(segmentation.min_interval_s >= 0.0 && segmentation.min_interval_s <= 60.0))
    return "segmentation.min_interval_s must be in [0, 60]";
  if (segmentation.backend != "opencv" && segmentation.backend != "cuda")
    return "segmentation.backend: expected opencv or cuda, got '" + segmentation.backend + "'";
  if (segmentation.target != "cpu" && segmentation.target != "cuda" && segmentation.target != "cuda_fp16")
    return "segmentation.target: expected cpu, cuda or cuda_fp16, got '" + segmentation.target + "'";
  if ((segmentation.backend == "cuda") != (segmentation.target != "cpu"))
    return "segmentation.target " + segmentation.target + " does not go with backend " + segmentation.backend +
           " (opencv runs cpu; cuda runs cuda or cuda_fp16)";
  if (segmentation.opencv_threads < 0 || segmentation.opencv_threads > 64)
    return "segmentation.opencv_threads must be in [0, 64]";
  if (!(segmentation.min_confidence >= 0.0f && segmentation.min_confidence <= 1.0f))
    return "segmentation.min_confidence must be in [0, 1]";
  if (gpio.chip.empty()) return "gpio.chip must not be empty (\"sim\" for the simulated chip)";
  for (int line : {gpio.heartbeat_line, gpio.trigger_line, gpio.pause_line})
    if (line < -1 || line > 1023) return "gpio lines must be -1 (unused) or an offset in [0, 1023]";
  if ((gpio.heartbeat_line >= 0 && (gpio.heartbeat_line == gpio.trigger_line || gpio.heartbeat_line == gpio.pause_line)) ||
      (gpio.trigger_line >= 0 && gpio.trigger_line == gpio.pause_line))
    return "gpio: heartbeat_line, trigger_line and pause_line must differ";
  if (!(gpio.trigger_width_s > 0.0 && gpio.trigger_width_s <= 1.0)) return "gpio.trigger_width_s must be in (0, 1]";
  if (!(gpio.pause_debounce_s >= 0.0 && gpio.pause_debounce_s <= 10.0)) return "gpio.pause_debounce_s must be in [0, 10]";
  // Times become int64 nanoseconds: kMaxTime_s (10^9 s; "never" in tests and benchmarks) keeps them from overflow.
  constexpr double kMaxTime_s = 1e9;
  if (!(duration_s >= 0.0 && duration_s <= kMaxTime_s)) return "duration_s must be in [0, 1e9]";
  if (!(snapshot_interval_s > 0.0 && snapshot_interval_s <= kMaxTime_s)) return "snapshot_interval_s must be in (0, 1e9]";
  if (!(telemetry_interval_s > 0.0 && telemetry_interval_s <= kMaxTime_s))
    return "telemetry_interval_s must be in (0, 1e9]";
  if (const std::string b = building.validate(); !b.empty()) return "building: " + b;
  if (const std::string e = exploration.check(); !e.empty()) return "exploration: " + e;
  if (const std::string c = camera.check(); !c.empty()) return "camera: " + c;
  if (const std::string r = reconstruction.check(); !r.empty()) return "reconstruction: " + r;
  if (const std::string f = frontend.check(); !f.empty()) return "frontend: " + f;
  if (const std::string r = rooms.check(); !r.empty()) return r;
  if (std::string d; !doors.validate(&d)) return d;
  if (const std::string k = keyframes.check(); !k.empty()) return "keyframes: " + k;
  if (const std::string o = check_odometry(); !o.empty()) return "odometry: " + o;
  if (const std::string s = scheduler.check(); !s.empty()) return "scheduler: " + s;
  if (const std::string l = loop_closure.check(); !l.empty()) return "loop_closure: " + l;
  return {};
}

std::string AppConfig::check_odometry() const {
  const Odometry& o = odometry;
  if (o.source == OdometrySourceKind::kSimDrift && driver != Driver::kSim) return "source sim_drift needs driver sim";
  if (o.source == OdometrySourceKind::kGroundTruth && driver == Driver::kV4l2)
    return "source ground_truth needs driver sim or replay (a live camera has no ground truth)";
  if (o.source == OdometrySourceKind::kTum && o.tum_path.empty()) return "source tum needs tum_path";
  for (double v : {o.translation_sigma_m_per_sqrt_m, o.yaw_sigma_rad_per_sqrt_m})
    if (!(v >= 0.0 && v <= 1.0)) return "drift sigmas must be in [0, 1] per sqrt(metre)";
  if (!(std::abs(o.scale_bias) <= 0.5)) return "scale_bias must be in [-0.5, 0.5]";
  if (!(std::abs(o.yaw_bias_rad_per_m) <= 0.5)) return "yaw_bias_rad_per_m must be in [-0.5, 0.5]";
  if (o.stream_transport != "udp" && o.stream_transport != "unix")
    return "stream_transport must be udp or unix, got '" + o.stream_transport + "'";
  if (o.stream_transport == "unix" && o.stream_unix_path.empty()) return "stream_unix_path must not be empty";
  if (!(o.silence_fault_s > 0.0 && o.silence_fault_s <= 3600.0)) return "silence_fault_s must be in (0, 3600]";
  for (double v : o.body_t_camera_m)
    if (!(std::abs(v) <= 10.0)) return "body_t_camera_m: each coordinate must be within 10 m";
  const double qn = std::sqrt(o.body_q_camera_xyzw[0] * o.body_q_camera_xyzw[0] + o.body_q_camera_xyzw[1] * o.body_q_camera_xyzw[1] +
                              o.body_q_camera_xyzw[2] * o.body_q_camera_xyzw[2] + o.body_q_camera_xyzw[3] * o.body_q_camera_xyzw[3]);
  if (!(std::abs(qn - 1.0) <= 1e-3)) return "body_q_camera_xyzw must be a unit quaternion";
  if (const std::string b = o.buffer.check(); !b.empty()) return b;
  return {};
}

void AppConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "app: driver=%s%s%s output_dir=%s duration_s=%.1f lockstep=%d snapshot_interval_s=%.1f "
               "telemetry_interval_s=%.1f telemetry_stores=%d lock_memory=%d ground_truth_labels=%d%s%s\n",
               to_string(driver), driver == Driver::kReplay ? " replay_path=" : "",
               driver == Driver::kReplay ? replay_path.c_str() : "", output_dir.c_str(), duration_s, lockstep ? 1 : 0,
               snapshot_interval_s, telemetry_interval_s, telemetry_stores ? 1 : 0, lock_memory ? 1 : 0,
               ground_truth_labels ? 1 : 0,
               fault_plan.empty() ? "" : " fault_plan=", fault_plan.c_str());
  if (driver == Driver::kReplay) {
    replay::DatasetReplayConfig r = replay;
    r.path = replay_path;
    r.print(out);
  }
  if (driver == Driver::kV4l2)
    std::fprintf(out, "v4l2: depth=%s colour=%s %dx%d depth_scale_m=%.5f\n", v4l2.depth_device.c_str(),
                 v4l2.colour_device.c_str(), v4l2.width, v4l2.height, v4l2.depth_scale_m);
  const Odometry& o = odometry;
  std::fprintf(out, "odometry: source=%s", to_string(o.source));
  if (o.source == OdometrySourceKind::kSimDrift || (o.source == OdometrySourceKind::kAuto && driver == Driver::kSim))
    std::fprintf(out, " drift %.4f m and %.4f rad per sqrt(m), scale_bias=%.4f yaw_bias_rad_per_m=%.5f seed=%llu",
                 o.translation_sigma_m_per_sqrt_m, o.yaw_sigma_rad_per_sqrt_m, o.scale_bias, o.yaw_bias_rad_per_m,
                 (unsigned long long)o.seed);
  if (o.source == OdometrySourceKind::kTum) std::fprintf(out, " tum_path=%s", o.tum_path.c_str());
  if (o.source == OdometrySourceKind::kStream) {
    if (o.stream_transport == "udp") std::fprintf(out, " udp %s:%d", o.stream_bind_address.c_str(), o.stream_port);
    else std::fprintf(out, " unix %s", o.stream_unix_path.c_str());
  }
  std::fprintf(out, " silence_fault_s=%.2f body_t_camera_m=[%g %g %g] body_q_camera_xyzw=[%g %g %g %g]\n",
               o.silence_fault_s, o.body_t_camera_m[0], o.body_t_camera_m[1], o.body_t_camera_m[2],
               o.body_q_camera_xyzw[0], o.body_q_camera_xyzw[1], o.body_q_camera_xyzw[2], o.body_q_camera_xyzw[3]);
  o.buffer.print(out);
  if (driver == Driver::kSim) {
    building.print(out);
    exploration.print(out);
    camera.print(out);
  }
  std::fprintf(out, "segmentation: %s%s%s deadline_s=%.2f min_interval_s=%.2f min_confidence=%.2f backend=%s "
               "target=%s fallback_to_cpu=%d opencv_threads=%d\n",
               segmentation.model_path.empty() ? "off (no model_path)" : segmentation.model_path.c_str(),
               segmentation.model_path.empty() ? "" : " label_map=",
               segmentation.model_path.empty() ? "" : segmentation.label_map_path.c_str(), segmentation.deadline_s,
               segmentation.min_interval_s, segmentation.min_confidence, segmentation.backend.c_str(),
               segmentation.target.c_str(), segmentation.fallback_to_cpu ? 1 : 0, segmentation.opencv_threads);
  std::fprintf(out,
               "doors: %s%s%s, slice %.2f m above the robot on each storey, widths %.2f .. %.2f m, rise %.2f m "
               "within %.2f m, dropped where the places go round within %.2f m (steps <= %.2f m, line + %.2f m); "
               "sight lines past walls >= %.1f m (thickened %.2f m; islands < %.1f m wider than %.2f m are "
               "furniture)%s\n",
               doors_online ? "online (every " : "",
               doors_online ? (std::to_string(doors_online_every_n) + ". backend update, dropped after " +
                               std::to_string(doors.online_misses_to_drop) + " missed passes), ")
                                  .c_str()
                            : "",
               doors_at_finish ? "found when the run finishes" : "not at the finish", doors.slice_above_robot_m, doors.min_width_m,
               doors.max_width_m, doors.min_rise_m, doors.rise_reach_m, doors.bypass_max_m, doors.bypass_max_edge_m,
               doors.bypass_extension_m, doors.sight_min_wall_m, doors.sight_wall_dilation_m,
               doors.sight_furniture_max_m, doors.sight_furniture_min_width_m,
               doors.sight_cut_edges ? ", place edges through them closed" : "");
  std::fprintf(out, "room_labels: weights_path=%s\n",
               room_weights_path.empty() ? "(built-in: core/neural_tree/weights/room_classifier_v4.json)"
                                         : room_weights_path.c_str());
  std::fprintf(out, "gpio: chip=%s heartbeat_line=%d trigger_line=%d pause_line=%d trigger_width_s=%.4f pause_debounce_s=%.3f\n",
               gpio.chip.c_str(), gpio.heartbeat_line, gpio.trigger_line, gpio.pause_line, gpio.trigger_width_s,
               gpio.pause_debounce_s);
  reconstruction.print(out);
  frontend.print(out);
  rooms.print(out);
  keyframes.print(out);
  scheduler.print(out);
}

}  // namespace qsg::app

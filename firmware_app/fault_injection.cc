// Fault plans in the running app: the file format, the source wrappers, store caps and recovery times.
#include "firmware_app/fault_injection.h"

#include <algorithm>
#include <cinttypes>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/json/json_guard.h"

namespace qsg::app {
namespace {

using Json = nlohmann::json;

bool read_caps(const Json& v, const std::string& origin, StoreCaps* caps, std::string* error) {
  const auto fail = [&](const std::string& field, const std::string& message) {
    return *error = origin + ": " + field + ": " + message, false;
  };
  if (!v.is_object()) return fail("stores", "expected an object of store: capacity");
  const scene_graph::Capacities board = scene_graph::capacities_from_budget();
  const struct {
    const char* name;
    std::size_t* cap;
    std::size_t board;
  } stores[] = {{"object_nodes", &caps->object_nodes, board.object_nodes},
                {"agent_nodes", &caps->agent_nodes, board.agent_nodes},
                {"place_nodes", &caps->place_nodes, board.place_nodes},
                {"room_nodes", &caps->room_nodes, board.room_nodes},
                {"edges", &caps->edges, board.edges}};
  for (auto it = v.begin(); it != v.end(); ++it) {
    const auto* s = std::find_if(std::begin(stores), std::end(stores),
                                 [&](const auto& e) { return it.key() == e.name; });
    if (s == std::end(stores))
      return fail("stores." + it.key(), "unknown store (expected object_nodes, agent_nodes, place_nodes, room_nodes, edges)");
    if (!it.value().is_number_integer() || it.value().get<std::int64_t>() < 1 ||
        it.value().get<std::int64_t>() > static_cast<std::int64_t>(s->board))
      return fail("stores." + it.key(), "expected an integer in [1, " + std::to_string(s->board) +
                                            "] (the board's capacity)");
    *s->cap = static_cast<std::size_t>(it.value().get<std::int64_t>());
  }
  return true;
}

}  // namespace

bool parse_app_fault_plan(const std::string& text, const std::string& origin, AppFaultPlan* plan, std::string* error) {
  Json doc;
  if (json_guard::ParseFailure f; !json_guard::parse(text, json_guard::Limits{}, &doc, &f))
    return *error = origin + ": " + (f.kind == json_guard::ParseFailure::Kind::kSyntax ? "not valid JSON: " : "") +
                    f.message,
           false;
  if (!doc.is_object())
    return *error = origin + ": expected an object with camera, odometry and stores (firmware_app/FAULT_PLAN.md)", false;
  AppFaultPlan result;
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    const std::string& key = it.key();
    if (key == "camera" || key == "odometry") {
      if (!it.value().is_object()) return *error = origin + ": " + key + ": expected a fault plan object", false;
      sim::FaultPlan& p = key == "camera" ? result.camera : result.odometry;
      if (!sim::parse_fault_plan_json(it.value().dump(), origin + ": " + key, &p, error)) return false;
      (key == "camera" ? result.has_camera : result.has_odometry) = true;
    } else if (key == "stores") {
      if (!read_caps(it.value(), origin, &result.stores, error)) return false;
    } else {
      return *error = origin + ": " + key + ": unknown key (expected camera, odometry, stores)", false;
    }
  }
  *plan = std::move(result);
  return true;
}

bool load_app_fault_plan(const std::string& path, AppFaultPlan* plan, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return *error = "fault plan '" + path + "': cannot open", false;
  std::ostringstream text;
  text << in.rdbuf();
  return parse_app_fault_plan(text.str(), "fault plan '" + path + "'", plan, error);
}

bool FaultInjection::init(const std::string& path, std::string* error) {
  path_ = path;
  if (path.empty()) return true;
  return load_app_fault_plan(path, &plan_, error);
}

scene_graph::Capacities FaultInjection::capped(scene_graph::Capacities c) const {
  const StoreCaps& s = plan_.stores;
  const auto cap = [](std::size_t* v, std::size_t limit) {
    if (limit > 0) *v = std::min(*v, limit);
  };
  cap(&c.object_nodes, s.object_nodes);
  cap(&c.agent_nodes, s.agent_nodes);
  cap(&c.place_nodes, s.place_nodes);
  cap(&c.room_nodes, s.room_nodes);
  cap(&c.edges, s.edges);
  return c;
}

drivers::RgbdSource* FaultInjection::wrap_camera(drivers::RgbdSource* inner) {
  if (!plan_.has_camera || inner == nullptr || camera_ != nullptr) return inner;
  camera_ = std::make_unique<sim::FaultInjectingRgbdSource>(*inner, plan_.camera);
  return camera_.get();
}

drivers::OdometrySource* FaultInjection::wrap_odometry(drivers::OdometrySource* inner) {
  if (!plan_.has_odometry || inner == nullptr || odometry_ != nullptr) return inner;
  odometry_ = std::make_unique<sim::FaultInjectingOdometrySource>(*inner, plan_.odometry);
  return odometry_.get();
}

void FaultInjection::note_end(const sim::FaultInjector& injector, std::uint64_t* seen) {
  if (injector.faults_ended() == *seen) return;
  recovery_.faults_ended += injector.faults_ended() - *seen;
  pending_ends_ += injector.faults_ended() - *seen;
  *seen = injector.faults_ended();
  recovery_.last_end_ns = std::max(recovery_.last_end_ns, injector.last_fault_end_ns());
  recovery_.waiting = true;
}

void FaultInjection::settle() {
  if (camera_ != nullptr) note_end(camera_->injector(), &camera_ends_seen_);
  if (odometry_ != nullptr) note_end(odometry_->injector(), &odometry_ends_seen_);
}

void FaultInjection::on_keyframe_integrated(std::int64_t sample_time_ns, std::int64_t now_loop_ns,
                                            std::int64_t due_loop_ns) {
  settle();
  FaultRecovery& r = recovery_;
  if (r.catching_up && now_loop_ns - due_loop_ns <= kCaughtUpNs) {
    r.catching_up = false;
    r.max_catch_up_ns = std::max(r.max_catch_up_ns, now_loop_ns - catch_up_start_ns_);
  }
  if (!r.waiting || sample_time_ns < r.last_end_ns) return;
  r.waiting = false;
  r.recovered += pending_ends_;
  pending_ends_ = 0;
  r.last_recovery_ns = sample_time_ns - r.last_end_ns;
  r.max_recovery_ns = std::max(r.max_recovery_ns, r.last_recovery_ns);
  if (now_loop_ns - due_loop_ns > kCaughtUpNs) {
    r.catching_up = true;
    catch_up_start_ns_ = now_loop_ns;
  } else if (!r.catching_up) {
    r.max_catch_up_ns = std::max<std::int64_t>(r.max_catch_up_ns, 0);
  }
}

void FaultInjection::print_plan(std::FILE* out) const {
  if (!active()) return;
  std::fprintf(out, "fault plan %s:\n", path_.c_str());
  if (plan_.has_camera) std::fprintf(out, "  camera "), plan_.camera.print(out);
  if (plan_.has_odometry) std::fprintf(out, "  odometry "), plan_.odometry.print(out);
  if (plan_.stores.any())
    std::fprintf(out, "  stores capped: object_nodes=%zu agent_nodes=%zu place_nodes=%zu room_nodes=%zu edges=%zu (0: board)\n",
                 plan_.stores.object_nodes, plan_.stores.agent_nodes, plan_.stores.place_nodes, plan_.stores.room_nodes,
                 plan_.stores.edges);
}

void FaultInjection::print_report(std::FILE* out) const {
  if (!active()) return;
  const auto injected = [&](const char* what, const sim::FaultTally& tally) {
    std::fprintf(out, "faults injected into the %s:", what);
    for (int k = 0; k < sim::kNumFaultKinds; ++k)
      std::fprintf(out, " %s=%" PRIu64, sim::to_string(static_cast<sim::FaultKind>(k)), tally[static_cast<std::size_t>(k)]);
    std::fprintf(out, "\n");
  };
  if (camera_ != nullptr) injected("camera", camera_->injected());
  if (odometry_ != nullptr) injected("odometry", odometry_->injected());
  const FaultRecovery& r = recovery_;
  std::fprintf(out,
               "fault recovery: %" PRIu64 " fault ends, %" PRIu64 " followed by an integrated keyframe; latest %.3f s, "
               "longest %.3f s after the fault ended (data time); back within %.2f s of real time %.3f s after "
               "(loop time, longest)%s%s\n",
               r.faults_ended, r.recovered, r.last_recovery_ns >= 0 ? 1e-9 * static_cast<double>(r.last_recovery_ns) : -1.0,
               r.max_recovery_ns >= 0 ? 1e-9 * static_cast<double>(r.max_recovery_ns) : -1.0, 1e-9 * kCaughtUpNs,
               r.max_catch_up_ns >= 0 ? 1e-9 * static_cast<double>(r.max_catch_up_ns) : -1.0,
               r.waiting ? "; NOT RECOVERED: no keyframe integrated after the latest fault ended" : "",
               r.catching_up ? "; STILL BEHIND real time at the end" : "");
}

}  // namespace qsg::app

// Fault plans in the running app (`--fault-plan FILE`, config key `fault_plan`): the camera (sim, replay or V4L2)
// and the odometry source (sim drift, ground truth, TUM estimate or pose stream) are wrapped in the fault-injecting
// decorators of drivers/sim/fault_plan.h, and the scene graph's stores can be capped below the board's budget so
// one fills during the run. The app file format is documented in firmware_app/FAULT_PLAN.md:
//
//   {"camera":   {"seed": 1, "rates": {"drop": 0.3}, "random": {"from": 300, "until": 600}},
//    "odometry": {"events": [{"at": 900, "fault": "pose_jump", "offset_m": [2, 0, 0], "samples": 5}]},
//    "stores":   {"place_nodes": 150}}
//
// Every key is optional; unknown and duplicated keys are errors naming the file and the key. Everything is built
// at start-up; after it, reads through the decorators and the recovery bookkeeping do not allocate.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "core/scene_graph/scene_graph.h"
#include "drivers/sim/fault_plan.h"
#include "drivers/sources.h"

namespace qsg::app {

// Caps on the scene graph's stores (0: the board's capacity). A cap must not exceed the board's capacity.
struct StoreCaps {
  std::size_t object_nodes = 0;
  std::size_t agent_nodes = 0;
  std::size_t place_nodes = 0;
  std::size_t room_nodes = 0;
  std::size_t edges = 0;
  bool any() const { return object_nodes + agent_nodes + place_nodes + room_nodes + edges > 0; }
};

struct AppFaultPlan {
  bool has_camera = false;
  bool has_odometry = false;
  sim::FaultPlan camera;
  sim::FaultPlan odometry;
  StoreCaps stores;
};

// Reads and checks an app fault-plan file (JSON). Errors name the file and the key path
// ("plan.json: camera: events[0].reads: expected a positive integer").
bool load_app_fault_plan(const std::string& path, AppFaultPlan* plan, std::string* error);
bool parse_app_fault_plan(const std::string& text, const std::string& origin, AppFaultPlan* plan, std::string* error);

// Recovery from a fault: from the fault's end (the sample time of the first message its source delivered clean)
// to the sample time of the first keyframe integrated at or after it (the data clock, i.e. simulated time).
// Catch-up: on the loop clock (simulated time in lockstep), from the first keyframe integrated after a fault's end
// until a keyframe is integrated within kCaughtUpNs of its due time again (a stall or an unplug leaves a backlog of
// frames the loop works through).
struct FaultRecovery {
  std::uint64_t faults_ended = 0;  // fault ends seen (camera and odometry together)
  std::uint64_t recovered = 0;     // ... followed by an integrated keyframe (ends before it count once each)
  std::int64_t last_end_ns = -1;   // sample time of the latest fault end (-1: none)
  std::int64_t last_recovery_ns = -1;
  std::int64_t max_recovery_ns = -1;
  std::int64_t max_catch_up_ns = -1;  // loop time to be back within kCaughtUpNs of real time
  bool waiting = false;  // a fault ended and no keyframe has been integrated since (at the end: not recovered)
  bool catching_up = false;
};
inline constexpr std::int64_t kCaughtUpNs = 250'000'000;  // the odometry's frame wait bound on both boards

class FaultInjection {
 public:
  FaultInjection() = default;
  FaultInjection(const FaultInjection&) = delete;
  FaultInjection& operator=(const FaultInjection&) = delete;

  // Loads the plan ("" = no faults: the wrappers return their input). Start-up only.
  bool init(const std::string& path, std::string* error);
  bool active() const { return !path_.empty(); }
  const std::string& path() const { return path_; }
  const AppFaultPlan& plan() const { return plan_; }

  // The scene graph's capacities with the plan's caps applied.
  scene_graph::Capacities capped(scene_graph::Capacities c) const;
  // The source to read: a decorator around `inner` when the plan has a section for it, else `inner`. Once each.
  drivers::RgbdSource* wrap_camera(drivers::RgbdSource* inner);
  drivers::OdometrySource* wrap_odometry(drivers::OdometrySource* inner);
  const sim::FaultInjectingRgbdSource* camera() const { return camera_.get(); }
  const sim::FaultInjectingOdometrySource* odometry() const { return odometry_.get(); }

  // Called for every keyframe integrated, with its sample time, the loop time now and the loop time it was due
  // (its sample time on the loop clock). Allocation-free.
  void on_keyframe_integrated(std::int64_t sample_time_ns, std::int64_t now_loop_ns, std::int64_t due_loop_ns);
  // At the end of the run: takes in fault ends no keyframe followed (recovery().waiting then says so).
  void settle();
  const FaultRecovery& recovery() const { return recovery_; }

  void print_plan(std::FILE* out) const;
  // One line per wrapped source (faults injected per kind) and the recovery; nothing without a plan.
  void print_report(std::FILE* out) const;

 private:
  void note_end(const sim::FaultInjector& injector, std::uint64_t* seen);

  std::string path_;
  AppFaultPlan plan_;
  std::unique_ptr<sim::FaultInjectingRgbdSource> camera_;
  std::unique_ptr<sim::FaultInjectingOdometrySource> odometry_;
  std::uint64_t camera_ends_seen_ = 0;
  std::uint64_t odometry_ends_seen_ = 0;
  std::uint64_t pending_ends_ = 0;       // fault ends no keyframe has followed yet
  std::int64_t catch_up_start_ns_ = 0;   // loop time of the first keyframe after the latest fault end
  FaultRecovery recovery_;
};

}  // namespace qsg::app

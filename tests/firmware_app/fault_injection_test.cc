// Fault plans in the running app: the file format refuses nonsense by name, the camera and the odometry are read
// through the plan's decorators, every injected fault shows in the exit report (and its JSON), the run recovers,
// and steady-state ticks with faults firing allocate nothing.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "firmware_app/exit_report.h"
#include "firmware_app/fault_injection.h"
#include "firmware_app/pipeline.h"
#include "tests/support/allocation_counter.h"
#include "tests/firmware_app/run_app.h"
#include "tests/support/emulation.h"

extern char** environ;

namespace qsg::app {
namespace {

std::string temp_dir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/qsg_faults_" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

AppConfig small_config(const std::string& dir) {
  AppConfig c;
  c.output_dir = dir + "/out";
  c.building.num_rooms = 4;
  c.building.seed = 3;
  c.camera.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  c.snapshot_interval_s = 1e6;
  c.telemetry_interval_s = 1e6;
  return c;
}

// value of report[group][key]; fails the test when absent.
double value(const std::vector<ReportGroup>& report, const std::string& group, const std::string& key) {
  for (const ReportGroup& g : report) {
    if (g.name != group) continue;
    for (const auto& [k, v] : g.values)
      if (k == key) return v;
  }
  ADD_FAILURE() << "no " << group << "." << key << " in the exit report";
  return -1.0;
}

TEST(AppFaultPlan, ParsesEverySectionAndCapsTheStores) {
  AppFaultPlan plan;
  std::string error;
  ASSERT_TRUE(parse_app_fault_plan(
      R"({"camera": {"rates": {"drop": 0.3}, "random": {"from": 10, "until": 20}},
          "odometry": {"events": [{"at": 5, "fault": "pose_jump", "offset_m": [1, 0, 0]}]},
          "stores": {"place_nodes": 50, "object_nodes": 7}})",
      "p.json", &plan, &error))
      << error;
  EXPECT_TRUE(plan.has_camera);
  EXPECT_TRUE(plan.has_odometry);
  EXPECT_DOUBLE_EQ(plan.camera.random.rate[static_cast<int>(sim::FaultKind::kDrop)], 0.3);
  EXPECT_EQ(plan.camera.random.until, 20u);
  ASSERT_EQ(plan.odometry.events.size(), 1u);
  EXPECT_EQ(plan.stores.place_nodes, 50u);
  EXPECT_EQ(plan.stores.object_nodes, 7u);
  EXPECT_EQ(plan.stores.room_nodes, 0u);

  FaultInjection f;
  const std::string dir = temp_dir("caps");
  ASSERT_TRUE(f.init(write(dir + "/p.json", R"({"stores": {"place_nodes": 50}})"), &error)) << error;
  const scene_graph::Capacities board = scene_graph::capacities_from_budget();
  const scene_graph::Capacities c = f.capped(board);
  EXPECT_EQ(c.place_nodes, 50u);
  EXPECT_EQ(c.object_nodes, board.object_nodes);
  EXPECT_EQ(c.edges, board.edges);
}

TEST(AppFaultPlan, RefusesNonsenseByName) {
  const std::string big = std::to_string(scene_graph::capacities_from_budget().place_nodes + 1);
  const std::pair<std::string, std::string> cases[] = {
      {R"({"camera": {"rates": {"drop": 2}}})", "p.json: camera: rates.drop: expected a probability in [0, 1]"},
      {R"({"odometry": {"events": [{"at": 1, "fault": "stall", "reads": 0}]}})",
       "p.json: odometry: events[0].reads: expected a positive integer"},
      {R"({"camera": {}, "camera": {}})", "p.json: camera: duplicated key"},
      {R"({"cmaera": {}})", "p.json: cmaera: unknown key (expected camera, odometry, stores)"},
      {R"({"camera": 3})", "p.json: camera: expected a fault plan object"},
      {R"({"stores": {"places": 3}})", "p.json: stores.places: unknown store"},
      {R"({"stores": {"place_nodes": 0}})", "p.json: stores.place_nodes: expected an integer in [1, "},
      {R"({"stores": {"place_nodes": 1.5}})", "p.json: stores.place_nodes: expected an integer"},
      {R"({"stores": {"place_nodes": )" + big + "}}", "(the board's capacity)"},
      {"[1]", "p.json: expected an object"},
      {"{\"camera\": ", "p.json: not valid JSON"},
  };
  for (const auto& [text, expected] : cases) {
    AppFaultPlan plan;
    std::string error;
    EXPECT_FALSE(parse_app_fault_plan(text, "p.json", &plan, &error)) << text;
    EXPECT_NE(error.find(expected), std::string::npos) << "input: " << text << "\nerror: " << error;
  }
  FaultInjection f;
  std::string error;
  EXPECT_FALSE(f.init("/no/such/plan.json", &error));
  EXPECT_NE(error.find("fault plan '/no/such/plan.json': cannot open"), std::string::npos) << error;
}

// The camera and the odometry both run through the plan: every fault it injects is in the exit report, the
// pipeline's own counters see the consequences, and the run recovers from each fault within a second of data time.
TEST(AppFaultInjection, EveryInjectedFaultShowsInTheExitReportAndTheRunRecovers) {
  const std::string dir = temp_dir("report");
  AppConfig config = small_config(dir);
  config.duration_s = 25.0;
  // Camera at 10 Hz, odometry at 30 Hz (the tour's rate).
  config.fault_plan = write(dir + "/plan.json", R"({
    "camera": {"seed": 2, "rates": {"drop": 0.3}, "random": {"from": 20, "until": 60},
               "events": [{"at": 80, "fault": "stall", "reads": 100},
                          {"at": 90, "fault": "unplug", "reads": 50},
                          {"at": 100, "fault": "backwards", "back_ms": 30},
                          {"at": 105, "fault": "late", "delay_ms": 40},
                          {"at": 110, "fault": "depth_nan", "rect": [0, 0, 80, 60]},
                          {"at": 115, "fault": "wrong_size"}]},
    "odometry": {"events": [{"at": 420, "fault": "dropout", "samples": 45},
                            {"at": 540, "fault": "pose_jump", "offset_m": [3, 0, 0], "samples": 1}]}})");
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  ASSERT_NE(p.faults().camera(), nullptr);
  ASSERT_NE(p.faults().odometry(), nullptr);
  while (p.step()) {
  }
  ASSERT_TRUE(p.finish(&error)) << error;
  const std::vector<ReportGroup> report = collect_exit_report(p);
  const sim::FaultTally& cam = p.faults().camera()->injected();
  const auto kind = [](sim::FaultKind k) { return static_cast<std::size_t>(k); };
  ASSERT_GT(cam[kind(sim::FaultKind::kDrop)], 0u);
  EXPECT_EQ(value(report, "camera", "dropped"), static_cast<double>(cam[kind(sim::FaultKind::kDrop)]));
  EXPECT_EQ(value(report, "camera", "stalls"), 100.0);
  EXPECT_EQ(value(report, "camera", "disconnects"), 1.0);
  EXPECT_EQ(value(report, "camera", "reconnects"), 1.0);
  EXPECT_EQ(value(report, "camera", "timestamps_backwards"), 1.0);
  EXPECT_EQ(value(report, "camera", "late"), 1.0);
  EXPECT_EQ(value(report, "camera", "invalid_depth_frames"), 1.0);
  EXPECT_EQ(value(report, "camera", "bad_frames"), 1.0);
  EXPECT_EQ(value(report, "pipeline", "frames_bad"), 1.0);
  EXPECT_EQ(value(report, "faults", "camera.unplug"), 1.0);
  EXPECT_EQ(value(report, "odometry_driver", "dropped"), 45.0);
  EXPECT_EQ(value(report, "faults", "odometry.dropout"), 1.0);
  EXPECT_EQ(value(report, "faults", "odometry.pose_jump"), 1.0);
  // A 1.5 s dropout leaves a gap no pose is interpolated across: frames inside it are dropped and counted.
  EXPECT_GE(value(report, "odometry", "gaps"), 1.0);
  EXPECT_GT(value(report, "pipeline", "frames_without_pose"), 0.0);
  // A 3 m jump in 33 ms is faster than the pose buffer allows: rejected, counted.
  EXPECT_EQ(value(report, "odometry", "rejected_pose_jumps"), 1.0);
  // Recovery: every fault end was followed by an integrated keyframe, within a second of data time.
  EXPECT_GT(value(report, "faults", "fault_ends"), 5.0);
  EXPECT_EQ(value(report, "faults", "not_recovered"), 0.0);
  EXPECT_EQ(value(report, "faults", "recovered"), value(report, "faults", "fault_ends"));
  EXPECT_GE(value(report, "faults", "max_recovery_s"), 0.0);
  EXPECT_LE(value(report, "faults", "max_recovery_s"), 1.0);
  // The 0.5 s stall and the 0.25 s unplug leave a backlog of frames the loop works through within a second.
  EXPECT_GE(value(report, "faults", "max_catch_up_s"), 0.0);
  EXPECT_LE(value(report, "faults", "max_catch_up_s"), 1.0);
  EXPECT_EQ(value(report, "faults", "still_behind"), 0.0);
  EXPECT_GT(p.counters().keyframes_integrated, 50u);

  std::ostringstream text;
  char buffer[1 << 16] = {};
  std::FILE* out = fmemopen(buffer, sizeof(buffer) - 1, "w");
  ASSERT_NE(out, nullptr);
  print_exit_report(report, out);
  std::fclose(out);
  const std::string printed(buffer);
  EXPECT_NE(printed.find("camera sim_camera: delivered="), std::string::npos) << printed;
  EXPECT_NE(printed.find(" stalls=100 "), std::string::npos) << printed;
  EXPECT_NE(printed.find("stores: refused_total=0 "), std::string::npos) << printed;
  EXPECT_NE(printed.find("scene_graph.places.refused=0"), std::string::npos) << printed;
}

// A store capped below what the run needs fills: the release build refuses and counts (the test build aborts on
// overflow, so the refusal itself is the fault suite's to show); here the cap reaches the graph.
TEST(AppFaultInjection, StoreCapsReachTheGraph) {
  const std::string dir = temp_dir("caps_graph");
  AppConfig config = small_config(dir);
  config.fault_plan = write(dir + "/plan.json", R"({"stores": {"room_nodes": 40, "place_nodes": 3000}})");
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  EXPECT_EQ(p.graph().capacities().room_nodes, 40u);
  EXPECT_EQ(p.graph().capacities().place_nodes, 3000u);
  EXPECT_EQ(p.faults().camera(), nullptr);
  EXPECT_EQ(p.faults().odometry(), nullptr);
}

// A full place store shows under the store's own name: the places stage checks for room before asking (so the
// test build, which aborts on overflow, counts rather than aborts), and counts the request on the store it found
// full, so the stores line of the exit report and the telemetry line name it, not only the stage's counter.
TEST(AppFaultInjection, AFullStoreShowsUnderItsOwnName) {
  const std::string dir = temp_dir("full_places");
  AppConfig config = small_config(dir);
  config.fault_plan = write(dir + "/plan.json", R"({"stores": {"place_nodes": 12}})");
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  for (int k = 0; k < 3000 && p.step(); ++k) {
  }
  EXPECT_EQ(p.graph().num_nodes(scene_graph::NodeKind::kPlace), 12u);
  const std::vector<ReportGroup> report = collect_exit_report(p);
  const double stage = value(report, "places", "graph_refused");
  const double store = value(report, "stores", "scene_graph.places.refused");
  EXPECT_GT(store, 0.0) << "the place store's own refusals";
  EXPECT_LE(store, stage) << "the stage counts its refused edges too";
  EXPECT_GE(value(report, "stores", "refused_total"), store);
  EXPECT_EQ(value(report, "stores", "scene_graph.places.high_water"), 12.0);

  char buffer[1 << 16] = {};
  std::FILE* out = fmemopen(buffer, sizeof(buffer) - 1, "w");
  ASSERT_NE(out, nullptr);
  p.print_telemetry(out);
  p.print_telemetry_stores(out, 1.0);
  std::fclose(out);
  const std::string printed(buffer);
  const std::string named = "refused by store: scene_graph.places=" + std::to_string(static_cast<long long>(store));
  EXPECT_NE(printed.find(named), std::string::npos) << printed;
  EXPECT_NE(printed.find(" scene_graph.places=12/12/12/" + std::to_string(static_cast<long long>(store))),
            std::string::npos)
      << printed;
}

// Without a full store the telemetry line says so, and the stores line carries the memory figures the soak reads.
TEST(AppFaultInjection, TelemetryNamesNoStoreOnAHealthyRun) {
  const std::string dir = temp_dir("healthy");
  AppConfig config = small_config(dir);
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  for (int k = 0; k < 600 && p.step(); ++k) {
  }
  char buffer[1 << 16] = {};
  std::FILE* out = fmemopen(buffer, sizeof(buffer) - 1, "w");
  ASSERT_NE(out, nullptr);
  p.print_telemetry(out);
  p.print_telemetry_stores(out, 3.0);
  std::fclose(out);
  const std::string printed(buffer);
  EXPECT_NE(printed.find("refused by store: none"), std::string::npos) << printed;
  EXPECT_NE(printed.find("[t=    3.0s] stores rss_kb="), std::string::npos) << printed;
  EXPECT_EQ(printed.find("rss_kb=0 "), std::string::npos) << "the resident set is read from /proc: " << printed;
  EXPECT_NE(printed.find(" | arenas reconstruction="), std::string::npos) << printed;
  EXPECT_NE(printed.find(" scene_graph.places="), std::string::npos) << printed;
  EXPECT_NE(printed.find(" | counters camera.dropped=0 "), std::string::npos) << printed;
  EXPECT_NE(printed.find(" | traffic pipeline.keyframes_integrated="), std::string::npos) << printed;
}

TEST(AppFaultInjection, SteadyStateTicksWithFaultsFiringDoNotAllocate) {
  const std::string dir = temp_dir("alloc");
  AppConfig config = small_config(dir);
  config.fault_plan = write(dir + "/plan.json", R"({
    "camera": {"seed": 4, "rates": {"drop": 0.2, "stall": 0.05, "late": 0.1, "backwards": 0.05, "depth_zero": 0.1,
                                    "unplug": 0.01, "wrong_size": 0.02, "dropout": 0.01},
               "random": {"region": [40, 30], "dropout_samples": 3}},
    "odometry": {"seed": 5, "rates": {"drop": 0.1, "stall": 0.02, "dropout": 0.005},
                 "events": [{"at": 400, "fault": "pose_jump", "offset_m": [0, 2, 0], "samples": 2}]}})");
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  while (p.counters().keyframes_integrated < 20 && p.step()) {
  }
  const std::uint64_t before = p.counters().keyframes_integrated;
  EXPECT_NO_ALLOCATIONS({
    for (int k = 0; k < 2000 && p.step(); ++k) {
    }
  });
  EXPECT_GT(p.counters().keyframes_integrated, before + 20);
  EXPECT_GT(p.camera()->counters().dropped, 0u);
  EXPECT_GT(p.odometry().driver_counters()->dropped, 0u);
}

using testing::run_app;

TEST(AppFaultPlanFlag, TheAppTakesAPlanReportsItsFaultsAndRefusesABadOne) {
  if (qsg::testing::running_emulated())
    GTEST_SKIP() << "under qemu-user a test cannot start the arm64 qsg_app (no binfmt_misc)";
  const std::string dir = temp_dir("flag");
  const std::string plan =
      write(dir + "/plan.json", R"({"camera": {"events": [{"at": 30, "fault": "dropout", "samples": 5}]}})");
  std::string output;
  ASSERT_EQ(run_app({"--rooms", "4", "--duration", "8", "--output", dir + "/out", "--quiet", "--fault-plan", plan,
                     "--report-json", dir + "/report.json"},
                    dir + "/run.log", &output),
            0)
      << output;
  EXPECT_NE(output.find("fault plan " + plan + ":"), std::string::npos) << output;
  EXPECT_NE(output.find("faults injected into the camera: drop=0"), std::string::npos) << output;
  EXPECT_NE(output.find(" dropout=1 "), std::string::npos) << output;
  std::ifstream in(dir + "/report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["exit_status"], 0);
  EXPECT_EQ(report["camera"]["dropped"], 5.0);
  EXPECT_EQ(report["camera"]["source"], "sim_camera");
  EXPECT_EQ(report["faults"]["camera.dropout"], 1.0);
  EXPECT_EQ(report["faults"]["not_recovered"], 0.0);
  EXPECT_TRUE(report.contains("stores"));
  EXPECT_TRUE(report["stores"].contains("scene_graph.places.refused"));

  const std::string bad = write(dir + "/bad.json", R"({"camera": {"events": [{"at": 1, "fault": "stal"}]}})");
  EXPECT_EQ(run_app({"--fault-plan", bad, "--output", dir + "/out2"}, dir + "/bad.log", &output), 2) << output;
  EXPECT_NE(output.find("qsg_app: fault plan '" + bad + "': camera: events[0].fault: expected one of drop"),
            std::string::npos)
      << output;
}

}  // namespace
}  // namespace qsg::app

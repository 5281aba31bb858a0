// The exit report: every counter a driver or stage of the pipeline keeps, in one place, as text lines
// ("camera sim_camera: delivered=... dropped=...") and as JSON ({"camera": {"delivered": ...}, ...}) for tools
// (the fault suite reads it). Groups: pipeline, camera, odometry, odometry_driver, queues, reconstruction, places,
// objects, frontend, agents, rooms, stores (refused, high water and capacity of every store), tasks (overruns,
// slips, skips, deferrals), memory (resident set, page faults, mlockall) and faults (injected per kind, recovery), the last only with a fault plan.
// Built after the run, off the real-time path (it allocates).
#pragma once

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace qsg::app {

class Pipeline;

struct ReportGroup {
  std::string name;   // JSON key and the line's first word
  std::string label;  // printed after the name (a driver's name), not in JSON's values
  std::vector<std::pair<std::string, double>> values;
  void add(const std::string& key, double value) { values.emplace_back(key, value); }
};

std::vector<ReportGroup> collect_exit_report(const Pipeline& pipeline);
// The telemetry line's fault segment and its end (" | faults late=... \n"): the counters the line's first part
// leaves out. Called on the loop thread; allocation-free.
void print_telemetry_faults(const Pipeline& pipeline, std::FILE* out);
// AppConfig::telemetry_stores' line's end: " | counters <group>.<key>=N ... (every fault counter, exit-report
// names; none grows on a healthy run) | load ... (budget misses on the wall clock) | traffic ... (counts a healthy
// run grows)\n". Allocation-free.
void print_telemetry_counters(const Pipeline& pipeline, std::FILE* out);
// One line per group.
void print_exit_report(const std::vector<ReportGroup>& report, std::FILE* out);
// {"<group>": {"source": "<label>", "<key>": value, ...}, ..., "exit_status": exit_status}, written atomically.
bool write_exit_report_json(const std::vector<ReportGroup>& report, int exit_status, const std::string& path,
                            std::string* error);

}  // namespace qsg::app

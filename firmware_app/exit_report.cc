// The exit report: every counter of the run, as text lines and JSON.
#include "firmware_app/exit_report.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "firmware_app/memory_lock.h"
#include "firmware_app/pipeline.h"

namespace qsg::app {
namespace {

using U = double;

ReportGroup driver_group(const char* name, const char* label, const drivers::DriverCounters& d) {
  ReportGroup g{name, label, {}};
  g.add("delivered", U(d.delivered));
  g.add("dropped", U(d.dropped));
  g.add("stalls", U(d.stalls));
  g.add("late", U(d.late));
  g.add("timestamps_backwards", U(d.timestamps_backwards));
  g.add("invalid_depth_frames", U(d.invalid_depth_frames));
  g.add("bad_frames", U(d.bad_frames));
  g.add("disconnects", U(d.disconnects));
  g.add("reconnects", U(d.reconnects));
  g.add("missing_files", U(d.missing_files));
  return g;
}

ReportGroup pipeline_group(const PipelineCounters& c) {
  ReportGroup g{"pipeline", "", {}};
  g.add("frames_read", U(c.frames_read));
  g.add("frames_bad", U(c.frames_bad));
  g.add("frames_without_pose", U(c.frames_without_pose));
  g.add("frames_paused", U(c.frames_paused));
  g.add("keyframes", U(c.keyframes));
  g.add("keyframes_integrated", U(c.keyframes_integrated));
  g.add("keyframes_refused", U(c.keyframes_refused));
  g.add("keyframes_segmented", U(c.keyframes_segmented));
  g.add("keyframes_unlabelled", U(c.keyframes_unlabelled));
  g.add("frontend_updates", U(c.frontend_updates));
  g.add("frontend_deadline_stops", U(c.frontend_deadline_stops));
  g.add("agent_nodes", U(c.agent_nodes));
  g.add("agent_refused", U(c.agent_refused));
  g.add("agent_sparsified", U(c.agent_sparsified));
  g.add("snapshots_written", U(c.snapshots_written));
  g.add("snapshot_failures", U(c.snapshot_failures));
  g.add("snapshots_deferred", U(c.snapshots_deferred));
  g.add("gpio_failures", U(c.gpio_failures));
  g.add("backend_updates", U(c.backend_updates));
  g.add("rooms", U(c.rooms));
  g.add("rooms_labelled", U(c.rooms_labelled));
  g.add("doors", U(c.doors));
  g.add("door_failures", U(c.door_failures));
  g.add("door_passes", U(c.door_passes));
  g.add("online_bypass_refused", U(c.online_bypass_refused));
  g.add("wall_paint_deferred", U(c.wall_paint_deferred));
  g.add("agents_described", U(c.agents_described));
  g.add("agent_frames_dropped", U(c.agent_frames_dropped));
  g.add("loop_closures", U(c.loop_closures));
  g.add("loop_closures_by_appearance", U(c.loop_closures_by_appearance));
  g.add("places_merged_after_correction", U(c.places_merged_after_correction));
  g.add("objects_merged_at_finish", U(c.objects_merged_at_finish));
  g.add("objects_held_at_once_kept_apart", U(c.objects_held_at_once_kept_apart));
  g.add("loop_closures_kept", U(c.loop_closures_kept));
  g.add("loop_closures_true", U(c.loop_closures_true));
  g.add("loop_closures_false", U(c.loop_closures_false));
  g.add("loop_closures_false_kept", U(c.loop_closures_false_kept));
  g.add("loop_closure_folds", U(c.loop_closure_folds));
  g.add("loop_closures_folded", U(c.loop_closures_folded));
  g.add("graph_optimizations", U(c.graph_optimizations));
  g.add("graph_optimization_failures", U(c.graph_optimization_failures));
  g.add("graph_optimization_max_us", U(c.graph_optimization_max_us));
  return g;
}

ReportGroup odometry_group(const OdometryInput& o) {
  const OdometryCounters& c = o.counters();
  const runtime::PoseBufferCounters& b = o.buffer().counters();
  ReportGroup g{"odometry", o.source_name(), {}};
  g.add("samples_read", U(c.samples_read));
  g.add("source_bad", U(c.source_bad));
  g.add("file_lines_skipped", U(c.file_lines_skipped));
  g.add("frames_posed", U(c.frames_posed));
  g.add("frames_waited", U(c.frames_waited));
  g.add("frames_no_pose", U(c.frames_no_pose));
  g.add("frames_pose_too_old", U(c.frames_pose_too_old));
  g.add("frames_in_gap", U(c.frames_in_gap));
  g.add("silences", U(c.silences));
  g.add("disconnected_reads", U(c.disconnects));
  g.add("accepted", U(b.accepted));
  g.add("rejected_non_finite", U(b.non_finite));
  g.add("rejected_bad_quaternion", U(b.bad_quaternion));
  g.add("rejected_out_of_order", U(b.out_of_order));
  g.add("rejected_duplicates", U(b.duplicates));
  g.add("rejected_time_jumps", U(b.time_jumps));
  g.add("rejected_pose_jumps", U(b.pose_jumps));
  g.add("resyncs", U(b.resyncs));
  g.add("steps", U(b.steps));
  g.add("gaps", U(b.gaps));
  g.add("overwritten", U(b.overwritten));
  return g;
}

ReportGroup queues_group(const Pipeline& p) {
  ReportGroup g{"queues", "", {}};
  for (const runtime::QueueStats& q :
       {p.frame_queue_stats(), p.segmentation_queue_stats(), p.backend_queue_stats()}) {
    const std::string n = q.name;
    g.add(n + ".dropped", U(q.dropped));
    g.add(n + ".high_water", U(q.high_water));
    g.add(n + ".depth", U(q.depth));
    g.add(n + ".collated", U(q.collated));
  }
  return g;
}

void add_stage_groups(const Pipeline& p, std::vector<ReportGroup>* out) {
  const reconstruction::Counters& r = p.reconstruction().counters();
  ReportGroup recon{"reconstruction", "", {}};
  recon.add("frames", U(r.frames));
  recon.add("pixels_invalid", U(r.pixels_invalid));
  recon.add("blocks_evicted", U(r.blocks_evicted));
  recon.add("blocks_refused", U(r.blocks_refused));
  recon.add("mesh_overflow", U(r.mesh_overflow));
  recon.add("archive_overflow", U(r.archive_overflow));
  recon.add("archive_compactions", U(r.archive_compactions));
  recon.add("archive_coarsenings", U(r.archive_coarsenings));
  out->push_back(recon);

  const auto& pl = p.frontend().places().counters();
  ReportGroup places{"places", "", {}};
  places.add("blocks_refused", U(pl.blocks_refused));
  places.add("clusters_refused", U(pl.clusters_refused));
  places.add("edges_refused", U(pl.edges_refused));
  places.add("edges_pruned", U(pl.edges_pruned));
  places.add("graph_refused", U(pl.graph_refused));
  places.add("graph_errors", U(pl.graph_errors));
  places.add("revivals_refused", U(pl.revivals_refused));
  places.add("revisits_merged", U(pl.revisits_merged));
  out->push_back(places);

  const auto& ob = p.frontend().objects().counters();
  ReportGroup objects{"objects", "", {}};
  objects.add("objects_created", U(ob.objects_created));
  objects.add("candidate_overflow", U(ob.candidate_overflow));
  objects.add("tracked_overflow", U(ob.tracked_overflow));
  objects.add("key_overflow", U(ob.key_overflow));
  objects.add("block_overflow", U(ob.block_overflow));
  objects.add("object_overflow", U(ob.object_overflow));
  objects.add("graph_node_failures", U(ob.graph_node_failures));
  objects.add("graph_connection_failures", U(ob.graph_connection_failures));
  out->push_back(objects);

  const auto& fr = p.frontend().counters();
  ReportGroup frontend{"frontend", "", {}};
  frontend.add("deadline_stops", U(fr.deadline_stops));
  frontend.add("interlayer_failed", U(fr.interlayer_failed));
  frontend.add("graph_refused", U(fr.graph_refused));
  out->push_back(frontend);

  const auto& ag = p.frontend().agents().counters();
  ReportGroup agents{"agents", "", {}};
  agents.add("keyframes", U(ag.keyframes));
  agents.add("folded", U(ag.folded));
  agents.add("rejected_time", U(ag.rejected_time));
  agents.add("rejected_full", U(ag.rejected_full));
  agents.add("rejected_pose", U(ag.rejected_pose));
  out->push_back(agents);

  const auto& rf = p.room_finder().counters();
  ReportGroup rooms{"rooms", "", {}};
  rooms.add("updates", U(rf.updates));
  rooms.add("truncated", U(rf.truncated));
  rooms.add("graph_refused", U(rf.graph_refused));
  rooms.add("seeds_dropped", U(rf.seeds_dropped));
  out->push_back(rooms);
}

ReportGroup stores_group(const Pipeline& p) {
  ReportGroup g{"stores", "", {}};
  std::uint64_t refused = 0;
  const auto add = [&](const memory::ResourceStats& s) {
    const std::string n = s.name;
    g.add(n + ".refused", U(s.failed));
    g.add(n + ".high_water", U(s.high_water));
    g.add(n + ".capacity", U(s.capacity));
    refused += s.failed;
  };
  p.for_each_store(add);
  g.values.insert(g.values.begin(), {"refused_total", U(refused)});
  return g;
}

// The process's memory at the end: resident set and its peak, page faults, and whether it was locked.
ReportGroup memory_group(const Pipeline& p) {
  ReportGroup g{"memory", "", {}};
  const ProcessMemory m = read_process_memory();
  g.add("vm_rss_kb", U(m.vm_rss_kb));
  g.add("vm_hwm_kb", U(m.vm_hwm_kb));
  g.add("vm_lck_kb", U(m.vm_lck_kb));
  g.add("minor_faults", U(m.minor_faults));
  g.add("major_faults", U(m.major_faults));
  g.add("locked", U(p.counters().memory_locked));
  g.add("lock_failures", U(p.counters().memory_lock_failures));
  return g;
}

ReportGroup graph_group(const Pipeline& p) {
  ReportGroup g{"graph", "", {}};
  using scene_graph::NodeKind;
  for (NodeKind k : {NodeKind::kObject, NodeKind::kAgent, NodeKind::kPlace, NodeKind::kRoom, NodeKind::kBuilding})
    g.add(std::string(scene_graph::to_string(k)) + "_nodes", U(p.graph().num_nodes(k)));
  g.add("edges", U(p.graph().num_edges()));
  return g;
}

ReportGroup tasks_group(const Pipeline& p) {
  ReportGroup g{"tasks", "", {}};
  const runtime::Scheduler& s = p.scheduler();
  for (std::size_t i = 0; i < s.num_tasks(); ++i) {
    const std::string n = s.task(i).budget.name;
    g.add(n + ".overruns", U(s.task(i).stats.overruns));
    g.add(n + ".slips", U(s.task(i).stats.slips));
    g.add(n + ".skips", U(s.task(i).stats.skips));
    g.add(n + ".deferrals", U(s.task(i).stats.deferrals));
  }
  // The worker threads outside the tick loop: runs, CPU time per run and overruns of their thread budgets.
  const auto thread = [&](const std::string& n, const runtime::TaskStats& cpu) {
    g.add(n + ".runs", U(cpu.runs));
    g.add(n + ".cpu_mean_us", cpu.mean_us());
    g.add(n + ".cpu_max_us", static_cast<double>(cpu.max_us));
    g.add(n + ".overruns", U(cpu.overruns));
  };
  thread("backend_thread", p.backend_cpu_stats());
  thread("backend_door_pass", p.door_pass_cpu_stats());
  thread("backend_final_stage", p.finish_cpu_stats());
  if (p.backend_stage().loop_closure_enabled()) {
    thread("backend_loop_closure_detect", p.loop_closure_detect_cpu_stats());
    thread("backend_loop_closure_lock", p.loop_closure_lock_cpu_stats());
    thread("backend_solve", p.solve_cpu_stats());
  }
  if (p.segmentation().initialized()) thread("segmentation_thread", p.segmentation().cpu_stats());
  const runtime::TelemetryWriterStats t = p.telemetry_stats();
  g.add("telemetry_lines.dropped", U(t.dropped));
  g.add("telemetry_lines.high_water", U(t.high_water));
  g.add("telemetry_lines.write_failures", U(t.write_failures));
  return g;
}

ReportGroup faults_group(const FaultInjection& f) {
  ReportGroup g{"faults", f.path(), {}};
  const auto injected = [&](const char* source, const sim::FaultTally& tally) {
    for (int k = 0; k < sim::kNumFaultKinds; ++k)
      g.add(std::string(source) + "." + sim::to_string(static_cast<sim::FaultKind>(k)), U(tally[static_cast<std::size_t>(k)]));
  };
  if (f.camera() != nullptr) injected("camera", f.camera()->injected());
  if (f.odometry() != nullptr) injected("odometry", f.odometry()->injected());
  const FaultRecovery& r = f.recovery();
  g.add("fault_ends", U(r.faults_ended));
  g.add("recovered", U(r.recovered));
  g.add("not_recovered", r.waiting ? 1.0 : 0.0);
  g.add("last_recovery_s", r.last_recovery_ns >= 0 ? 1e-9 * U(r.last_recovery_ns) : -1.0);
  g.add("max_recovery_s", r.max_recovery_ns >= 0 ? 1e-9 * U(r.max_recovery_ns) : -1.0);
  g.add("last_fault_end_s", r.last_end_ns >= 0 ? 1e-9 * U(r.last_end_ns) : -1.0);
  g.add("max_catch_up_s", r.max_catch_up_ns >= 0 ? 1e-9 * U(r.max_catch_up_ns) : -1.0);
  g.add("still_behind", r.catching_up ? 1.0 : 0.0);
  return g;
}

}  // namespace

std::vector<ReportGroup> collect_exit_report(const Pipeline& p) {
  std::vector<ReportGroup> out;
  out.push_back(pipeline_group(p.counters()));
  // The camera's own name (under a fault plan the source read is its decorator; the counters are the sum).
  const char* camera = p.faults().camera() != nullptr ? p.faults().camera()->inner_name() : p.camera()->name();
  out.push_back(driver_group("camera", camera, p.camera()->counters()));
  out.push_back(odometry_group(p.odometry()));
  if (const drivers::DriverCounters* d = p.odometry().driver_counters())
    out.push_back(driver_group("odometry_driver", p.odometry().source_name(), *d));
  out.push_back(queues_group(p));
  add_stage_groups(p, &out);
  out.push_back(graph_group(p));
  out.push_back(stores_group(p));
  out.push_back(tasks_group(p));
  out.push_back(memory_group(p));
  if (p.faults().active()) out.push_back(faults_group(p.faults()));
  return out;
}

void print_telemetry_faults(const Pipeline& p, std::FILE* out) {
  const drivers::DriverCounters& d = p.camera()->counters();
  const PipelineCounters& c = p.counters();
  const drivers::DriverCounters* o = p.odometry().driver_counters();
  const FaultInjection& f = p.faults();
  const bool open = f.recovery().waiting || (f.camera() != nullptr && f.camera()->injector().fault_open()) ||
                    (f.odometry() != nullptr && f.odometry()->injector().fault_open());
  const auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
  std::fprintf(out,
               " | faults camera late=%llu backwards=%llu bad depth=%llu disconnects=%llu reconnects=%llu "
               "frames bad=%llu | odometry driver drops=%llu stalls=%llu backwards=%llu bad=%llu disconnects=%llu "
               "| keyframes refused=%llu unlabelled=%llu | queue drops segmentation=%llu backend=%llu "
               "| places refused=%llu objects refused=%llu interlayer failed=%llu%s\n",
               u(d.late), u(d.timestamps_backwards), u(d.invalid_depth_frames), u(d.disconnects), u(d.reconnects),
               u(c.frames_bad), u(o ? o->dropped : 0), u(o ? o->stalls : 0), u(o ? o->timestamps_backwards : 0),
               u(o ? o->bad_frames : 0), u(o ? o->disconnects : 0), u(c.keyframes_refused), u(c.keyframes_unlabelled),
               u(p.segmentation_queue_stats().dropped), u(p.backend_queue_stats().dropped),
               u(p.frontend().places().counters().graph_refused + p.frontend().places().counters().clusters_refused),
               u(p.frontend().objects().counters().graph_node_failures), u(p.frontend().counters().interlayer_failed),
               open ? " | FAULT (open or not recovered yet)" : "");
}

void print_telemetry_counters(const Pipeline& p, std::FILE* out) {
  const auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
  const drivers::DriverCounters& d = p.camera()->counters();
  const drivers::DriverCounters* od = p.odometry().driver_counters();
  const OdometryCounters& o = p.odometry().counters();
  const runtime::PoseBufferCounters& b = p.odometry().buffer().counters();
  const PipelineCounters& c = p.counters();
  const reconstruction::Counters& r = p.reconstruction().counters();
  const auto& pl = p.frontend().places().counters();
  const auto& ob = p.frontend().objects().counters();
  const auto& fr = p.frontend().counters();
  const auto& ag = p.frontend().agents().counters();
  std::uint64_t overruns = 0, slips = 0, skips = 0;
  for (std::size_t i = 0; i < p.scheduler().num_tasks(); ++i) {
    overruns += p.scheduler().task(i).stats.overruns;
    slips += p.scheduler().task(i).stats.slips;
    skips += p.scheduler().task(i).stats.skips;
  }
  std::fprintf(out,
               " | counters camera.dropped=%llu camera.stalls=%llu camera.late=%llu camera.timestamps_backwards=%llu "
               "camera.invalid_depth_frames=%llu camera.bad_frames=%llu camera.disconnects=%llu camera.missing_files=%llu "
               "odometry_driver.dropped=%llu odometry_driver.stalls=%llu odometry.source_bad=%llu "
               "odometry.frames_no_pose=%llu odometry.frames_pose_too_old=%llu odometry.frames_in_gap=%llu "
               "odometry.silences=%llu odometry.rejected=%llu odometry.gaps=%llu odometry.steps=%llu "
               "pipeline.frames_bad=%llu pipeline.frames_without_pose=%llu pipeline.keyframes_refused=%llu "
               "pipeline.keyframes_unlabelled=%llu pipeline.agent_refused=%llu pipeline.snapshot_failures=%llu "
               "pipeline.gpio_failures=%llu pipeline.door_failures=%llu pipeline.online_bypass_refused=%llu "
               "queues.frames.dropped=%llu queues.segmentation.dropped=%llu queues.frontend_to_backend.dropped=%llu "
               "reconstruction.blocks_refused=%llu reconstruction.mesh_overflow=%llu "
               "reconstruction.archive_overflow=%llu places.blocks_refused=%llu places.clusters_refused=%llu "
               "places.edges_refused=%llu places.graph_refused=%llu places.graph_errors=%llu "
               "objects.candidate_overflow=%llu "
               "objects.tracked_overflow=%llu objects.key_overflow=%llu objects.block_overflow=%llu "
               "objects.object_overflow=%llu objects.graph_node_failures=%llu objects.graph_connection_failures=%llu "
               "frontend.interlayer_failed=%llu frontend.graph_refused=%llu agents.rejected_time=%llu "
               "agents.rejected_full=%llu agents.rejected_pose=%llu "
               "| load pipeline.frontend_deadline_stops=%llu pipeline.wall_paint_deferred=%llu tasks.overruns=%llu "
               "tasks.slips=%llu tasks.skips=%llu | traffic pipeline.keyframes_integrated=%llu agents.folded=%llu "
               "odometry.overwritten=%llu places.revisits_merged=%llu places.edges_pruned=%llu reconstruction.blocks_evicted=%llu "
               "reconstruction.archive_compactions=%llu reconstruction.archive_coarsenings=%llu "
               "pipeline.snapshots_written=%llu\n",
               u(d.dropped), u(d.stalls), u(d.late), u(d.timestamps_backwards), u(d.invalid_depth_frames),
               u(d.bad_frames), u(d.disconnects), u(d.missing_files), u(od ? od->dropped : 0), u(od ? od->stalls : 0),
               u(o.source_bad), u(o.frames_no_pose), u(o.frames_pose_too_old), u(o.frames_in_gap), u(o.silences),
               u(b.rejected()), u(b.gaps), u(b.steps), u(c.frames_bad), u(c.frames_without_pose), u(c.keyframes_refused),
               u(c.keyframes_unlabelled), u(c.agent_refused), u(c.snapshot_failures), u(c.gpio_failures),
               u(c.door_failures), u(c.online_bypass_refused), u(p.frame_queue_stats().dropped),
               u(p.segmentation_queue_stats().dropped), u(p.backend_queue_stats().dropped), u(r.blocks_refused),
               u(r.mesh_overflow), u(r.archive_overflow), u(pl.blocks_refused), u(pl.clusters_refused),
               u(pl.edges_refused), u(pl.graph_refused), u(pl.graph_errors), u(ob.candidate_overflow), u(ob.tracked_overflow),
               u(ob.key_overflow), u(ob.block_overflow), u(ob.object_overflow), u(ob.graph_node_failures),
               u(ob.graph_connection_failures), u(fr.interlayer_failed), u(fr.graph_refused), u(ag.rejected_time),
               u(ag.rejected_full), u(ag.rejected_pose), u(c.frontend_deadline_stops), u(c.wall_paint_deferred),
               u(overruns), u(slips), u(skips), u(c.keyframes_integrated), u(ag.folded), u(b.overwritten),
               u(pl.revisits_merged), u(pl.edges_pruned), u(r.blocks_evicted), u(r.archive_compactions), u(r.archive_coarsenings),
               u(c.snapshots_written));
}

void print_exit_report(const std::vector<ReportGroup>& report, std::FILE* out) {
  for (const ReportGroup& g : report) {
    std::fprintf(out, "%s%s%s:", g.name.c_str(), g.label.empty() ? "" : " ", g.label.c_str());
    for (const auto& [key, value] : g.values) {
      if (value == std::floor(value) && std::fabs(value) < 1e15)
        std::fprintf(out, " %s=%lld", key.c_str(), static_cast<long long>(value));
      else
        std::fprintf(out, " %s=%.3f", key.c_str(), value);
    }
    std::fprintf(out, "\n");
  }
}

bool write_exit_report_json(const std::vector<ReportGroup>& report, int exit_status, const std::string& path,
                            std::string* error) {
  nlohmann::json doc = nlohmann::json::object();
  for (const ReportGroup& g : report) {
    nlohmann::json& j = doc[g.name];
    if (!g.label.empty()) j["source"] = g.label;
    for (const auto& [key, value] : g.values) j[key] = value;
  }
  doc["exit_status"] = exit_status;
  return write_file_atomically(path, doc.dump(1) + "\n", error);
}

}  // namespace qsg::app

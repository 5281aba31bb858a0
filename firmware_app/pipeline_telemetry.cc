// The pipeline's telemetry: a line per telemetry interval, and (AppConfig::telemetry_stores) the stores line with
// every store's use, high-water mark, capacity and refusals, the resident set and the run's counters.
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>

#include "firmware_app/exit_report.h"
#include "firmware_app/memory_lock.h"
#include "firmware_app/pipeline.h"

namespace qsg::app {

namespace {

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

// Resident set now (not the peak), from /proc/self/statm without allocating; 0 where it cannot be read.
double rss_mb() {
  const int fd = ::open("/proc/self/statm", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0.0;
  char text[128];
  const ssize_t n = ::read(fd, text, sizeof(text) - 1);
  ::close(fd);
  if (n <= 0) return 0.0;
  text[n] = '\0';
  unsigned long long size_pages = 0, resident_pages = 0;
  if (std::sscanf(text, "%llu %llu", &size_pages, &resident_pages) != 2) return 0.0;
  return static_cast<double>(resident_pages) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / 1048576.0;
}
}  // namespace

void Pipeline::print_telemetry(std::FILE* out) {
  const std::int64_t now = clock_->now_ns();
  const double t_s = static_cast<double>(now - start_ns_) * 1e-9;
  const double dt_s = static_cast<double>(now - last_telemetry_ns_) * 1e-9;
  const double kf_per_s = dt_s > 0.0 ? static_cast<double>(counters_.keyframes - last_telemetry_keyframes_) / dt_s : 0.0;
  last_telemetry_ns_ = now;
  last_telemetry_keyframes_ = counters_.keyframes;
  const runtime::TaskStats* recon = scheduler_.stats("reconstruction");
  const runtime::TaskStats* front = scheduler_.stats("frontend");
  std::size_t overruns = 0;
  for (std::size_t i = 0; i < scheduler_.num_tasks(); ++i) overruns += scheduler_.task(i).stats.overruns;
  const runtime::QueueStats q = keyframe_queue_.stats();
  const drivers::DriverCounters& d = camera_->counters();
  std::size_t graph_nodes = 0;
  // The fullest store by high-water mark (arenas are carved whole at start-up, so their pools tell the story),
  // and how many requests any store refused.
  memory::ResourceStats fullest;
  double fullest_fill = -1.0;
  std::uint64_t refused = 0;
  const auto watch = [&](const memory::ResourceStats& r) {
    refused += r.failed;
    if (r.capacity == 0 || std::strcmp(r.unit, "bytes") == 0) return;
    const double fill = static_cast<double>(r.high_water) / static_cast<double>(r.capacity);
    if (fill > fullest_fill) fullest_fill = fill, fullest = r;
  };
  {
    std::lock_guard<std::mutex> lock(graph_mutex_);  // the backend's stores change under it
    graph_nodes = graph_.num_nodes();
    for_each_store(watch, /*from_loop=*/true);
  }
  std::fprintf(out,
               "[t=%7.1fs] kf/s=%.1f keyframes=%llu | max_us recon=%lld frontend=%lld overruns=%zu | blocks=%zu/%zu "
               "archive=%zu tri | graph nodes=%zu rooms=%llu | frames queue hw=%u drops=%llu | driver drops=%llu stalls=%llu "
               "bad=%llu missing files=%llu | gpio fail=%llu%s | fullest store %s hw %zu/%zu, refused %llu | odometry %s rejected=%llu "
               "gaps=%llu steps=%llu silences=%llu frames without pose=%llu | agents %zu/%zu (folded %llu) | rss=%.0f MB "
               "(peak %.0f)",
               t_s, kf_per_s, (unsigned long long)counters_.keyframes, (long long)(recon ? recon->max_us : 0),
               (long long)(front ? front->max_us : 0), overruns, tsdf_.active_blocks(), tsdf_.capacities().max_blocks,
               tsdf_.archive_triangles(), graph_nodes, (unsigned long long)backend_.counters().rooms.load(), q.high_water, (unsigned long long)q.dropped,
               (unsigned long long)d.dropped, (unsigned long long)d.stalls, (unsigned long long)d.bad_frames,
               (unsigned long long)d.missing_files, (unsigned long long)counters_.gpio_failures, paused() ? " PAUSED" : "", fullest.name, fullest.high_water,
               fullest.capacity, (unsigned long long)refused, odometry_.source_name(),
               (unsigned long long)odometry_.buffer().counters().rejected(),
               (unsigned long long)odometry_.buffer().counters().gaps,
               (unsigned long long)odometry_.buffer().counters().steps, (unsigned long long)odometry_.counters().silences,
               (unsigned long long)counters_.frames_without_pose, frontend_.agents().chain_size(),
               frontend_.agents().chain_stats().capacity, (unsigned long long)frontend_.agents().counters().folded,
               rss_mb(), peak_rss_mb());
  {
    // Refusals under each store's own name ("none" on a healthy run).
    std::lock_guard<std::mutex> lock(graph_mutex_);
    std::fprintf(out, " | refused by store:%s", refused == 0 ? " none" : "");
    for_each_store(
        [&](const memory::ResourceStats& r) {
          if (r.failed > 0) std::fprintf(out, " %s=%llu", r.name, static_cast<unsigned long long>(r.failed));
        },
        /*from_loop=*/true);
  }
  print_telemetry_faults(*this, out);  // the rest of the fault counters, and the line's end
  if (config_.telemetry_stores) print_telemetry_stores(out, t_s);
  std::fflush(out);  // into a log file or a pipe too, each interval's lines arrive whole as they are printed
  ++counters_.telemetry_lines;
}

void Pipeline::print_telemetry_stores(std::FILE* out, double t_s) {
  const ProcessMemory m = read_process_memory();
  std::unique_lock<std::mutex> lock(graph_mutex_);  // the backend's stores change under it
  std::uint64_t arena_bytes = tsdf_.arena_bytes();
  const auto is_arena = [](const memory::ResourceStats& r) { return std::strcmp(r.unit, "bytes") == 0; };
  for_each_store([&](const memory::ResourceStats& r) { arena_bytes += is_arena(r) ? r.capacity : 0; }, true);
  std::fprintf(out, "[t=%7.1fs] stores rss_kb=%llu hwm_kb=%llu locked_kb=%llu minflt=%llu majflt=%llu arenas_kb=%llu "
               "| arenas reconstruction=%zu",
               t_s, static_cast<unsigned long long>(m.vm_rss_kb), static_cast<unsigned long long>(m.vm_hwm_kb),
               static_cast<unsigned long long>(m.vm_lck_kb), static_cast<unsigned long long>(m.minor_faults),
               static_cast<unsigned long long>(m.major_faults), static_cast<unsigned long long>(arena_bytes / 1024),
               tsdf_.arena_bytes());
  // Arenas are carved whole at start-up: their bytes are what they hold; the stores carved from them say how full.
  for_each_store([&](const memory::ResourceStats& r) { if (is_arena(r)) std::fprintf(out, " %s=%zu", r.name, r.capacity); },
                 true);
  // Stores: use/high_water/capacity/refused. The TSDF's active blocks (a window: no high-water mark kept) and its
  // mesh archive, then every store of the graph, frontend, agents, rooms, doors and loop closure.
  std::fprintf(out, " | reconstruction.blocks=%zu/%zu/%zu/%llu reconstruction.archive_triangles=%zu/%zu/%zu/%llu",
               tsdf_.active_blocks(), tsdf_.active_blocks(), tsdf_.capacities().max_blocks,
               static_cast<unsigned long long>(tsdf_.counters().blocks_refused), tsdf_.archive_triangles(),
               tsdf_.archive_triangles(), tsdf_.capacities().archive_triangles,
               static_cast<unsigned long long>(tsdf_.counters().archive_overflow));
  for_each_store(
      [&](const memory::ResourceStats& r) {
        if (!is_arena(r))
          std::fprintf(out, " %s=%zu/%zu/%zu/%llu", r.name, r.in_use, r.high_water, r.capacity,
                       static_cast<unsigned long long>(r.failed));
      },
      true);
  lock.unlock();
  print_telemetry_counters(*this, out);  // " | counters ... | load ... | traffic ...\n"
}

}  // namespace qsg::app

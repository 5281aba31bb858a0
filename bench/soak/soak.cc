// Soak (issue 36): qsg_app on a long simulated mission in lockstep (by default 8 hours on a large two-floor
// building toured again and again, mapping from the simulator's drifting odometry, the app's default), checked
// every telemetry interval (by default every simulated 10 minutes):
//   - the resident set (VmRSS) and its peak (VmHWM), page faults, and the arenas' bytes;
//   - every store's use, high water, capacity and refusals (scene graph, frontend, agent chain, room finder,
//     online doors, reconstruction);
//   - every fault counter of the exit report (camera, odometry, pipeline, queues, stages).
// The samples come from the app itself: with `telemetry_stores` on, after each telemetry line it prints one more
// ("[t=...s] stores rss_kb=... | <store>=use/high_water/capacity/refused ... | counters ..."), read at that
// simulated instant on the loop thread. In lockstep the simulated clock runs many times faster than the wall
// clock and unevenly (a frontend update or a snapshot takes a while), so an outside sampler reading
// /proc/PID/status on a wall-clock timer could not say at which simulated minute it read; the app's own line can.
//
// The mission's config is a base config (default firmware_app/config/mission_8h.json, the odometry issue's 8-hour
// mission) with the soak's settings laid over it (duration, building, telemetry); it is written beside the log.
//
// Pass criteria, checked after the warm-up (default: the first hour, or the first quarter of a shorter run):
//   - the app exits 0, without a signal, within the timeout;
//   - no store refused anything, at any sample or in the exit report (stores.refused_total 0);
//   - no fault counter grows after the warm-up (a counter that moved during the warm-up is reported, not failed);
//   - VmRSS is flat: over the samples after the warm-up, max - min <= max(--rss-tolerance-mb, --rss-tolerance-pct
//     of their median);
//   - no store is filling: its use after the warm-up, extrapolated linearly (least squares over the samples) to
//     three times the mission's length, stays below its capacity.
// --stop-after-wall-s stops the app (SIGTERM: it writes its outputs and its report) when the wall clock allows no
// more, and judges the mission as far as it went; --analyze-log judges a log written before (its report.json beside).
// --report-only COUNTER,... reports a listed fault counter's growth without failing on it (a known finding, named
// where it is used, e.g. CI). Reported without failing: the load counters (deadline stops, overruns: the wall clock's, on a shared machine),
// the traffic counters a healthy run grows (folds, merges, evictions), minor page faults after the warm-up.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/figures.h"

namespace {

using Json = nlohmann::json;

struct Options {
  std::string app = QSG_APP_PATH;
  std::string config = std::string(QSG_SOURCE_DIR) + "/firmware_app/config/mission_8h.json";
  double duration_s = 8 * 3600.0;
  double report_every_s = 600.0;
  double warmup_s = -1.0;  // < 0: min(3600, a quarter of the run)
  int rooms = 24;
  int floors = 2;
  long long seed = -1;  // < 0: the config's
  std::string out = "soak_out";
  std::string json_path;
  std::string analyze_log;  // analyse an existing log instead of running
  double timeout_s = 0.0;   // 0: none
  double stop_after_wall_s = 0.0;  // > 0: SIGTERM the app then (it writes its outputs and report); judged as far as it got
  double rss_tolerance_mb = 16.0;
  double rss_tolerance_pct = 3.0;
  double filling_horizon = 3.0;  // a store must not fill within this many mission lengths
  std::vector<std::string> report_only;  // fault counters whose growth is reported, not failed (known findings)
};

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--app QSG_APP] [--config BASE.json] [--hours H | --duration-s S] [--report-every-s S]\n"
               "          [--warmup-s S] [--rooms N] [--floors 1|2] [--seed N] [--out DIR] [--json FILE]\n"
               "          [--timeout-s S] [--stop-after-wall-s S] [--rss-tolerance-mb MB] [--rss-tolerance-pct P]\n"
               "          [--report-only COUNTER,...] [--analyze-log LOG]\n"
               "  Runs qsg_app on a long lockstep mission and checks its memory, stores and fault counters every\n"
               "  --report-every-s of simulated time; see the file comment for the criteria. Exit 0 when all hold.\n",
               argv0);
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--app" && v) o->app = argv[++i];
    else if (a == "--config" && v) o->config = argv[++i];
    else if (a == "--hours" && v) o->duration_s = 3600.0 * std::atof(argv[++i]);
    else if (a == "--duration-s" && v) o->duration_s = std::atof(argv[++i]);
    else if (a == "--report-every-s" && v) o->report_every_s = std::atof(argv[++i]);
    else if (a == "--warmup-s" && v) o->warmup_s = std::atof(argv[++i]);
    else if (a == "--rooms" && v) o->rooms = std::atoi(argv[++i]);
    else if (a == "--floors" && v) o->floors = std::atoi(argv[++i]);
    else if (a == "--seed" && v) o->seed = std::atoll(argv[++i]);
    else if (a == "--out" && v) o->out = argv[++i];
    else if (a == "--json" && v) o->json_path = argv[++i];
    else if (a == "--analyze-log" && v) o->analyze_log = argv[++i];
    else if (a == "--timeout-s" && v) o->timeout_s = std::atof(argv[++i]);
    else if (a == "--stop-after-wall-s" && v) o->stop_after_wall_s = std::atof(argv[++i]);
    else if (a == "--report-only" && v) {
      std::stringstream list(argv[++i]);
      std::string item;
      while (std::getline(list, item, ',')) o->report_only.push_back(item);
    }
    else if (a == "--rss-tolerance-mb" && v) o->rss_tolerance_mb = std::atof(argv[++i]);
    else if (a == "--rss-tolerance-pct" && v) o->rss_tolerance_pct = std::atof(argv[++i]);
    else return usage(argv[0]), false;
  }
  if (!(o->duration_s > 0) || !(o->report_every_s > 0) || (o->floors != 1 && o->floors != 2) || o->rooms < 3) {
    std::fprintf(stderr, "soak: need a positive duration and report interval, --floors 1 or 2, --rooms >= 3\n");
    return false;
  }
  if (o->warmup_s < 0) o->warmup_s = std::min(3600.0, 0.25 * o->duration_s);
  return true;
}

// One "[t=...s] stores ..." line.
struct Sample {
  double t_s = 0;
  double wall_s = -1;  // when the soak read it (live runs only)
  std::map<std::string, double> memory;                  // rss_kb, hwm_kb, locked_kb, minflt, majflt, arenas_kb
  std::map<std::string, double> arenas;                  // bytes, carved whole at start-up
  std::map<std::string, std::array<double, 4>> stores;   // use, high water, capacity, refused
  std::map<std::string, double> counters, load, traffic;
};

bool parse_sample(const std::string& line, Sample* s) {
  if (line.rfind("[t=", 0) != 0) return false;
  const std::size_t close = line.find("s] stores ");
  if (close == std::string::npos) return false;
  s->t_s = std::atof(line.c_str() + 3);
  std::stringstream in(line.substr(close + 10));
  std::string token;
  int segment = 0;  // 0 memory, 1 arenas, 2 stores, then the named segments
  std::map<std::string, double>* named = nullptr;
  while (in >> token) {
    if (token == "|") {
      ++segment;
      named = nullptr;
      continue;
    }
    if (segment == 1 && token == "arenas") continue;
    if (segment >= 3 && named == nullptr) {
      named = token == "counters" ? &s->counters : token == "load" ? &s->load : &s->traffic;
      continue;
    }
    const std::size_t eq = token.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = token.substr(0, eq), value = token.substr(eq + 1);
    if (segment == 0) {
      s->memory[key] = std::atof(value.c_str());
    } else if (segment == 1) {
      s->arenas[key] = std::atof(value.c_str());
    } else if (segment == 2) {
      std::array<double, 4> v{};
      std::stringstream parts(value);
      std::string part;
      for (int k = 0; k < 4 && std::getline(parts, part, '/'); ++k) v[static_cast<std::size_t>(k)] = std::atof(part.c_str());
      s->stores[key] = v;
    } else {
      (*named)[key] = std::atof(value.c_str());
    }
  }
  return s->memory.count("rss_kb") > 0;
}

// Least-squares slope of y over x (units of y per unit of x); 0 with fewer than two points.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = x.size();
  if (n < 2) return 0.0;
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n; ++i) mx += x[i], my += y[i];
  mx /= static_cast<double>(n), my /= static_cast<double>(n);
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < n; ++i) sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
  return sxx > 0 ? sxy / sxx : 0.0;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string clock_text(double t_s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%d:%02d", static_cast<int>(t_s / 3600), static_cast<int>(std::fmod(t_s, 3600) / 60));
  return text;
}

// The mission's config: the base config (whole-line // comments allowed, as the app reads it) with the soak's
// settings over it.
bool write_config(const Options& o, const std::string& path, std::string* summary) {
  std::ifstream in(o.config);
  if (!in) return std::fprintf(stderr, "soak: cannot read %s\n", o.config.c_str()), false;
  std::string text, line;
  while (std::getline(in, line)) {
    const std::size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line.compare(first, 2, "//") == 0) continue;
    text += line + "\n";
  }
  Json c = Json::parse(text, nullptr, false);
  if (!c.is_object()) return std::fprintf(stderr, "soak: %s is not a JSON object\n", o.config.c_str()), false;
  c["duration_s"] = o.duration_s;
  c["telemetry_interval_s"] = o.report_every_s;
  c["telemetry_stores"] = true;
  c["output_dir"] = o.out + "/qsg_output";
  c["building"]["num_rooms"] = o.rooms;
  c["building"]["two_floors"] = o.floors == 2;
  if (o.seed >= 0) c["building"]["seed"] = o.seed;
  std::ofstream(path) << c.dump(2) << "\n";
  *summary = c.dump();
  return true;
}

struct RunResult {
  int exit_status = -1;
  int signal = 0;
  bool hang = false;
  bool stopped_early = false;  // --stop-after-wall-s: the app was asked to stop before its mission's end
  double wall_s = 0;
  std::vector<Sample> samples;
};

void print_sample(const Sample& s, const Sample* previous) {
  double refused = 0, fullest = -1;
  std::string fullest_name;
  for (const auto& [name, v] : s.stores) {
    refused += v[3];
    if (v[2] > 0 && v[1] / v[2] > fullest) fullest = v[1] / v[2], fullest_name = name;
  }
  double faults = 0;
  for (const auto& [k, v] : s.counters) faults += v;
  const double minflt = s.memory.count("minflt") ? s.memory.at("minflt") : 0;
  const double prev_minflt = previous != nullptr && previous->memory.count("minflt") ? previous->memory.at("minflt") : 0;
  std::printf("soak: t=%s (%7.0f s)%s VmRSS %.1f MB, VmHWM %.1f MB, +%.0f minor faults, stores refused %.0f, fault "
              "counters %.0f, fullest %s %.0f %%\n",
              clock_text(s.t_s).c_str(), s.t_s,
              s.wall_s >= 0 ? (" [" + std::to_string(static_cast<int>(s.wall_s)) + " s wall]").c_str() : "",
              s.memory.at("rss_kb") / 1024.0, s.memory.count("hwm_kb") ? s.memory.at("hwm_kb") / 1024.0 : 0.0,
              minflt - prev_minflt, refused, faults, fullest_name.c_str(), 100 * fullest);
  std::fflush(stdout);
}

// Spawns the app, its stdout and stderr into `log`, and follows the log as it grows.
RunResult run_app(const Options& o, const std::string& config_path, const std::string& log_path) {
  RunResult r;
  std::vector<std::string> args = {o.app, "--config", config_path, "--report-json", o.out + "/report.json", "--quiet"};
  std::filesystem::remove(o.out + "/report.json");
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) ::dup2(fd, STDOUT_FILENO), ::dup2(fd, STDERR_FILENO);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  std::ifstream log;
  std::string pending;
  const auto follow = [&]() {
    if (!log.is_open()) log.open(log_path);
    if (!log.is_open()) return;
    log.clear();
    std::string chunk;
    char buffer[65536];
    while (log.read(buffer, sizeof(buffer)) || log.gcount() > 0) chunk.append(buffer, static_cast<std::size_t>(log.gcount()));
    log.clear();
    pending += chunk;
    std::size_t nl;
    while ((nl = pending.find('\n')) != std::string::npos) {
      Sample s;
      if (parse_sample(pending.substr(0, nl), &s)) {
        s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        print_sample(s, r.samples.empty() ? nullptr : &r.samples.back());
        r.samples.push_back(std::move(s));
      }
      pending.erase(0, nl + 1);
    }
  };
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    follow();
    if (done == pid) break;
    if (o.stop_after_wall_s > 0 && r.wall_s > o.stop_after_wall_s && !r.stopped_early) {
      r.stopped_early = true;
      std::printf("soak: %.0f s of wall time: stopping the app (SIGTERM; it writes its outputs and report)\n", r.wall_s);
      std::fflush(stdout);
      ::kill(pid, SIGTERM);
    }
    if (o.timeout_s > 0 && r.wall_s > o.timeout_s) {
      r.hang = true;
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  follow();
  if (!r.hang && WIFEXITED(status)) r.exit_status = WEXITSTATUS(status);
  if (!r.hang && WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) return 2;
  std::filesystem::create_directories(o.out);
  RunResult run;
  std::string conditions;
  if (!o.analyze_log.empty()) {
    std::ifstream in(o.analyze_log);
    if (!in) return std::fprintf(stderr, "soak: cannot read %s\n", o.analyze_log.c_str()), 2;
    std::string line;
    while (std::getline(in, line)) {
      Sample s;
      if (parse_sample(line, &s)) {
        print_sample(s, run.samples.empty() ? nullptr : &run.samples.back());
        run.samples.push_back(std::move(s));
      }
    }
    // The exit status from the run's report (--report-json) beside the log, when there is one.
    std::ifstream report_in((std::filesystem::path(o.analyze_log).parent_path() / "report.json").string());
    const Json r = report_in ? Json::parse(report_in, nullptr, false) : Json();
    run.exit_status = r.is_object() ? r.value("exit_status", -1) : 0;
    if (!r.is_object()) std::printf("soak: no report.json beside %s: exit status unknown\n", o.analyze_log.c_str());
    conditions = "analysis of " + o.analyze_log;
  } else {
    const std::string config_path = o.out + "/soak_config.json";
    std::string summary;
    if (!write_config(o, config_path, &summary)) return 2;
    std::printf("soak: %s --config %s (base %s): %.0f s simulated, a sample every %.0f s, warm-up %.0f s\n",
                o.app.c_str(), config_path.c_str(), o.config.c_str(), o.duration_s, o.report_every_s, o.warmup_s);
    std::fflush(stdout);
    run = run_app(o, config_path, o.out + "/log.txt");
    conditions = "qsg_app lockstep, " + std::to_string(o.rooms) + " rooms, " + std::to_string(o.floors) +
                 " floor(s), " + std::to_string(static_cast<long long>(o.duration_s)) + " s simulated, base config " +
                 std::filesystem::path(o.config).filename().string() + ", a sample every " +
                 std::to_string(static_cast<long long>(o.report_every_s)) + " s, warm-up " +
                 std::to_string(static_cast<long long>(o.warmup_s)) + " s";
  }

  // --- Analysis ---
  std::vector<std::string> failures;
  const auto fail = [&](const std::string& why) {
    failures.push_back(why);
    std::printf("soak: FAIL: %s\n", why.c_str());
  };
  if (run.hang) fail("the app did not finish within " + std::to_string(o.timeout_s) + " s (killed)");
  if (run.signal != 0) fail("the app died of signal " + std::to_string(run.signal));
  if (!run.hang && run.signal == 0 && run.exit_status != 0) fail("the app exited " + std::to_string(run.exit_status));
  Json report;
  {
    std::ifstream in(o.analyze_log.empty() ? o.out + "/report.json"
                                           : (std::filesystem::path(o.analyze_log).parent_path() / "report.json").string());
    if (in) report = Json::parse(in, nullptr, false);
  }
  std::vector<const Sample*> after;
  const Sample* at_warmup = nullptr;
  for (const Sample& s : run.samples) {
    if (s.t_s <= o.warmup_s + 1e-6) at_warmup = &s;
    else after.push_back(&s);
  }
  if (run.samples.empty()) fail("no sample in the log (is telemetry_stores supported by this qsg_app?)");
  if (after.size() < 2) fail("fewer than two samples after the warm-up: nothing to judge flatness on");
  if (at_warmup == nullptr && !run.samples.empty()) at_warmup = &run.samples.front();

  // Memory.
  std::vector<double> t_h, rss_mb;
  for (const Sample* s : after) t_h.push_back(s->t_s / 3600.0), rss_mb.push_back(s->memory.at("rss_kb") / 1024.0);
  const double rss_med = median(rss_mb);
  const double rss_min = rss_mb.empty() ? 0 : *std::min_element(rss_mb.begin(), rss_mb.end());
  const double rss_max = rss_mb.empty() ? 0 : *std::max_element(rss_mb.begin(), rss_mb.end());
  const double rss_slope = slope(t_h, rss_mb);
  const double rss_allowed = std::max(o.rss_tolerance_mb, 0.01 * o.rss_tolerance_pct * rss_med);
  if (!rss_mb.empty() && rss_max - rss_min > rss_allowed) {
    char why[256];
    std::snprintf(why, sizeof(why), "VmRSS not flat after the warm-up: %.1f to %.1f MB (range %.1f MB > %.1f MB allowed), "
                  "slope %.2f MB/h", rss_min, rss_max, rss_max - rss_min, rss_allowed, rss_slope);
    fail(why);
  }
  const Sample* last = run.samples.empty() ? nullptr : &run.samples.back();
  const double minflt_after = last != nullptr && at_warmup != nullptr ? last->memory.at("minflt") - at_warmup->memory.at("minflt") : 0;
  const double hwm_mb = last != nullptr && last->memory.count("hwm_kb") ? last->memory.at("hwm_kb") / 1024.0 : 0;

  // Stores: refusals at any sample, and filling.
  double refused_total = 0;
  std::vector<std::string> refusing, filling;
  std::map<std::string, double> projected_fill;
  if (last != nullptr) {
    for (const auto& [name, v] : last->stores) {
      if (v[3] > 0) refusing.push_back(name + "=" + std::to_string(static_cast<long long>(v[3])));
      refused_total += v[3];
      std::vector<double> x, y;
      for (const Sample* s : after)
        if (s->stores.count(name)) x.push_back(s->t_s), y.push_back(s->stores.at(name)[0]);
      const double per_s = slope(x, y);
      const double horizon_s = o.filling_horizon * o.duration_s;
      const double projected = v[0] + std::max(0.0, per_s) * std::max(0.0, horizon_s - last->t_s);
      projected_fill[name] = v[2] > 0 ? projected / v[2] : 0.0;
      if (v[2] > 0 && projected >= v[2] && per_s > 0) filling.push_back(name);
    }
  }
  if (report.is_object() && report.contains("stores") && report["stores"].value("refused_total", 0.0) > 0)
    refused_total = std::max(refused_total, report["stores"].value("refused_total", 0.0));
  if (refused_total > 0) {
    std::string list;
    for (const std::string& r : refusing) list += " " + r;
    fail("stores refused " + std::to_string(static_cast<long long>(refused_total)) + " request(s):" + list);
  }
  for (const std::string& name : filling) {
    const auto& v = last->stores.at(name);
    char why[256];
    std::snprintf(why, sizeof(why), "store %s is filling: %.0f of %.0f now, would be full within %.0fx the mission",
                  name.c_str(), v[0], v[2], o.filling_horizon);
    fail(why);
  }

  // Fault counters: none may grow after the warm-up.
  std::vector<std::string> drifting, moved_in_warmup;
  if (last != nullptr && at_warmup != nullptr) {
    for (const auto& [k, v] : last->counters) {
      const double w = at_warmup->counters.count(k) ? at_warmup->counters.at(k) : 0.0;
      if (v > w) drifting.push_back(k + " " + std::to_string(static_cast<long long>(w)) + " -> " + std::to_string(static_cast<long long>(v)));
      else if (w > 0) moved_in_warmup.push_back(k + "=" + std::to_string(static_cast<long long>(w)));
    }
  }
  std::vector<std::string> reported;
  for (const std::string& d : drifting) {
    const std::string name = d.substr(0, d.find(' '));
    if (std::find(o.report_only.begin(), o.report_only.end(), name) != o.report_only.end()) {
      reported.push_back(d);
      std::printf("soak: REPORTED (--report-only, not failed): fault counter grows after the warm-up: %s\n", d.c_str());
    } else {
      fail("fault counter grows after the warm-up: " + d);
    }
  }

  // --- Table and figures ---
  std::printf("\n| sim time | VmRSS MB | VmHWM MB | minor faults since the last | stores refused | fault counters | fullest store (use / capacity) |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- |\n");
  for (std::size_t i = 0; i < run.samples.size(); ++i) {
    const Sample& s = run.samples[i];
    double refused = 0, faults = 0, fullest = -1, fu = 0, fc = 0;
    std::string fullest_name;
    for (const auto& [name, v] : s.stores) {
      refused += v[3];
      if (v[2] > 0 && v[0] / v[2] > fullest)
        fullest = v[0] / v[2], fullest_name = name, fu = v[0], fc = v[2];
    }
    for (const auto& [k, v] : s.counters) faults += v;
    const double dflt = i > 0 ? s.memory.at("minflt") - run.samples[i - 1].memory.at("minflt") : s.memory.at("minflt");
    std::printf("| %s | %.1f | %.1f | %.0f | %.0f | %.0f | %s %.0f / %.0f |\n", clock_text(s.t_s).c_str(),
                s.memory.at("rss_kb") / 1024.0, s.memory.count("hwm_kb") ? s.memory.at("hwm_kb") / 1024.0 : 0.0, dflt,
                refused, faults, fullest_name.c_str(), fu, fc);
  }
  if (last != nullptr) {
    std::printf("\nstores at %s (use / high water / capacity, refused; projected fill at %.0fx the mission):\n",
                clock_text(last->t_s).c_str(), o.filling_horizon);
    for (const auto& [name, v] : last->stores)
      if (v[2] > 0 && v[1] > 0)
        std::printf("  %-34s %10.0f / %10.0f / %10.0f, refused %.0f; projected %.1f %%\n", name.c_str(), v[0], v[1], v[2],
                    v[3], 100 * projected_fill[name]);
    std::printf("load counters (wall clock, reported):");
    for (const auto& [k, v] : last->load) std::printf(" %s=%.0f", k.c_str(), v);
    std::printf("\ntraffic:");
    for (const auto& [k, v] : last->traffic) std::printf(" %s=%.0f", k.c_str(), v);
    std::printf("\n");
  }
  if (!moved_in_warmup.empty()) {
    std::printf("fault counters that moved during the warm-up only:");
    for (const std::string& m : moved_in_warmup) std::printf(" %s", m.c_str());
    std::printf("\n");
  }
  std::printf("\nsoak: %zu samples over %s simulated (%.0f s wall, %.1fx real time); after the warm-up (%s): VmRSS "
              "%.1f-%.1f MB (median %.1f, slope %.2f MB/h, allowed range %.1f MB), VmHWM %.1f MB, %.0f minor page "
              "faults; stores refused %.0f; %zu fault counters growing, %zu stores filling: %s\n",
              run.samples.size(), last != nullptr ? clock_text(last->t_s).c_str() : "0:00", run.wall_s,
              run.wall_s > 0 && last != nullptr ? last->t_s / run.wall_s : 0.0, clock_text(o.warmup_s).c_str(), rss_min,
              rss_max, rss_med, rss_slope, rss_allowed, hwm_mb, minflt_after, refused_total, drifting.size(),
              filling.size(), failures.empty() ? "PASS" : "FAIL");
  if (run.stopped_early)
    std::printf("soak: stopped early by --stop-after-wall-s: %s of the %s planned were run and judged\n",
                last != nullptr ? clock_text(last->t_s).c_str() : "0:00", clock_text(o.duration_s).c_str());

  if (!o.json_path.empty()) {
    qsg::bench::Figures figures(conditions);
    figures.add("soak.simulated", last != nullptr ? last->t_s : 0.0, "s");
    figures.add("soak.wall", run.wall_s, "s");
    figures.add("soak.samples", static_cast<double>(run.samples.size()), "samples");
    figures.add("soak.exit_status", run.exit_status, "status");
    figures.add("soak.rss_after_warmup_min", rss_min, "MB");
    figures.add("soak.rss_after_warmup_max", rss_max, "MB");
    figures.add("soak.rss_after_warmup_median", rss_med, "MB");
    figures.add("soak.rss_after_warmup_range", rss_max - rss_min, "MB");
    figures.add("soak.rss_after_warmup_slope", rss_slope, "MB/h");
    figures.add("soak.vm_hwm", hwm_mb, "MB");
    figures.add("soak.minor_faults_after_warmup", minflt_after, "faults");
    figures.add("soak.stores_refused", refused_total, "requests");
    figures.add("soak.fault_counters_growing", static_cast<double>(drifting.size()), "counters");
    figures.add("soak.fault_counters_growing_reported_only", static_cast<double>(reported.size()), "counters");
    if (last != nullptr)
      for (const auto& [k, v] : last->counters)
        if (v > 0) figures.add("soak.end.counter." + k, v, "count");
    figures.add("soak.stores_filling", static_cast<double>(filling.size()), "stores");
    figures.add("soak.pass", failures.empty() ? 1 : 0, "bool");
    figures.add("soak.stopped_early", run.stopped_early ? 1 : 0, "bool");
    figures.add("soak.arenas", last != nullptr && last->memory.count("arenas_kb") ? last->memory.at("arenas_kb") / 1024.0 : 0.0, "MB");
    for (const Sample& s : run.samples) {
      const std::string p = "soak.t" + std::to_string(static_cast<long long>(std::llround(s.t_s)));
      figures.add(p + ".vm_rss", s.memory.at("rss_kb") / 1024.0, "MB");
      figures.add(p + ".minor_faults", s.memory.at("minflt"), "faults");
    }
    if (last != nullptr)
      for (const auto& [name, v] : last->stores) {
        if (v[2] <= 0) continue;
        figures.add("soak.end.store." + name + ".in_use", v[0], "units");
        figures.add("soak.end.store." + name + ".high_water", v[1], "units");
        figures.add("soak.end.store." + name + ".capacity", v[2], "units");
      }
    if (!figures.write(o.json_path)) return 1;
  }
  return failures.empty() ? 0 : 1;
}

// Trajectory evaluation: ATE and RPE of an estimated TUM trajectory against a reference one, optionally as JSON.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "core/metrics/trajectory_error.h"
#include "drivers/replay/trajectory.h"

namespace {

using namespace qsg;

constexpr int kExitUsage = 2;  // bad arguments; 1 is a file or evaluation failure

struct Options {
  std::string reference_path;
  std::string estimate_path;
  std::string json_path;
  metrics::TrajectoryErrorConfig config;
};

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s REFERENCE.txt ESTIMATE.txt [--align none|se3|sim3] [--max-dt S] [--rpe-delta M] "
               "[--json OUT.json]\n"
               "  TUM trajectories (t tx ty tz qx qy qz qw, t in seconds); reference = s R estimate + t.\n"
               "  --align      alignment before ATE (default se3; sim3 also fits a scale, for monocular estimates)\n"
               "  --max-dt     association window in seconds (default 0.02)\n"
               "  --rpe-delta  RPE pairs this many metres apart along the reference path (default 1)\n"
               "  --json       write the figures [{name, value, unit, conditions, commit}]\n",
               argv0);
}

// A finite number and nothing after it.
bool parse_double(const char* text, double* value) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || errno == ERANGE || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool parse_alignment(const std::string& text, metrics::Alignment* alignment) {
  for (metrics::Alignment a : {metrics::Alignment::kNone, metrics::Alignment::kSE3, metrics::Alignment::kSim3}) {
    if (text == metrics::to_string(a)) {
      *alignment = a;
      return true;
    }
  }
  return false;
}

// False with a message on stderr for anything the usage line does not allow.
bool parse(int argc, char** argv, Options* o) {
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return false;
    if (a.rfind("--", 0) == 0) {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        return false;
      }
      const char* value = argv[++i];
      double number = 0.0;
      if (a == "--align") {
        if (!parse_alignment(value, &o->config.alignment)) {
          std::fprintf(stderr, "--align: '%s' is not none, se3 or sim3\n", value);
          return false;
        }
      } else if (a == "--max-dt") {
        // Up to a day: beyond that the seconds-to-nanoseconds conversion is a wrong unit, not a window.
        if (!parse_double(value, &number) || number < 0.0 || number > 86'400.0) {
          std::fprintf(stderr, "--max-dt: '%s' is not a time in seconds between 0 and 86400\n", value);
          return false;
        }
        o->config.max_time_difference_ns = std::llround(number * 1e9);
      } else if (a == "--rpe-delta") {
        if (!parse_double(value, &number) || !(number > 0.0)) {
          std::fprintf(stderr, "--rpe-delta: '%s' is not a positive distance in metres\n", value);
          return false;
        }
        o->config.rpe_delta_m = number;
      } else if (a == "--json") {
        o->json_path = value;
      } else {
        std::fprintf(stderr, "unknown option %s\n", a.c_str());
        return false;
      }
      continue;
    }
    positional.push_back(a);
  }
  if (positional.size() != 2) {
    std::fprintf(stderr, "expected REFERENCE and ESTIMATE files, got %zu file arguments\n", positional.size());
    return false;
  }
  o->reference_path = positional[0];
  o->estimate_path = positional[1];
  return true;
}

bool read(const std::string& path, std::vector<metrics::TimedPose>* poses) {
  replay::Trajectory trajectory;
  std::string error;
  if (!replay::read_tum_trajectory(path, &trajectory, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return false;
  }
  poses->clear();
  poses->reserve(trajectory.size());
  for (const replay::StampedPose& pose : trajectory) {
    poses->push_back({pose.time_ns, pose.world_t_body_m, pose.world_R_body});
  }
  return true;
}

std::string base_name(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    usage(argv[0]);
    return kExitUsage;
  }
  std::vector<metrics::TimedPose> reference, estimate;
  if (!read(opt.reference_path, &reference) || !read(opt.estimate_path, &estimate)) return 1;

  opt.config.print(stdout);
  const metrics::TrajectoryError e = metrics::evaluate_trajectory(reference, estimate, opt.config);
  if (!e.ok) {
    std::fprintf(stderr, "%s vs %s: %s\n", opt.reference_path.c_str(), opt.estimate_path.c_str(), e.error.c_str());
    return 1;
  }
  std::printf("reference %s: %zu poses (%zu dropped); estimate %s: %zu poses (%zu dropped); associated %zu\n",
              opt.reference_path.c_str(), e.reference_poses, e.reference_dropped, opt.estimate_path.c_str(),
              e.estimate_poses, e.estimate_dropped, e.associated);
  std::printf("alignment %s%s: scale %.6f, rotation %.4f deg, translation %.4f m\n",
              metrics::to_string(opt.config.alignment),
              e.alignment_degenerate ? " (degenerate: positions coincide, translation only)" : "", e.scale,
              Eigen::AngleAxisd(e.R).angle() * 180.0 / 3.14159265358979323846, e.t_m.norm());
  std::printf("ATE  rmse %.4f m  mean %.4f m  median %.4f m  max %.4f m  (path %.3f m)\n", e.ate_rmse_m,
              e.ate_mean_m, e.ate_median_m, e.ate_max_m, e.path_length_m);
  std::printf("RPE  %zu pairs %g m apart: translation rmse %.4f m/m, rotation rmse %.4f deg/m\n", e.rpe_pairs,
              opt.config.rpe_delta_m, e.rpe_translation_rmse_m_per_m, e.rpe_rotation_rmse_deg_per_m);

  if (!opt.json_path.empty()) {
    char conditions[512];
    std::snprintf(conditions, sizeof(conditions),
                  "reference %s, estimate %s, %zu associated poses within %.3f s, alignment %s, RPE pairs %g m "
                  "apart along the reference",
                  base_name(opt.reference_path).c_str(), base_name(opt.estimate_path).c_str(), e.associated,
                  static_cast<double>(opt.config.max_time_difference_ns) * 1e-9,
                  metrics::to_string(opt.config.alignment), opt.config.rpe_delta_m);
    bench::Figures figures(conditions);
    figures.add("traj_eval.ate_rmse", e.ate_rmse_m, "m");
    figures.add("traj_eval.ate_mean", e.ate_mean_m, "m");
    figures.add("traj_eval.ate_median", e.ate_median_m, "m");
    figures.add("traj_eval.ate_max", e.ate_max_m, "m");
    figures.add("traj_eval.scale", e.scale, "ratio");
    figures.add("traj_eval.associated", static_cast<double>(e.associated), "poses");
    figures.add("traj_eval.path_length", e.path_length_m, "m");
    figures.add("traj_eval.rpe_pairs", static_cast<double>(e.rpe_pairs), "pairs");
    figures.add("traj_eval.rpe_translation_rmse", e.rpe_translation_rmse_m_per_m, "m/m");
    figures.add("traj_eval.rpe_rotation_rmse", e.rpe_rotation_rmse_deg_per_m, "deg/m");
    if (!figures.write(opt.json_path)) return 1;
  }
  return 0;
}

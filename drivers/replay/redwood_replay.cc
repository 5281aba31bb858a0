// Redwood .log replay and Open3D camera JSON.
#include "drivers/replay/redwood_replay.h"

#include <algorithm>
#include <cinttypes>
#include <filesystem>
#include <system_error>

#include "drivers/replay/camera_calibration.h"
#include "drivers/replay/text_parse.h"

namespace qsg::replay {
namespace {

// Sorted regular files in folder/sub whose names end in one of `exts` (case-sensitive).
std::vector<std::string> list_images(const std::string& folder, const std::string& sub,
                                     std::initializer_list<const char*> exts) {
  std::vector<std::string> names;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(join_path(folder, sub), ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string name = it->path().filename().string();
    for (const char* ext : exts) {
      const std::string e(ext);
      if (name.size() > e.size() && name.compare(name.size() - e.size(), e.size(), e) == 0) {
        names.push_back(sub + "/" + name);
        break;
      }
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

bool read_camera_intrinsics_json(const std::string& path, messages::CameraIntrinsics* intrinsics,
                                 std::string* error) {
  CameraCalibration calibration;
  if (!read_camera_calibration(path, &calibration, error)) return false;
  *intrinsics = calibration.intrinsics;
  return true;
}

void RedwoodReplay::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "RedwoodReplay: intrinsics %dx%d fx=%g fy=%g cx=%g cy=%g camera_json='%s' trajectory_log='%s' "
               "match_list='%s' depth_scale_m=%g frame_period_ns=%" PRId64 " publish_latency_ns=%" PRId64
               " check_files_at_open=%d size_from_first_frame=%d\n",
               intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy,
               camera_json.c_str(), trajectory_log.c_str(), match_list.c_str(), static_cast<double>(depth_scale_m),
               frame_period_ns, publish_latency_ns, check_files_at_open, size_from_first_frame);
}

bool RedwoodReplay::open(const std::string& folder, const Config& config, std::string* error) {
  config_ = config;
  ListSettings settings;
  settings.intrinsics = config.intrinsics;
  if (!config.camera_json.empty()) {
    if (!read_camera_intrinsics_json(join_path(folder, config.camera_json), &settings.intrinsics, error)) return false;
  }
  log_.clear();
  Trajectory trajectory;
  if (!config.trajectory_log.empty()) {
    if (!read_redwood_log(join_path(folder, config.trajectory_log), &log_, error)) return false;
    trajectory.reserve(log_.size());
    for (const RedwoodLogEntry& e : log_) {
      Eigen::Isometry3d pose(e.world_T_camera);
      trajectory.push_back(StampedPose::from_isometry(e.id[0] * config.frame_period_ns, pose));
    }
  }
  trajectory_odometry_.reset(std::move(trajectory), "redwood_trajectory");

  std::vector<FrameFiles> frames;
  const std::string match_path = join_path(folder, config.match_list);
  if (!config.match_list.empty() && file_exists(match_path)) {
    std::vector<TextLine> lines;
    if (!read_text_lines(match_path, &lines, error)) return false;
    for (const TextLine& line : lines) {
      if (line.fields.size() != 2) {
        if (error) {
          *error = error_at(match_path, line.line_number,
                            "expected 2 fields 'depth_file color_file', found " + std::to_string(line.fields.size()));
        }
        return false;
      }
      FrameFiles f;
      f.depth_path = join_path(folder, line.fields[0]);
      f.rgb_path = join_path(folder, line.fields[1]);
      f.depth_line = f.rgb_line = line.line_number;
      f.sample_time_ns = static_cast<std::int64_t>(frames.size()) * config.frame_period_ns;
      frames.push_back(std::move(f));
    }
    settings.depth_list_name = settings.rgb_list_name = match_path;
  } else {
    const std::vector<std::string> depth = list_images(folder, "depth", {".png"});
    const std::vector<std::string> color = list_images(folder, "color", {".jpg", ".png"});
    if (depth.size() != color.size()) {
      if (error) {
        *error = folder + ": depth/ holds " + std::to_string(depth.size()) + " .png images but color/ holds " +
                 std::to_string(color.size()) + " .jpg/.png images; they must pair up (or give " +
                 config.match_list + ")";
      }
      return false;
    }
    for (std::size_t i = 0; i < depth.size(); ++i) {
      FrameFiles f;
      f.depth_path = join_path(folder, depth[i]);
      f.rgb_path = join_path(folder, color[i]);
      f.sample_time_ns = static_cast<std::int64_t>(i) * config.frame_period_ns;
      frames.push_back(std::move(f));
    }
  }
  settings.size_from_first_frame = config.size_from_first_frame;
  settings.depth_scale_m = config.depth_scale_m;
  settings.publish_latency_ns = config.publish_latency_ns;
  settings.check_files_at_open = config.check_files_at_open;
  return install("redwood_replay", std::move(frames), settings, error);
}

}  // namespace qsg::replay

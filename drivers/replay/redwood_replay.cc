// Redwood .log replay and Open3D camera JSON.
#include "drivers/replay/redwood_replay.h"

#include <algorithm>
#include <cinttypes>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>

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

bool read_camera_intrinsics_json(const std::string& path, drivers::CameraIntrinsics* intrinsics,
                                 std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error) *error = path + ": cannot open";
    return false;
  }
  std::ostringstream text;
  text << in.rdbuf();
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::exception& e) {
    if (error) *error = path + ": " + e.what();
    return false;
  }
  const nlohmann::json* cam = &doc;
  if (doc.is_object() && !doc.contains("intrinsic_matrix") && doc.contains("intrinsic") && doc["intrinsic"].is_object()) {
    cam = &doc["intrinsic"];
  }
  if (!cam->is_object()) {
    if (error) *error = path + ": expected a JSON object";
    return false;
  }
  const auto integer_field = [&](const char* key, int* value) {
    if (!cam->contains(key) || !(*cam)[key].is_number_integer()) {
      if (error) *error = path + ": field '" + key + "': expected an integer";
      return false;
    }
    *value = (*cam)[key].get<int>();
    return true;
  };
  drivers::CameraIntrinsics k;
  if (!integer_field("width", &k.width) || !integer_field("height", &k.height)) return false;
  if (!cam->contains("intrinsic_matrix") || !(*cam)["intrinsic_matrix"].is_array() ||
      (*cam)["intrinsic_matrix"].size() != 9) {
    if (error) *error = path + ": field 'intrinsic_matrix': expected an array of 9 numbers (column-major 3x3)";
    return false;
  }
  double m[9];
  for (std::size_t i = 0; i < 9; ++i) {
    const nlohmann::json& v = (*cam)["intrinsic_matrix"][i];
    if (!v.is_number()) {
      if (error) *error = path + ": field 'intrinsic_matrix[" + std::to_string(i) + "]': expected a number";
      return false;
    }
    m[i] = v.get<double>();
  }
  // Column-major: m[0] = K(0,0), m[4] = K(1,1), m[6] = K(0,2), m[7] = K(1,2).
  k.fx = m[0];
  k.fy = m[4];
  k.cx = m[6];
  k.cy = m[7];
  if (!k.valid()) {
    if (error) {
      *error = path + ": intrinsics invalid or larger than the frame buffers (" + std::to_string(k.width) + "x" +
               std::to_string(k.height) + ", fx " + std::to_string(k.fx) + ", fy " + std::to_string(k.fy) + ")";
    }
    return false;
  }
  *intrinsics = k;
  return true;
}

void RedwoodReplay::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "RedwoodReplay: intrinsics %dx%d fx=%g fy=%g cx=%g cy=%g camera_json='%s' trajectory_log='%s' "
               "match_list='%s' depth_scale_m=%g frame_period_ns=%" PRId64 " publish_latency_ns=%" PRId64
               " check_files_at_open=%d\n",
               intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy,
               camera_json.c_str(), trajectory_log.c_str(), match_list.c_str(), static_cast<double>(depth_scale_m),
               frame_period_ns, publish_latency_ns, check_files_at_open);
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
  settings.size_from_first_frame = false;  // the camera file (or config) states the size; frames must match it
  settings.depth_scale_m = config.depth_scale_m;
  settings.publish_latency_ns = config.publish_latency_ns;
  settings.check_files_at_open = config.check_files_at_open;
  return install("redwood_replay", std::move(frames), settings, error);
}

}  // namespace qsg::replay

// Numbered-frame replay driven by a pose list.
#include "drivers/replay/pose_list_replay.h"

#include <cinttypes>
#include <vector>

#include "drivers/replay/text_parse.h"

namespace qsg::replay {

void PoseListReplay::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "PoseListReplay: intrinsics %dx%d fx=%g fy=%g cx=%g cy=%g depth_scale_m=%g color=%s/<i>%s "
               "depth=%s/<i>%s first_index=%d pose_file='%s' frame_period_ns=%" PRId64 " publish_latency_ns=%" PRId64
               " check_files_at_open=%d size_from_first_frame=%d\n",
               intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy,
               static_cast<double>(depth_scale_m), color_dir.c_str(), color_ext.c_str(), depth_dir.c_str(),
               depth_ext.c_str(), first_index, pose_file.c_str(), frame_period_ns, publish_latency_ns,
               check_files_at_open, size_from_first_frame);
}

bool PoseListReplay::open(const std::string& folder, const Config& config, std::string* error) {
  config_ = config;
  const std::string pose_path = join_path(folder, config.pose_file);
  Trajectory trajectory;
  if (!read_pose_list(pose_path, config.frame_period_ns, &trajectory, error)) return false;
  std::vector<TextLine> lines;  // line numbers of the poses, to name the line a missing frame was listed on
  if (!read_text_lines(pose_path, &lines, error)) return false;
  std::vector<FrameFiles> frames;
  frames.reserve(trajectory.size());
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const std::string number = std::to_string(config.first_index + static_cast<int>(i));
    FrameFiles f;
    f.depth_path = join_path(folder, join_path(config.depth_dir, number + config.depth_ext));
    f.rgb_path = join_path(folder, join_path(config.color_dir, number + config.color_ext));
    f.depth_line = f.rgb_line = lines[i].line_number;
    f.sample_time_ns = trajectory[i].time_ns;
    frames.push_back(std::move(f));
  }
  trajectory_odometry_.reset(std::move(trajectory), "pose_list_trajectory");
  ListSettings settings;
  settings.intrinsics = config.intrinsics;
  settings.size_from_first_frame = config.size_from_first_frame;
  settings.depth_scale_m = config.depth_scale_m;
  settings.publish_latency_ns = config.publish_latency_ns;
  settings.check_files_at_open = config.check_files_at_open;
  settings.depth_list_name = settings.rgb_list_name = pose_path;
  return install("pose_list_replay", std::move(frames), settings, error);
}

}  // namespace qsg::replay

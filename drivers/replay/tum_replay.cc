// TUM RGB-D replay: list parsing, timestamp association, ground truth.
#include "drivers/replay/tum_replay.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <tuple>

#include "drivers/replay/text_parse.h"

namespace qsg::replay {

std::vector<std::pair<std::size_t, std::size_t>> associate_timestamps(const std::vector<std::int64_t>& first,
                                                                      const std::vector<std::int64_t>& second,
                                                                      std::int64_t max_difference_ns) {
  std::vector<std::size_t> order(second.size());
  for (std::size_t j = 0; j < order.size(); ++j) order[j] = j;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return second[a] < second[b] || (second[a] == second[b] && a < b);
  });
  // Candidates inside the window only (the tool builds all pairs; the window keeps this linear in practice).
  struct Candidate {
    std::int64_t diff;
    std::size_t i;
    std::size_t j;
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < first.size(); ++i) {
    const std::int64_t lo = first[i] - max_difference_ns;
    auto it = std::upper_bound(order.begin(), order.end(), lo,
                               [&](std::int64_t t, std::size_t j) { return t < second[j]; });
    for (; it != order.end(); ++it) {
      const std::int64_t diff = second[*it] - first[i];
      if (diff >= max_difference_ns) break;
      candidates.push_back({diff < 0 ? -diff : diff, i, *it});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [&](const Candidate& a, const Candidate& b) {
    return std::make_tuple(a.diff, first[a.i], second[a.j], a.i, a.j) <
           std::make_tuple(b.diff, first[b.i], second[b.j], b.i, b.j);
  });
  std::vector<bool> used_first(first.size(), false);
  std::vector<bool> used_second(second.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> matches;
  for (const Candidate& c : candidates) {
    if (used_first[c.i] || used_second[c.j]) continue;
    used_first[c.i] = true;
    used_second[c.j] = true;
    matches.emplace_back(c.i, c.j);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

bool read_tum_list(const std::string& folder, const std::string& list_name, std::vector<ListedFile>* files,
                   std::string* error) {
  files->clear();
  const std::string path = join_path(folder, list_name);
  std::vector<TextLine> lines;
  if (!read_text_lines(path, &lines, error)) return false;
  files->reserve(lines.size());
  for (const TextLine& line : lines) {
    if (line.fields.size() != 2) {
      if (error) {
        *error = error_at(path, line.line_number,
                          "expected 2 fields 'timestamp filename', found " + std::to_string(line.fields.size()));
      }
      return false;
    }
    ListedFile file;
    if (!parse_seconds_to_ns(line.fields[0], &file.time_ns)) {
      if (error) *error = error_at(path, line.line_number, "timestamp '" + line.fields[0] + "' is not a number");
      return false;
    }
    file.path = join_path(folder, line.fields[1]);
    file.line_number = line.line_number;
    files->push_back(std::move(file));
  }
  return true;
}

void TumReplay::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "TumReplay: intrinsics %dx%d fx=%g fy=%g cx=%g cy=%g size_from_first_frame=%d depth_scale_m=%g "
               "max_time_difference_s=%g labels_max_time_difference_s=%g publish_latency_ns=%" PRId64
               " check_files_at_open=%d require_groundtruth=%d read_labels=%d lists=%s,%s,%s,%s "
               "groundtruth_max_gap_s=%g\n",
               intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy,
               size_from_first_frame, static_cast<double>(depth_scale_m), max_time_difference_s,
               labels_max_time_difference_s, publish_latency_ns,
               check_files_at_open, require_groundtruth, read_labels, rgb_list.c_str(), depth_list.c_str(),
               labels_list.c_str(), groundtruth.c_str(), groundtruth_max_gap_s);
}

bool TumReplay::open(const std::string& folder, const Config& config, std::string* error) {
  config_ = config;
  std::vector<ListedFile> rgb;
  std::vector<ListedFile> depth;
  if (!read_tum_list(folder, config.rgb_list, &rgb, error)) return false;
  if (!read_tum_list(folder, config.depth_list, &depth, error)) return false;
  std::vector<ListedFile> labels;
  const std::string labels_path = join_path(folder, config.labels_list);
  if (config.read_labels && file_exists(labels_path)) {
    if (!read_tum_list(folder, config.labels_list, &labels, error)) return false;
  }
  const std::string gt_path = join_path(folder, config.groundtruth);
  Trajectory groundtruth;
  if (file_exists(gt_path)) {
    if (!read_tum_trajectory(gt_path, &groundtruth, error)) return false;
  } else if (config.require_groundtruth) {
    if (error) *error = gt_path + ": cannot open (ground truth required)";
    return false;
  }
  groundtruth_odometry_.reset(std::move(groundtruth), "tum_groundtruth");

  const auto stamps = [](const std::vector<ListedFile>& files) {
    std::vector<std::int64_t> t(files.size());
    for (std::size_t i = 0; i < files.size(); ++i) t[i] = files[i].time_ns;
    return t;
  };
  const std::int64_t window_ns = std::llround(config.max_time_difference_s * 1e9);
  const std::vector<std::int64_t> depth_t = stamps(depth);
  const auto depth_rgb = associate_timestamps(depth_t, stamps(rgb), window_ns);
  std::vector<std::size_t> label_of_depth(depth.size(), SIZE_MAX);
  const std::int64_t labels_window_ns = std::llround(config.labels_max_time_difference_s * 1e9);
  for (const auto& m : associate_timestamps(depth_t, stamps(labels), labels_window_ns)) {
    label_of_depth[m.first] = m.second;
  }

  std::vector<FrameFiles> frames;
  frames.reserve(depth_rgb.size());
  for (const auto& [di, ri] : depth_rgb) {
    FrameFiles f;
    f.depth_path = depth[di].path;
    f.depth_line = depth[di].line_number;
    f.rgb_path = rgb[ri].path;
    f.rgb_line = rgb[ri].line_number;
    if (label_of_depth[di] != SIZE_MAX) {
      f.labels_path = labels[label_of_depth[di]].path;
      f.labels_line = labels[label_of_depth[di]].line_number;
    }
    f.sample_time_ns = depth[di].time_ns;
    frames.push_back(std::move(f));
  }
  ListSettings settings;
  settings.intrinsics = config.intrinsics;
  settings.size_from_first_frame = config.size_from_first_frame;
  settings.depth_scale_m = config.depth_scale_m;
  settings.publish_latency_ns = config.publish_latency_ns;
  settings.check_files_at_open = config.check_files_at_open;
  settings.depth_list_name = join_path(folder, config.depth_list);
  settings.rgb_list_name = join_path(folder, config.rgb_list);
  settings.labels_list_name = labels_path;
  return install("tum_replay", std::move(frames), settings, error);
}

bool TumReplay::ground_truth_at(std::int64_t time_ns, StampedPose* pose) const {
  return interpolate_pose(ground_truth(), time_ns, std::llround(config_.groundtruth_max_gap_s * 1e9), pose);
}

}  // namespace qsg::replay

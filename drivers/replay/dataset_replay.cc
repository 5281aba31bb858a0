// Dataset format detection, camera resolution (calibration file, config overrides, format default) and the
// backend behind one replay.
#include "drivers/replay/dataset_replay.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <vector>

#include "drivers/replay/camera_calibration.h"
#include "drivers/replay/text_parse.h"

namespace qsg::replay {
namespace {

bool is_folder(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec);
}

bool holds(const std::string& folder, DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kTum:
      return file_exists(join_path(folder, "rgb.txt")) && file_exists(join_path(folder, "depth.txt"));
    case DatasetFormat::kRedwood:
      return is_folder(join_path(folder, "depth")) && is_folder(join_path(folder, "color")) &&
             (file_exists(join_path(folder, "trajectory.log")) || file_exists(join_path(folder, "rgbd.match")));
    case DatasetFormat::kPoseList:
      return file_exists(join_path(folder, "pose.txt")) && is_folder(join_path(folder, "depth"));
  }
  return false;
}

std::string parent_folder(const std::string& folder) {
  std::filesystem::path p(folder);
  if (!p.has_filename()) p = p.parent_path();  // "a/b/" -> "a/b"
  return p.parent_path().empty() ? std::string("..") : p.parent_path().string();
}

// All three formats' documented default camera is the PrimeSense / Kinect one TUM's ROS driver assumed.
messages::CameraIntrinsics default_intrinsics() {
  return messages::CameraIntrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
}

float default_depth_scale_m(DatasetFormat format) {
  // TUM and slambook2's pose lists store 5000 units per metre; Redwood stores millimetres.
  return format == DatasetFormat::kRedwood ? 0.001f : 1.0f / 5000.0f;
}

const char* default_camera_text(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kTum: return "the TUM default camera (640x480, fx = fy = 525, cx = 319.5, cy = 239.5)";
    case DatasetFormat::kRedwood: return "the Redwood default camera (PrimeSense: 640x480, fx = fy = 525, cx = 319.5, cy = 239.5)";
    case DatasetFormat::kPoseList: return "the pose-list default camera (640x480, fx = fy = 525, cx = 319.5, cy = 239.5)";
  }
  return "?";
}

// Numbered frames: the first index (1 in slambook2's samples, 0 accepted) and the extensions present.
void find_numbered_frames(const std::string& folder, PoseListReplay::Config* c) {
  for (const int first : {1, 0}) {
    for (const char* ext : {".png", ".pgm"}) {
      if (!file_exists(join_path(folder, "depth/" + std::to_string(first) + ext))) continue;
      c->first_index = first;
      c->depth_ext = ext;
      for (const char* colour_ext : {".png", ".jpg", ".ppm"}) {
        if (file_exists(join_path(folder, "color/" + std::to_string(first) + colour_ext))) {
          c->color_ext = colour_ext;
          break;
        }
      }
      return;
    }
  }
}

}  // namespace

const char* to_string(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kTum: return "tum";
    case DatasetFormat::kRedwood: return "redwood";
    case DatasetFormat::kPoseList: return "pose_list";
  }
  return "?";
}

bool parse_dataset_format(const std::string& name, DatasetFormat* format) {
  for (const DatasetFormat f : {DatasetFormat::kTum, DatasetFormat::kRedwood, DatasetFormat::kPoseList}) {
    if (name == to_string(f)) {
      *format = f;
      return true;
    }
  }
  return false;
}

std::string DatasetReplayConfig::check() const {
  if (format != "auto") {
    DatasetFormat f;
    if (!parse_dataset_format(format, &f)) return "format: expected auto, tum, redwood or pose_list, got '" + format + "'";
  }
  // 0 means "from the dataset"; anything else must be a plausible camera (NaN fails every comparison).
  if (!(fx == 0.0 || (fx >= 1.0 && fx <= 1e5))) return "fx must be 0 (from the dataset) or in [1, 1e5] pixels";
  if (!(fy == 0.0 || (std::abs(fy) >= 1.0 && std::abs(fy) <= 1e5)))
    return "fy must be 0 (from the dataset) or in [1, 1e5] pixels, either sign";
  if (!(cx == 0.0 || (cx > 0.0 && cx <= messages::kMaxFrameWidth)))
    return "cx must be 0 (from the dataset) or in (0, " + std::to_string(messages::kMaxFrameWidth) + "] pixels";
  if (!(cy == 0.0 || (cy > 0.0 && cy <= messages::kMaxFrameHeight)))
    return "cy must be 0 (from the dataset) or in (0, " + std::to_string(messages::kMaxFrameHeight) + "] pixels";
  if (!(depth_scale_m == 0.0 || (depth_scale_m >= kMinDepthScaleM && depth_scale_m <= kMaxDepthScaleM)))
    return "depth_scale_m must be 0 (from the dataset) or in [1e-6, 1] metres per unit";
  if (!(frame_period_s >= 1e-3 && frame_period_s <= 10.0)) return "frame_period_s must be in [0.001, 10]";
  return {};
}

void DatasetReplayConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "replay: path=%s format=%s calibration=%s fx=%g fy=%g cx=%g cy=%g depth_scale_m=%g (0: from the "
               "dataset) frame_period_s=%g check_files_at_open=%d\n",
               path.c_str(), format.c_str(), calibration.empty() ? "(calibration.json beside the frames)" : calibration.c_str(),
               fx, fy, cx, cy, depth_scale_m, frame_period_s, check_files_at_open ? 1 : 0);
}

bool detect_dataset_format(const std::string& path, DatasetFormat* format, std::string* frames_folder,
                           std::string* error) {
  for (const std::string& folder : {path, join_path(path, "RGBD")}) {
    for (const DatasetFormat f : {DatasetFormat::kTum, DatasetFormat::kRedwood, DatasetFormat::kPoseList}) {
      if (holds(folder, f)) {
        *format = f;
        *frames_folder = folder;
        return true;
      }
    }
  }
  if (error) {
    *error = path + (is_folder(path) ? ": no dataset found" : ": not a folder") +
             " (looked for rgb.txt and depth.txt: TUM; depth/ and color/ with trajectory.log or rgbd.match: Redwood; "
             "pose.txt and depth/: pose list; here and in RGBD/)";
  }
  return false;
}

// Before a successful open, the (empty) TUM backend: reads end at once.
drivers::RgbdSource& DatasetReplay::camera() {
  return active_ != nullptr ? *active_ : static_cast<ImageListReplay&>(tum_);
}

std::size_t DatasetReplay::size() const { return active_ != nullptr ? active_->size() : 0; }

std::size_t DatasetReplay::position() const { return active_ != nullptr ? active_->position() : 0; }

messages::CameraIntrinsics DatasetReplay::intrinsics() const {
  return active_ != nullptr ? active_->intrinsics() : messages::CameraIntrinsics{};
}

bool DatasetReplay::open(const DatasetReplayConfig& config, std::string* error) {
  const auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  config_ = config;
  active_ = nullptr;
  ground_truth_.clear();
  camera_source_.clear();
  if (config.path.empty()) return fail("replay: no dataset folder given");
  if (const std::string bad = config.check(); !bad.empty()) return fail("replay: " + bad);
  if (config.format == "auto") {
    if (!detect_dataset_format(config.path, &format_, &frames_folder_, error)) return false;
  } else {
    parse_dataset_format(config.format, &format_);
    if (!is_folder(config.path)) return fail(config.path + ": not a folder");
    const std::string rgbd = join_path(config.path, "RGBD");
    frames_folder_ = !holds(config.path, format_) && holds(rgbd, format_) ? rgbd : config.path;
  }

  // The camera: the calibration file, else the format's default; then the config keys over either.
  messages::CameraIntrinsics k = default_intrinsics();
  float scale = default_depth_scale_m(format_);
  std::string calibration_path = config.calibration;
  std::vector<std::string> looked_for;
  if (calibration_path.empty()) {
    looked_for.push_back(join_path(frames_folder_, kCalibrationFileName));
    if (frames_folder_ != config.path) looked_for.push_back(join_path(config.path, kCalibrationFileName));
    if (format_ == DatasetFormat::kRedwood) {
      // Open3D's name for its PrimeSense calibration, beside RGBD/ in its test data.
      looked_for.push_back(join_path(frames_folder_, "camera_primesense.json"));
      looked_for.push_back(join_path(parent_folder(frames_folder_), "camera_primesense.json"));
    }
    for (const std::string& candidate : looked_for) {
      if (file_exists(candidate)) {
        calibration_path = candidate;
        break;
      }
    }
  }
  CameraCalibration calibration;
  const bool have_calibration = !calibration_path.empty();
  if (have_calibration) {
    if (!read_camera_calibration(calibration_path, &calibration, error)) return false;
    k = calibration.intrinsics;
    if (calibration.depth_scale_m > 0.0f) scale = calibration.depth_scale_m;
  }
  std::string overridden;
  const auto take = [&](double value, double* field, const char* name) {
    if (value == 0.0) return;
    *field = value;
    overridden += overridden.empty() ? name : std::string(", ") + name;
  };
  take(config.fx, &k.fx, "fx");
  take(config.fy, &k.fy, "fy");
  take(config.cx, &k.cx, "cx");
  take(config.cy, &k.cy, "cy");
  if (config.depth_scale_m > 0.0) {
    scale = static_cast<float>(config.depth_scale_m);
    overridden += overridden.empty() ? "depth_scale_m" : ", depth_scale_m";
  }
  const bool whole_camera_from_config = config.fx != 0.0 && config.fy != 0.0 && config.cx != 0.0 && config.cy != 0.0;
  // A camera given whole by the config keys states no size: the frames have it.
  const bool size_from_frames = !have_calibration && whole_camera_from_config;
  default_intrinsics_ = !have_calibration && !whole_camera_from_config;
  default_depth_scale_ = (!have_calibration || calibration.depth_scale_m == 0.0f) && config.depth_scale_m == 0.0;
  if (have_calibration) camera_source_ = "calibration " + calibration_path;
  else if (default_intrinsics_) camera_source_ = default_camera_text(format_);
  else camera_source_ = "config";
  if (!overridden.empty() && camera_source_ != "config") camera_source_ += "; " + overridden + " from config";
  depth_scale_m_ = scale;
  looked_for_ = looked_for;
  if (!size_from_frames) {
    if (const std::string bad = check_intrinsics(k); !bad.empty()) return fail("replay: camera (" + camera_source_ + "): " + bad);
  }

  const std::int64_t period_ns = std::llround(config.frame_period_s * 1e9);
  switch (format_) {
    case DatasetFormat::kTum: {
      TumReplay::Config c;
      c.intrinsics = k;
      c.size_from_first_frame = size_from_frames;
      c.depth_scale_m = scale;
      c.check_files_at_open = config.check_files_at_open;
      c.require_groundtruth = false;
      tum_.set_intrinsics_source(camera_source_);
      if (!tum_.open(frames_folder_, c, error)) return false;
      ground_truth_ = tum_.ground_truth();
      ground_truth_max_gap_ns_ = std::llround(c.groundtruth_max_gap_s * 1e9);
      active_ = &tum_;
      break;
    }
    case DatasetFormat::kRedwood: {
      RedwoodReplay::Config c;
      c.intrinsics = k;
      c.size_from_first_frame = size_from_frames;
      c.depth_scale_m = scale;
      c.frame_period_ns = period_ns;
      c.check_files_at_open = config.check_files_at_open;
      if (!file_exists(join_path(frames_folder_, c.trajectory_log))) c.trajectory_log.clear();
      redwood_.set_intrinsics_source(camera_source_);
      if (!redwood_.open(frames_folder_, c, error)) return false;
      ground_truth_ = redwood_.trajectory();
      // A pose per frame at the frame's own time; one missing pose may be bridged.
      ground_truth_max_gap_ns_ = 2 * period_ns;
      active_ = &redwood_;
      break;
    }
    case DatasetFormat::kPoseList: {
      PoseListReplay::Config c;
      c.intrinsics = k;
      c.size_from_first_frame = size_from_frames;
      c.depth_scale_m = scale;
      c.frame_period_ns = period_ns;
      c.check_files_at_open = config.check_files_at_open;
      find_numbered_frames(frames_folder_, &c);
      pose_list_.set_intrinsics_source(camera_source_);
      if (!pose_list_.open(frames_folder_, c, error)) return false;
      ground_truth_ = pose_list_.trajectory();
      ground_truth_max_gap_ns_ = 2 * period_ns;
      active_ = &pose_list_;
      break;
    }
  }
  std::stable_sort(ground_truth_.begin(), ground_truth_.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.time_ns < b.time_ns; });
  if (size_from_frames) {
    if (const std::string bad = check_intrinsics(active_->intrinsics()); !bad.empty()) {
      active_ = nullptr;
      return fail("replay: camera (" + camera_source_ + "): " + bad);
    }
  }
  return true;
}

void DatasetReplay::print(std::FILE* out) const {
  if (active_ == nullptr) {
    std::fprintf(out, "replay: not open\n");
    return;
  }
  const messages::CameraIntrinsics k = active_->intrinsics();
  std::fprintf(out, "replay: %s dataset in %s: %zu frames, %zu ground-truth poses\n", format_name(),
               frames_folder_.c_str(), size(), ground_truth_.size());
  std::fprintf(out, "replay: camera %dx%d fx=%g fy=%g cx=%g cy=%g depth_scale_m=%g (%s)\n", k.width, k.height, k.fx,
               k.fy, k.cx, k.cy, static_cast<double>(depth_scale_m_), camera_source_.c_str());
  if (default_intrinsics_) {
    std::string looked;
    for (const std::string& p : looked_for_) looked += (looked.empty() ? "" : ", ") + p;
    std::fprintf(out,
                 "replay: NOTICE: no calibration file (looked for %s): the format's default camera was used. If the "
                 "frames came from another camera, write %s beside them or set replay.fx/fy/cx/cy "
                 "(drivers/replay/README.md)\n",
                 looked.c_str(), kCalibrationFileName);
  }
  if (default_depth_scale_) {
    std::fprintf(out,
                 "replay: NOTICE: no depth scale in a calibration file or the config: the %s default, %g m per unit, "
                 "was used\n",
                 format_name(), static_cast<double>(depth_scale_m_));
  }
}

}  // namespace qsg::replay

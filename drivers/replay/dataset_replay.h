// One entry point for every dataset replay: finds which format a folder holds (TUM RGB-D, Redwood, pose list),
// takes the camera from the calibration file beside the frames (config keys override it; without either, the
// format's documented default, with a notice), and gives the frames as an RgbdSource and the dataset's poses as
// ground truth.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/replay/pose_list_replay.h"
#include "drivers/replay/redwood_replay.h"
#include "drivers/replay/trajectory.h"
#include "drivers/replay/tum_replay.h"

namespace qsg::replay {

struct DatasetReplayConfig {
  std::string path;              // the dataset folder (for Redwood, the folder holding RGBD/ is accepted too)
  std::string format = "auto";   // auto | tum | redwood | pose_list
  std::string calibration;       // a calibration file (camera_calibration.h); "": calibration.json beside the frames
  // Overrides, 0 = from the calibration file, else from the format's default. fy may be negative (ICL-NUIM).
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  double depth_scale_m = 0.0;    // metres per raw depth unit
  // Redwood and pose lists carry no time stamps: frame i is sampled at i * frame_period_s.
  double frame_period_s = 1.0 / 30.0;
  bool check_files_at_open = true;  // every listed file must exist at open

  // What is wrong, or "" (the path is checked by open).
  std::string check() const;
  void print(std::FILE* out) const;
};

enum class DatasetFormat { kTum, kRedwood, kPoseList };
const char* to_string(DatasetFormat format);
// "tum", "redwood", "pose_list"; false for anything else.
bool parse_dataset_format(const std::string& name, DatasetFormat* format);

// Which format `path` holds, checked in this order: TUM (rgb.txt and depth.txt), Redwood (depth/ and color/ with
// trajectory.log or rgbd.match), pose list (pose.txt and depth/); first in `path`, then in `path`/RGBD (Open3D's
// layout). *frames_folder is where the frames are. False with an error saying what was looked for.
bool detect_dataset_format(const std::string& path, DatasetFormat* format, std::string* frames_folder,
                           std::string* error);

class DatasetReplay {
 public:
  DatasetReplay() = default;
  DatasetReplay(const DatasetReplay&) = delete;
  DatasetReplay& operator=(const DatasetReplay&) = delete;

  // Opens the dataset. Errors name the file (and line or field): no dataset found, a malformed list or calibration
  // file, a listed file missing, a depth image whose size is not the intrinsics' (both sizes named).
  bool open(const DatasetReplayConfig& config, std::string* error);

  drivers::RgbdSource& camera();
  // The dataset's poses (camera-to-world) sorted by time: TUM groundtruth.txt, Redwood trajectory.log, pose.txt.
  // Empty when the dataset has none.
  const Trajectory& ground_truth() const { return ground_truth_; }
  // How far apart two ground-truth poses may be for a frame between them to take an interpolated pose.
  std::int64_t ground_truth_max_gap_ns() const { return ground_truth_max_gap_ns_; }
  std::size_t size() const;
  std::size_t position() const;  // frames read so far (including skipped ones)
  const char* format_name() const { return to_string(format_); }
  DatasetFormat format() const { return format_; }
  const std::string& frames_folder() const { return frames_folder_; }

  messages::CameraIntrinsics intrinsics() const;
  float depth_scale_m() const { return depth_scale_m_; }
  // Where the camera came from, e.g. "calibration /data/x/calibration.json, fx from config" or
  // "the TUM default camera".
  const std::string& camera_source() const { return camera_source_; }
  // True when no calibration file and no complete set of config keys gave the intrinsics, or nothing gave the
  // depth scale: the format's default was used (print() says so).
  bool used_default_camera() const { return default_intrinsics_ || default_depth_scale_; }
  // The format, folder, frame count, camera and its source; a notice when defaults were used.
  void print(std::FILE* out) const;

 private:
  DatasetReplayConfig config_;
  DatasetFormat format_ = DatasetFormat::kTum;
  std::string frames_folder_;
  TumReplay tum_;
  RedwoodReplay redwood_;
  PoseListReplay pose_list_;
  ImageListReplay* active_ = nullptr;
  Trajectory ground_truth_;
  std::int64_t ground_truth_max_gap_ns_ = 0;
  float depth_scale_m_ = 0.0f;
  std::string camera_source_;
  std::vector<std::string> looked_for_;  // calibration files searched for (none found: the default camera)
  bool default_intrinsics_ = false;
  bool default_depth_scale_ = false;
};

}  // namespace qsg::replay

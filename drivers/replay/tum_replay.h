// TUM RGB-D dataset replay (rgb.txt, depth.txt, optional groundtruth.txt and labels.txt) and the writer of that
// format, so simulated runs can be stored on disk and read back by this replay and by third-party tools.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "drivers/replay/image_list_replay.h"
#include "drivers/replay/trajectory.h"

namespace qsg::replay {

// Pairs two timestamp lists the way the TUM associate tool does: candidates with |a - b| < max_difference_ns,
// taken greedily by increasing difference (ties by a, then b), each stamp used at most once. Returns index
// pairs (into first, into second) in the order of `first` (file order, so backwards stamps stay visible).
std::vector<std::pair<std::size_t, std::size_t>> associate_timestamps(const std::vector<std::int64_t>& first,
                                                                      const std::vector<std::int64_t>& second,
                                                                      std::int64_t max_difference_ns);

// Reads a TUM list file (`timestamp filename` lines, '#' comments) and resolves names against `folder`.
struct ListedFile {
  std::int64_t time_ns = 0;
  std::string path;
  int line_number = 0;
};
bool read_tum_list(const std::string& folder, const std::string& list_name, std::vector<ListedFile>* files,
                   std::string* error);

class TumReplay : public ImageListReplay {
 public:
  struct Config {
    messages::CameraIntrinsics intrinsics;  // default: TUM's ROS default (fx = fy = 525, cx = 319.5, cy = 239.5)
    bool size_from_first_frame = true;     // width/height from the first depth image instead of `intrinsics`
    float depth_scale_m = 1.0f / 5000.0f;  // TUM depth PNGs hold 5000 units per metre
    double max_time_difference_s = 0.02;   // association window, as the TUM associate tool
    // Label images carry their frame's exact stamp (TumWriter); a tight window keeps a frame without labels from
    // borrowing its neighbour's.
    double labels_max_time_difference_s = 0.001;
    std::int64_t publish_latency_ns = 0;
    bool check_files_at_open = true;  // every listed file must exist at open (else: counted and skipped in replay)
    bool require_groundtruth = false;
    bool read_labels = true;  // labels.txt (this project's extension) when present
    std::string rgb_list = "rgb.txt";
    std::string depth_list = "depth.txt";
    std::string labels_list = "labels.txt";
    std::string groundtruth = "groundtruth.txt";
    // Ground-truth lookup for a frame: interpolate between samples at most this far apart.
    double groundtruth_max_gap_s = 0.1;
    void print(std::FILE* out) const;
  };

  TumReplay() = default;
  // False with an error naming the file and line on a missing list, a malformed line, a non-numeric timestamp,
  // or (with check_files_at_open) a listed file that does not exist. Sample time of a frame = its depth stamp.
  bool open(const std::string& folder, const Config& config, std::string* error);

  const Config& config() const { return config_; }
  // groundtruth.txt as read (empty when absent), and an OdometrySource that plays it back.
  const Trajectory& ground_truth() const { return groundtruth_odometry_.trajectory(); }
  drivers::OdometrySource& ground_truth_odometry() { return groundtruth_odometry_; }
  // Ground-truth camera pose at a frame's sample time, interpolated; false when not covered.
  bool ground_truth_at(std::int64_t time_ns, StampedPose* pose) const;

 private:
  Config config_;
  TrajectoryOdometry groundtruth_odometry_;
};

// Writes frames and poses as a TUM RGB-D folder: rgb/<t>.png (8-bit colour), depth/<t>.png (16-bit, value =
// round(depth_m / depth_scale_m), 0 = no return), optional labels/<t>.png (16-bit) listed in labels.txt,
// groundtruth.txt, and calibration.json (camera_calibration.h) with the first frame's camera and the depth scale;
// frames from another camera are refused. Not for the real-time path: encoding allocates.
class TumWriter {
 public:
  struct Config {
    float depth_scale_m = 1.0f / 5000.0f;
    bool write_labels = true;  // for frames with has_labels
    int png_compression = 1;   // 0-9; low is fast and still lossless
    void print(std::FILE* out) const;
  };
  struct Stats {
    std::uint64_t frames = 0;
    std::uint64_t poses = 0;
    std::uint64_t depth_out_of_range_px = 0;  // deeper than 65535 units: written as 0 (no return)
  };

  TumWriter() = default;
  ~TumWriter();
  TumWriter(const TumWriter&) = delete;
  TumWriter& operator=(const TumWriter&) = delete;

  // Creates the folder (and rgb/, depth/, labels/) and the list files, replacing existing lists.
  bool open(const std::string& folder, const Config& config, std::string* error);
  bool write_frame(const messages::RgbdFrame& frame, std::string* error);
  bool write_pose(const StampedPose& pose, std::string* error);
  bool close(std::string* error);
  const Stats& stats() const { return stats_; }

 private:
  bool fail(const std::string& message, std::string* error);

  Config config_;
  std::string folder_;
  std::FILE* rgb_list_ = nullptr;
  std::FILE* depth_list_ = nullptr;
  std::FILE* labels_list_ = nullptr;
  std::FILE* groundtruth_ = nullptr;
  bool have_last_time_ = false;
  std::int64_t last_time_ns_ = 0;
  bool have_camera_ = false;
  messages::CameraIntrinsics camera_;
  Stats stats_;
};

}  // namespace qsg::replay

// Shared core of the dataset replays: a list of per-frame image files decoded, in order, into a caller-owned
// RgbdFrame. A listed file that is missing or corrupt is counted and skipped; replay goes on with the next frame.
//
// Decoding uses cv::imread, which allocates inside OpenCV on every frame. That is accepted for replay (a host
// tool reading from disk); the frame buffers themselves are the caller's, preallocated, and no other allocation
// happens per read.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "drivers/sources.h"

namespace qsg::replay {

// One frame's files, resolved to paths at open time, plus where they were listed (for error messages).
struct FrameFiles {
  std::string depth_path;
  std::string rgb_path;     // empty: no colour (the frame's rgb is zero-filled)
  std::string labels_path;  // empty: no labels (has_labels = false)
  std::int64_t sample_time_ns = 0;
  int depth_line = 0;  // line in the depth list (0: not from a list)
  int rgb_line = 0;
  int labels_line = 0;
};

class ImageListReplay : public drivers::RgbdSource {
 public:
  ImageListReplay() = default;
  ImageListReplay(const ImageListReplay&) = delete;
  ImageListReplay& operator=(const ImageListReplay&) = delete;

  const char* name() const override { return name_; }
  messages::CameraIntrinsics intrinsics() const override { return intrinsics_; }
  // Decodes the next listed frame into `frame` (sequence = its index in the list). Never waits: the timeout is
  // ignored. Missing files count in missing_files, undecodable ones (corrupt, wrong size or pixel type) in
  // bad_frames; both are skipped and the next delivered frame carries kFrameSequenceGap. A sample time not
  // after the previous delivered one is flagged kFrameTimestampBackwards and counted. After the last frame,
  // kEndOfStream forever.
  drivers::ReadStatus read(messages::RgbdFrame& frame, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return counters_; }

  std::size_t size() const { return frames_.size(); }
  std::size_t position() const { return next_; }
  const std::vector<FrameFiles>& frames() const { return frames_; }
  // Starts over from the first frame (counters kept; the first frame after a rewind is not flagged backwards).
  void rewind();
  // Where the intrinsics come from ("calibration /data/x/calibration.json", "the TUM default camera"), named in
  // open's size error; set before open.
  void set_intrinsics_source(std::string source) { intrinsics_source_ = std::move(source); }
  // Why the last skipped frame was skipped, naming the file ("" if none was skipped).
  const char* last_error() const { return last_error_; }

 protected:
  struct ListSettings {
    messages::CameraIntrinsics intrinsics;
    bool size_from_first_frame = true;  // width/height from the first readable depth image, not the config
    float depth_scale_m = 0.001f;
    std::int64_t publish_latency_ns = 0;
    bool check_files_at_open = true;    // every listed file must exist, or open fails naming it
    std::string depth_list_name;        // names of the lists the files came from, for error messages
    std::string rgb_list_name;
    std::string labels_list_name;
  };
  // Installs the frame list; called by the dataset-specific open(). False with an error naming file and line.
  // When the size is not taken from the first frame, the first readable depth image must have it: a frame of
  // another size is a camera the intrinsics do not describe, refused naming the file and both sizes.
  bool install(const char* name, std::vector<FrameFiles> frames, const ListSettings& settings, std::string* error);

 private:
  enum class Outcome { kOk, kMissing, kCorrupt };
  Outcome decode(const FrameFiles& files, messages::RgbdFrame& frame);
  Outcome fail(Outcome outcome, const char* what, const std::string& path);
  Outcome wrong_size(const char* what, const std::string& path, int width, int height);

  const char* name_ = "replay";
  std::string intrinsics_source_;
  std::vector<FrameFiles> frames_;
  messages::CameraIntrinsics intrinsics_;
  float depth_scale_m_ = 0.001f;
  std::int64_t publish_latency_ns_ = 0;
  std::size_t next_ = 0;
  bool have_last_ = false;
  bool gap_pending_ = false;
  std::int64_t last_sample_time_ns_ = 0;
  std::uint64_t last_sequence_ = 0;
  drivers::DriverCounters counters_;
  char last_error_[512] = {};
};

}  // namespace qsg::replay

// Decoding of listed depth / colour / label images into preallocated frames.
#include "drivers/replay/image_list_replay.h"

#include <cstdio>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/replay/text_parse.h"

namespace qsg::replay {
namespace {

// cv::imread reports most decoder failures as an empty image, but may still throw (cv::Exception, bad_alloc on
// an absurd header); nothing may escape a read.
cv::Mat read_image(const std::string& path, int flags) {
  try {
    return cv::imread(path, flags);
  } catch (...) {
    return cv::Mat();
  }
}

std::string listed_at(const std::string& list_name, int line) {
  if (list_name.empty() || line <= 0) return std::string();
  return list_name + ":" + std::to_string(line) + ": ";
}

}  // namespace

bool ImageListReplay::install(const char* name, std::vector<FrameFiles> frames, const ListSettings& settings,
                              std::string* error) {
  name_ = name;
  frames_ = std::move(frames);
  intrinsics_ = settings.intrinsics;
  depth_scale_m_ = settings.depth_scale_m;
  publish_latency_ns_ = settings.publish_latency_ns;
  counters_ = drivers::DriverCounters{};
  rewind();
  if (!(depth_scale_m_ > 0.0f)) {
    if (error) *error = std::string(name) + ": depth scale must be positive";
    return false;
  }
  if (settings.check_files_at_open) {
    for (const FrameFiles& f : frames_) {
      const struct {
        const std::string& path;
        const std::string& list;
        int line;
      } files[3] = {{f.depth_path, settings.depth_list_name, f.depth_line},
                    {f.rgb_path, settings.rgb_list_name, f.rgb_line},
                    {f.labels_path, settings.labels_list_name, f.labels_line}};
      for (const auto& file : files) {
        if (!file.path.empty() && !file_exists(file.path)) {
          if (error) *error = listed_at(file.list, file.line) + "listed file '" + file.path + "' not found";
          return false;
        }
      }
    }
  }
  if (settings.size_from_first_frame) {
    bool found = false;
    for (const FrameFiles& f : frames_) {
      if (!file_exists(f.depth_path)) continue;
      const cv::Mat depth = read_image(f.depth_path, cv::IMREAD_UNCHANGED);
      if (depth.empty()) continue;
      if (depth.cols > messages::kMaxFrameWidth || depth.rows > messages::kMaxFrameHeight) {
        if (error) {
          *error = listed_at(settings.depth_list_name, f.depth_line) + "'" + f.depth_path + "' is " +
                   std::to_string(depth.cols) + "x" + std::to_string(depth.rows) + ", larger than the " +
                   std::to_string(messages::kMaxFrameWidth) + "x" + std::to_string(messages::kMaxFrameHeight) +
                   " frame buffers";
        }
        return false;
      }
      intrinsics_.width = depth.cols;
      intrinsics_.height = depth.rows;
      found = true;
      break;
    }
    if (!found && !frames_.empty()) {
      if (error) {
        *error = std::string(name) + ": no listed depth image could be read to find the frame size (first: '" +
                 frames_.front().depth_path + "')";
      }
      return false;
    }
  }
  if (!intrinsics_.valid()) {
    if (error) {
      *error = std::string(name) + ": invalid intrinsics (" + std::to_string(intrinsics_.width) + "x" +
               std::to_string(intrinsics_.height) + ", fx " + std::to_string(intrinsics_.fx) + ", fy " +
               std::to_string(intrinsics_.fy) + ")";
    }
    return false;
  }
  if (!settings.size_from_first_frame) {
    // Decoding one image is the only way to know its size; the first readable one stands for the folder.
    for (const FrameFiles& f : frames_) {
      if (!file_exists(f.depth_path)) continue;
      const cv::Mat depth = read_image(f.depth_path, cv::IMREAD_UNCHANGED);
      if (depth.empty()) continue;
      if (depth.cols != intrinsics_.width || depth.rows != intrinsics_.height) {
        if (error) {
          *error = listed_at(settings.depth_list_name, f.depth_line) + "depth image '" + f.depth_path + "' is " +
                   std::to_string(depth.cols) + "x" + std::to_string(depth.rows) + " but the intrinsics" +
                   (intrinsics_source_.empty() ? std::string() : " (" + intrinsics_source_ + ")") +
                   " are for " + std::to_string(intrinsics_.width) + "x" + std::to_string(intrinsics_.height) +
                   " images";
        }
        return false;
      }
      break;
    }
  }
  return true;
}

void ImageListReplay::rewind() {
  next_ = 0;
  have_last_ = false;
  gap_pending_ = false;
}

ImageListReplay::Outcome ImageListReplay::fail(Outcome outcome, const char* what, const std::string& path) {
  std::snprintf(last_error_, sizeof(last_error_), "%s: %s", path.c_str(), what);
  return outcome;
}

ImageListReplay::Outcome ImageListReplay::wrong_size(const char* what, const std::string& path, int width,
                                                     int height) {
  std::snprintf(last_error_, sizeof(last_error_), "%s: %s is %dx%d, the intrinsics are for %dx%d", path.c_str(), what,
                width, height, intrinsics_.width, intrinsics_.height);
  return Outcome::kCorrupt;
}

ImageListReplay::Outcome ImageListReplay::decode(const FrameFiles& files, messages::RgbdFrame& frame) {
  const int w = intrinsics_.width;
  const int h = intrinsics_.height;
  // Depth.
  if (!file_exists(files.depth_path)) return fail(Outcome::kMissing, "depth image missing", files.depth_path);
  {
    const cv::Mat depth = read_image(files.depth_path, cv::IMREAD_UNCHANGED);
    if (depth.empty()) return fail(Outcome::kCorrupt, "depth image cannot be decoded", files.depth_path);
    if (depth.type() != CV_16UC1) {
      return fail(Outcome::kCorrupt, "depth image is not 16-bit single channel", files.depth_path);
    }
    if (depth.cols != w || depth.rows != h) return wrong_size("depth image", files.depth_path, depth.cols, depth.rows);
    const float scale = depth_scale_m_;
    for (int v = 0; v < h; ++v) {
      const std::uint16_t* row = depth.ptr<std::uint16_t>(v);
      float* out = frame.depth_m.data() + static_cast<std::size_t>(v) * w;
      for (int u = 0; u < w; ++u) out[u] = static_cast<float>(row[u]) * scale;
    }
  }
  // Colour (BGR in OpenCV, RGB in the frame).
  if (files.rgb_path.empty()) {
    std::memset(frame.rgb.data(), 0, static_cast<std::size_t>(w) * h * 3);
  } else {
    if (!file_exists(files.rgb_path)) return fail(Outcome::kMissing, "colour image missing", files.rgb_path);
    const cv::Mat bgr = read_image(files.rgb_path, cv::IMREAD_COLOR);
    if (bgr.empty()) return fail(Outcome::kCorrupt, "colour image cannot be decoded", files.rgb_path);
    if (bgr.cols != w || bgr.rows != h) return wrong_size("colour image", files.rgb_path, bgr.cols, bgr.rows);
    if (bgr.type() != CV_8UC3) return fail(Outcome::kCorrupt, "colour image is not 8-bit", files.rgb_path);
    for (int v = 0; v < h; ++v) {
      const std::uint8_t* row = bgr.ptr<std::uint8_t>(v);
      std::uint8_t* out = frame.rgb.data() + static_cast<std::size_t>(v) * w * 3;
      for (int u = 0; u < w; ++u) {
        out[3 * u + 0] = row[3 * u + 2];
        out[3 * u + 1] = row[3 * u + 1];
        out[3 * u + 2] = row[3 * u + 0];
      }
    }
  }
  // Labels (16-bit; 8-bit images are widened).
  frame.has_labels = false;
  if (!files.labels_path.empty()) {
    if (!file_exists(files.labels_path)) return fail(Outcome::kMissing, "label image missing", files.labels_path);
    const cv::Mat labels = read_image(files.labels_path, cv::IMREAD_UNCHANGED);
    if (labels.empty()) return fail(Outcome::kCorrupt, "label image cannot be decoded", files.labels_path);
    if (labels.cols != w || labels.rows != h || (labels.type() != CV_16UC1 && labels.type() != CV_8UC1)) {
      return fail(Outcome::kCorrupt, "label image has the wrong size or is not single channel", files.labels_path);
    }
    for (int v = 0; v < h; ++v) {
      std::uint16_t* out = frame.labels.data() + static_cast<std::size_t>(v) * w;
      if (labels.type() == CV_16UC1) {
        std::memcpy(out, labels.ptr<std::uint16_t>(v), static_cast<std::size_t>(w) * sizeof(std::uint16_t));
      } else {
        const std::uint8_t* row = labels.ptr<std::uint8_t>(v);
        for (int u = 0; u < w; ++u) out[u] = row[u];
      }
    }
    frame.has_labels = true;
  }
  return Outcome::kOk;
}

drivers::ReadStatus ImageListReplay::read(messages::RgbdFrame& frame, std::int64_t /*timeout_ns*/) {
  while (next_ < frames_.size()) {
    const std::size_t index = next_++;
    const FrameFiles& files = frames_[index];
    const Outcome outcome = decode(files, frame);
    if (outcome != Outcome::kOk) {
      if (outcome == Outcome::kMissing) {
        ++counters_.missing_files;
      } else {
        ++counters_.bad_frames;
      }
      gap_pending_ = true;
      continue;
    }
    frame.sequence = index;
    frame.sample_time_ns = files.sample_time_ns;
    frame.publish_time_ns = files.sample_time_ns + publish_latency_ns_;
    frame.intrinsics = intrinsics_;
    frame.depth_scale_m = depth_scale_m_;
    frame.flags = 0;
    if (gap_pending_ || (have_last_ && index != last_sequence_ + 1)) frame.flags |= messages::kFrameSequenceGap;
    if (have_last_ && files.sample_time_ns <= last_sample_time_ns_) {
      frame.flags |= messages::kFrameTimestampBackwards;
      ++counters_.timestamps_backwards;
    }
    gap_pending_ = false;
    have_last_ = true;
    last_sample_time_ns_ = files.sample_time_ns;
    last_sequence_ = index;
    ++counters_.delivered;
    return drivers::ReadStatus::kOk;
  }
  return drivers::ReadStatus::kEndOfStream;
}

}  // namespace qsg::replay

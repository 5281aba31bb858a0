// Writes frames and poses in the TUM RGB-D folder layout.
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

#include "drivers/replay/camera_calibration.h"
#include "drivers/replay/text_parse.h"
#include "drivers/replay/tum_replay.h"

namespace qsg::replay {
namespace {

std::FILE* open_list(const std::string& path, const char* what, std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    if (error) *error = path + ": cannot create";
    return nullptr;
  }
  std::fprintf(f, "# %s\n# written by quadsg TumWriter\n# timestamp filename\n", what);
  return f;
}

void close_file(std::FILE*& f, bool* ok) {
  if (f == nullptr) return;
  if (std::fclose(f) != 0) *ok = false;
  f = nullptr;
}

}  // namespace

void TumWriter::Config::print(std::FILE* out) const {
  std::fprintf(out, "TumWriter: depth_scale_m=%g write_labels=%d png_compression=%d\n",
               static_cast<double>(depth_scale_m), write_labels, png_compression);
}

TumWriter::~TumWriter() { close(nullptr); }

bool TumWriter::fail(const std::string& message, std::string* error) {
  if (error) *error = message;
  return false;
}

bool TumWriter::open(const std::string& folder, const Config& config, std::string* error) {
  close(nullptr);
  config_ = config;
  folder_ = folder;
  stats_ = Stats{};
  have_last_time_ = false;
  have_camera_ = false;
  if (!(config.depth_scale_m > 0.0f)) return fail(folder + ": depth scale must be positive", error);
  for (const char* sub : {"", "rgb", "depth", "labels"}) {
    std::error_code ec;
    const std::string dir = sub[0] == '\0' ? folder : join_path(folder, sub);
    std::filesystem::create_directories(dir, ec);
    if (ec) return fail(dir + ": cannot create folder (" + ec.message() + ")", error);
  }
  rgb_list_ = open_list(join_path(folder, "rgb.txt"), "color images", error);
  if (rgb_list_ != nullptr) depth_list_ = open_list(join_path(folder, "depth.txt"), "depth maps", error);
  if (depth_list_ != nullptr) {
    groundtruth_ = std::fopen(join_path(folder, "groundtruth.txt").c_str(), "w");
    if (groundtruth_ == nullptr && error) *error = join_path(folder, "groundtruth.txt") + ": cannot create";
  }
  if (groundtruth_ == nullptr) {
    close(nullptr);
    return false;
  }
  std::fprintf(groundtruth_, "# ground truth trajectory\n# written by quadsg TumWriter\n# timestamp tx ty tz qx qy qz qw\n");
  // A stale labels.txt from an earlier run would pair old label images with new frames.
  std::error_code ec;
  std::filesystem::remove(join_path(folder, "labels.txt"), ec);
  std::filesystem::remove(join_path(folder, kCalibrationFileName), ec);  // written with the first frame
  return true;
}

bool TumWriter::write_frame(const messages::RgbdFrame& frame, std::string* error) {
  if (rgb_list_ == nullptr) return fail("TumWriter: write_frame before open", error);
  const int w = frame.width();
  const int h = frame.height();
  if (!frame.intrinsics.valid()) return fail("TumWriter: frame has invalid intrinsics", error);
  // The first frame's camera goes into calibration.json, so the folder replays with the camera that took it; a TUM
  // folder has one camera, so a frame from another is refused.
  const messages::CameraIntrinsics& k = frame.intrinsics;
  if (!have_camera_) {
    CameraCalibration calibration;
    calibration.intrinsics = k;
    calibration.depth_scale_m = config_.depth_scale_m;
    if (!write_camera_calibration(join_path(folder_, kCalibrationFileName), calibration, error)) return false;
    camera_ = k;
    have_camera_ = true;
  } else if (k.width != camera_.width || k.height != camera_.height || k.fx != camera_.fx || k.fy != camera_.fy ||
             k.cx != camera_.cx || k.cy != camera_.cy) {
    char text[256];
    std::snprintf(text, sizeof(text),
                  "TumWriter: frame %llu's camera (%dx%d fx=%g fy=%g cx=%g cy=%g) is not the first frame's (%dx%d "
                  "fx=%g fy=%g cx=%g cy=%g) that %s describes",
                  static_cast<unsigned long long>(frame.sequence), k.width, k.height, k.fx, k.fy, k.cx, k.cy,
                  camera_.width, camera_.height, camera_.fx, camera_.fy, camera_.cx, camera_.cy, kCalibrationFileName);
    return fail(text, error);
  }
  std::string stamp = format_ns_as_seconds(frame.sample_time_ns);
  // File names are stamps; a repeated or backwards stamp gets the sequence number so no file is overwritten.
  if (have_last_time_ && frame.sample_time_ns <= last_time_ns_) stamp += "_" + std::to_string(frame.sequence);
  have_last_time_ = true;
  last_time_ns_ = frame.sample_time_ns;
  const std::string time_text = format_ns_as_seconds(frame.sample_time_ns);

  cv::Mat depth(h, w, CV_16UC1);
  const double scale = static_cast<double>(config_.depth_scale_m);
  for (int v = 0; v < h; ++v) {
    std::uint16_t* row = depth.ptr<std::uint16_t>(v);
    const float* in = frame.depth_m.data() + static_cast<std::size_t>(v) * w;
    for (int u = 0; u < w; ++u) {
      const double d = static_cast<double>(in[u]);
      if (!(d > 0.0) || !std::isfinite(d)) {
        row[u] = 0;
        continue;
      }
      const long long raw = std::llround(d / scale);
      if (raw > 65535) {
        row[u] = 0;
        ++stats_.depth_out_of_range_px;
      } else {
        row[u] = static_cast<std::uint16_t>(raw);
      }
    }
  }
  cv::Mat bgr(h, w, CV_8UC3);
  for (int v = 0; v < h; ++v) {
    std::uint8_t* row = bgr.ptr<std::uint8_t>(v);
    const std::uint8_t* in = frame.rgb.data() + static_cast<std::size_t>(v) * w * 3;
    for (int u = 0; u < w; ++u) {
      row[3 * u + 0] = in[3 * u + 2];
      row[3 * u + 1] = in[3 * u + 1];
      row[3 * u + 2] = in[3 * u + 0];
    }
  }
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, config_.png_compression};
  const std::string depth_name = "depth/" + stamp + ".png";
  const std::string rgb_name = "rgb/" + stamp + ".png";
  bool ok = false;
  try {  // imwrite throws cv::Exception on some failures; nothing may escape this API
    ok = cv::imwrite(join_path(folder_, depth_name), depth, params) &&
         cv::imwrite(join_path(folder_, rgb_name), bgr, params);
  } catch (const cv::Exception& e) {
    return fail(join_path(folder_, depth_name) + ": " + e.what(), error);
  }
  if (!ok) return fail(join_path(folder_, depth_name) + ": cannot write image", error);
  std::fprintf(depth_list_, "%s %s\n", time_text.c_str(), depth_name.c_str());
  std::fprintf(rgb_list_, "%s %s\n", time_text.c_str(), rgb_name.c_str());

  if (frame.has_labels && config_.write_labels) {
    if (labels_list_ == nullptr) {
      labels_list_ = open_list(join_path(folder_, "labels.txt"), "semantic labels (16-bit)", error);
      if (labels_list_ == nullptr) return false;
    }
    const cv::Mat labels(h, w, CV_16UC1, const_cast<std::uint16_t*>(frame.labels.data()));
    const std::string labels_name = "labels/" + stamp + ".png";
    try {
      ok = cv::imwrite(join_path(folder_, labels_name), labels, params);
    } catch (const cv::Exception& e) {
      return fail(join_path(folder_, labels_name) + ": " + e.what(), error);
    }
    if (!ok) return fail(join_path(folder_, labels_name) + ": cannot write image", error);
    std::fprintf(labels_list_, "%s %s\n", time_text.c_str(), labels_name.c_str());
  }
  ++stats_.frames;
  return true;
}

bool TumWriter::write_pose(const StampedPose& pose, std::string* error) {
  if (groundtruth_ == nullptr) return fail("TumWriter: write_pose before open", error);
  std::fprintf(groundtruth_, "%s\n", format_tum_pose(pose).c_str());
  ++stats_.poses;
  return true;
}

bool TumWriter::close(std::string* error) {
  bool ok = true;
  close_file(rgb_list_, &ok);
  close_file(depth_list_, &ok);
  close_file(labels_list_, &ok);
  close_file(groundtruth_, &ok);
  if (!ok) return fail(folder_ + ": error while closing the list files", error);
  return true;
}

}  // namespace qsg::replay

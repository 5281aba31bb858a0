// Helpers for the replay tests: scratch folders, small files, synthetic frames with known pixels.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "core/messages/sensor_types.h"

namespace qsg::testing {

// Scratch folders of this process, removed when it exits.
struct ScratchDirs {
  std::vector<std::string> dirs;
  ~ScratchDirs() {
    std::error_code ec;
    for (const std::string& d : dirs) std::filesystem::remove_all(d, ec);
  }
};
inline ScratchDirs& scratch_dirs() {
  static ScratchDirs dirs;
  return dirs;
}

// A fresh, empty scratch folder for one test (per process, so parallel ctest runs do not collide).
inline std::string fresh_dir(const std::string& name) {
  std::string base = ::testing::TempDir();
  if (!base.empty() && base.back() != '/') base += '/';
  const std::string dir = base + "qsg_replay_" + std::to_string(::getpid()) + "_" + name;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir, ec);
  scratch_dirs().dirs.push_back(dir);
  return dir;
}

inline void write_file(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// A frame whose every pixel is a known function of (u, v, sequence). Depth values are multiples of
// 1/5000 m (so TUM quantisation keeps them), with a few no-return pixels (0, NaN) and one beyond the 16-bit range.
inline void fill_synthetic_frame(messages::RgbdFrame& f, int width, int height, std::uint64_t sequence,
                                 std::int64_t time_ns, bool labels) {
  f.intrinsics.width = width;
  f.intrinsics.height = height;
  f.intrinsics.fx = 200.0;
  f.intrinsics.fy = 201.0;
  f.intrinsics.cx = (width - 1) / 2.0;
  f.intrinsics.cy = (height - 1) / 2.0;
  f.sequence = sequence;
  f.sample_time_ns = time_ns;
  f.publish_time_ns = time_ns;
  f.depth_scale_m = 1.0f / 5000.0f;
  f.flags = 0;
  f.has_labels = labels;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int i = v * width + u;
      const int raw = 1 + (u * 7 + v * 131 + static_cast<int>(sequence) * 1009) % 65000;
      f.depth_m[i] = static_cast<float>(raw / 5000.0);
      f.rgb[3 * i + 0] = static_cast<std::uint8_t>(u * 3 + sequence);
      f.rgb[3 * i + 1] = static_cast<std::uint8_t>(v * 5 + 2 * sequence);
      f.rgb[3 * i + 2] = static_cast<std::uint8_t>((u * v) ^ static_cast<int>(sequence));
      f.labels[i] = static_cast<std::uint16_t>((u / 8 + v / 8 * 7 + sequence) % 42 + (u == 0 ? 60000 : 0));
    }
  }
  f.depth_m[0] = 0.0f;
  f.depth_m[1] = std::numeric_limits<float>::quiet_NaN();
  f.depth_m[2] = 20.0f;  // 100000 units: beyond 16 bits, written as no return
  f.depth_m[3] = -1.0f;  // invalid: written as no return
}

// The raw 16-bit value a TUM writer must store for a depth in metres (0 = no return).
inline long expected_raw_depth(float depth_m) {
  if (!(depth_m > 0.0f) || !std::isfinite(depth_m)) return 0;
  const long raw = std::lround(static_cast<double>(depth_m) * 5000.0);
  return raw > 65535 ? 0 : raw;
}

}  // namespace qsg::testing

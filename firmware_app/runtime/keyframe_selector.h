// Keyframe selection by time and motion: a frame becomes a keyframe when enough time has passed and the camera
// moved or turned enough since the last keyframe, or when too much time has passed regardless.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <string>

namespace qsg::runtime {

struct KeyframeConfig {
  double min_interval_s = 0.1;     // never more than 10 keyframes per second
  double max_interval_s = 1.0;     // at least one keyframe per second, even standing still
  double min_translation_m = 0.1;
  double min_rotation_rad = 0.1;
  std::string check() const;
  void print(std::FILE* out) const;
};

struct KeyframeCounters {
  std::uint64_t offered = 0;
  std::uint64_t selected = 0;
  std::uint64_t backwards = 0;  // timestamp not after the last keyframe's: rejected
  std::uint64_t invalid = 0;    // non-finite pose: rejected
};

class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeConfig& config = {}) : config_(config) {}
  // True when (stamp_ns, world_T_body) should be a keyframe; the first valid frame always is.
  bool offer(std::int64_t stamp_ns, const Eigen::Isometry3d& world_T_body);
  const KeyframeCounters& counters() const { return counters_; }
  const KeyframeConfig& config() const { return config_; }

 private:
  KeyframeConfig config_;
  KeyframeCounters counters_;
  bool have_last_ = false;
  std::int64_t last_stamp_ns_ = 0;
  Eigen::Isometry3d last_pose_ = Eigen::Isometry3d::Identity();
};

}  // namespace qsg::runtime

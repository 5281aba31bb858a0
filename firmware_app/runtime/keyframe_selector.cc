// Keyframe selection by time and motion.
#include "firmware_app/runtime/keyframe_selector.h"

#include <cmath>

namespace qsg::runtime {

std::string KeyframeConfig::check() const {
  if (!(min_interval_s >= 0.0 && max_interval_s > min_interval_s)) return "need 0 <= min_interval_s < max_interval_s";
  if (!(max_interval_s <= 3600.0)) return "max_interval_s must be at most 3600 s";
  if (!(min_translation_m >= 0.0 && min_translation_m <= 100.0)) return "min_translation_m must be in [0, 100] m";
  if (!(min_rotation_rad >= 0.0 && min_rotation_rad <= 3.1416)) return "min_rotation_rad must be in [0, pi]";
  return {};
}

void KeyframeConfig::print(std::FILE* out) const {
  std::fprintf(out, "keyframes: interval_s=[%.2f, %.2f] min_translation_m=%.2f min_rotation_rad=%.2f\n", min_interval_s,
               max_interval_s, min_translation_m, min_rotation_rad);
}

bool KeyframeSelector::offer(std::int64_t stamp_ns, const Eigen::Isometry3d& world_T_body) {
  ++counters_.offered;
  if (!world_T_body.matrix().allFinite()) {
    ++counters_.invalid;
    return false;
  }
  if (have_last_) {
    if (stamp_ns <= last_stamp_ns_) {
      ++counters_.backwards;
      return false;
    }
    const double dt_s = static_cast<double>(stamp_ns - last_stamp_ns_) * 1e-9;
    if (dt_s < config_.min_interval_s) return false;
    const Eigen::Isometry3d delta = last_pose_.inverse() * world_T_body;
    const double moved_m = delta.translation().norm();
    const double turned_rad = Eigen::AngleAxisd(delta.linear()).angle();
    if (dt_s < config_.max_interval_s && moved_m < config_.min_translation_m && turned_rad < config_.min_rotation_rad)
      return false;
  }
  have_last_ = true;
  last_stamp_ns_ = stamp_ns;
  last_pose_ = world_T_body;
  ++counters_.selected;
  return true;
}

}  // namespace qsg::runtime

// Cross-frame geometric check for replayed datasets: depth of one frame, moved by the poses into another frame,
// must agree with that frame's depth. Validates intrinsics, depth scale and the pose convention together.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/messages/sensor_types.h"

namespace qsg::testing {

struct ReprojectionStats {
  int compared = 0;
  double median_abs_m = 0.0;
};

// Samples every `stride` pixels of `from`, transforms them with world_T_to^-1 * world_T_from, and compares the
// predicted depth with `to`'s depth at the projected pixel (skipping no-return pixels and depth edges).
inline ReprojectionStats reprojection_error(const messages::RgbdFrame& from, const Eigen::Isometry3d& world_T_from,
                                            const messages::RgbdFrame& to, const Eigen::Isometry3d& world_T_to,
                                            int stride) {
  const messages::CameraIntrinsics& k = from.intrinsics;
  const Eigen::Isometry3d to_T_from = world_T_to.inverse() * world_T_from;
  std::vector<double> errors;
  for (int v = 0; v < from.height(); v += stride) {
    for (int u = 0; u < from.width(); u += stride) {
      const float z = from.depth_m[v * from.width() + u];
      if (!(z > 0.0f)) continue;
      const Eigen::Vector3d p_from((u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, z);
      const Eigen::Vector3d p_to = to_T_from * p_from;
      if (p_to.z() <= 0.1) continue;
      const int u_to = static_cast<int>(std::lround(to.intrinsics.fx * p_to.x() / p_to.z() + to.intrinsics.cx));
      const int v_to = static_cast<int>(std::lround(to.intrinsics.fy * p_to.y() / p_to.z() + to.intrinsics.cy));
      if (u_to < 1 || v_to < 1 || u_to >= to.width() - 1 || v_to >= to.height() - 1) continue;
      const float z_to = to.depth_m[v_to * to.width() + u_to];
      if (!(z_to > 0.0f)) continue;
      // Skip depth discontinuities, where a one-pixel error is a large depth error.
      float lo = z_to, hi = z_to;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const float n = to.depth_m[(v_to + dv) * to.width() + (u_to + du)];
          lo = std::min(lo, n);
          hi = std::max(hi, n);
        }
      }
      if (hi - lo > 0.05f * z_to) continue;
      errors.push_back(std::abs(p_to.z() - z_to));
    }
  }
  ReprojectionStats stats;
  stats.compared = static_cast<int>(errors.size());
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    stats.median_abs_m = errors[errors.size() / 2];
  }
  return stats;
}

}  // namespace qsg::testing

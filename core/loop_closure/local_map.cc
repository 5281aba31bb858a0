#include "core/loop_closure/local_map.h"

#include "core/loop_closure/detector_params.h"
#include "core/memory/prefault.h"

#include <algorithm>
#include <cmath>

namespace qsg::loop_closure {

std::string LocalMapConfig::check() const {
  // Each field the app exposes within its declared range (detector_params.cc).
  if (std::string why = params::check(local_map_params_table(), *this); !why.empty()) return why;
  return "";
}

void LocalMapConfig::print(std::FILE* out) const {
  std::fprintf(out, "local-map verification: %s, agents within %.1f m of path, %.2f m voxels, overlap >= %.2f\n",
               enabled ? "on" : "off", path_m, voxel_m, min_overlap);
}

bool LocalMapVerifier::init(const LocalMapConfig& config, const LocalMapCapacities& capacities, std::string* error) {
  if (const std::string why = config.check(); !why.empty()) return *error = "local_map." + why, false;
  if (capacities.keyframes < 1) return *error = "local_map: capacity local_map_keyframes must be at least 1", false;
  if (capacities.points < 64) return *error = "local_map: capacity local_map_points must be at least 64", false;
  config_ = config;
  capacities_ = capacities;
  if (!config.enabled) return true;  // off: no buffers (the detector never calls the pass)
  const std::size_t gather = static_cast<std::size_t>(capacities.keyframes) * kMaxCloudPoints;
  gather_points_.reserve(gather);
  gather_normals_.reserve(gather);
  voxel_keys_.reserve(gather);
  for (LocalCloud* c : {&query_, &match_}) {
    c->points.reserve(capacities.points);
    c->normals.reserve(capacities.points);
  }
  grid_.reserve(capacities.points);
  memory::prefault_capacity(&gather_points_);
  memory::prefault_capacity(&gather_normals_);
  memory::prefault_capacity(&voxel_keys_);
  for (LocalCloud* c : {&query_, &match_}) {
    memory::prefault_capacity(&c->points);
    memory::prefault_capacity(&c->normals);
  }
  memory::prefault_capacity(&grid_);
  return true;
}

std::size_t LocalMapVerifier::bytes() const {
  return (gather_points_.capacity() + gather_normals_.capacity()) * sizeof(Eigen::Vector3d) +
         voxel_keys_.capacity() * sizeof(voxel_keys_[0]) +
         2 * (query_.points.capacity() + query_.normals.capacity()) * sizeof(Eigen::Vector3d) +
         grid_.capacity() * sizeof(grid_[0]);
}

void LocalMapVerifier::begin(const Eigen::Isometry3d& world_T_anchor) {
  anchor_T_world_ = world_T_anchor.inverse();
  gather_points_.clear();
  gather_normals_.clear();
}

bool LocalMapVerifier::add(const DepthCloud& cloud, const Eigen::Isometry3d& world_T_camera) {
  if (gather_points_.size() + cloud.count > gather_points_.capacity()) return false;
  const Eigen::Isometry3d anchor_T_camera = anchor_T_world_ * world_T_camera;
  for (std::uint32_t i = 0; i < cloud.count; ++i) {
    const Eigen::Vector3d p(cloud.points_mm[i][0], cloud.points_mm[i][1], cloud.points_mm[i][2]);
    const Eigen::Vector3d n(cloud.normals[i][0], cloud.normals[i][1], cloud.normals[i][2]);
    gather_points_.push_back(anchor_T_camera * (p * 1e-3));
    gather_normals_.push_back(anchor_T_camera.linear() * n.normalized());
  }
  return true;
}

// One point per voxel (the mean of the voxel's points and normals), evenly strided down to capacities_.points.
void LocalMapVerifier::finish(LocalCloud* out) {
  out->points.clear();
  out->normals.clear();
  voxel_keys_.clear();
  for (std::uint32_t i = 0; i < gather_points_.size(); ++i) {
    std::uint64_t key = 0;
    if (GridIndex::cell_key(gather_points_[i], config_.voxel_m, &key)) voxel_keys_.emplace_back(key, i);
  }
  std::sort(voxel_keys_.begin(), voxel_keys_.end());
  std::size_t voxels = 0;
  for (std::size_t i = 0; i < voxel_keys_.size(); ++i)
    voxels += (i == 0 || voxel_keys_[i].first != voxel_keys_[i - 1].first) ? 1 : 0;
  const std::size_t stride = std::max<std::size_t>(1, (voxels + capacities_.points - 1) / capacities_.points);
  std::size_t voxel = 0;
  for (std::size_t i = 0; i < voxel_keys_.size();) {
    std::size_t j = i;
    Eigen::Vector3d p = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
    for (; j < voxel_keys_.size() && voxel_keys_[j].first == voxel_keys_[i].first; ++j) {
      p += gather_points_[voxel_keys_[j].second];
      n += gather_normals_[voxel_keys_[j].second];
    }
    if (voxel++ % stride == 0 && out->points.size() < out->points.capacity() && n.norm() > 1e-6) {
      out->points.push_back(p / static_cast<double>(j - i));
      out->normals.push_back(n.normalized());
    }
    i = j;
  }
}

IcpResult LocalMapVerifier::register_clouds(const LocalCloud& query, const LocalCloud& match,
                                            const Eigen::Isometry3d& initial, const IcpConfig& icp,
                                            const GravityPrior* gravity) {
  if (query.points.size() < 32 || match.points.size() < 32) return IcpResult{};
  const double cell = std::max(icp.start_inlier_m, icp.neighbour_m);
  grid_.resize(grid_.capacity());  // within the capacity reserved at init: no allocation
  grid_.resize(GridIndex::build(match.points.data(), static_cast<std::uint32_t>(match.points.size()), cell,
                                grid_.data(), grid_.size()));
  IcpConfig bounded = icp;
  bounded.max_correction_rad = std::min(icp.max_correction_rad, config_.max_correction_rad);
  return point_to_plane_icp(query.points.data(), query.normals.data(), static_cast<std::uint32_t>(query.points.size()),
                            match.points.data(), match.normals.data(),
                            GridIndex(grid_.data(), grid_.size(), match.points.data(), cell), initial, bounded,
                            config_.min_overlap, gravity);
}

}  // namespace qsg::loop_closure

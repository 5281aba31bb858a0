// Local-map verification: a named refinement pass of loop-closure verification, for revisits whose keyframes face
// different ways (a hallway walked back, a room left by the door it was entered by), where the two keyframes' clouds
// share too little for ICP. An agent's local cloud is its keyframe cloud merged with those of the agents described
// within path_m of it along the trajectory, put in its camera frame by the odometry between them (locally exact over
// a few metres) and thinned to one point per voxel; the query's local cloud looks back along its path, the match's
// both ways. The two are registered by point-to-plane ICP from the object registration's coarse estimate, with the
// keyframe ICP's trust tests (overlap, every direction constrained, a bounded correction).
// Backend thread only; every buffer is sized at init, nothing allocates afterwards.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "core/loop_closure/depth_cloud.h"

namespace qsg::loop_closure {

struct LocalMapConfig {
  // On by default (loop closure itself is off by default); why, measured with per-distance odometry weighting:
  // bench/results/loop_closure.md, "Session of 2026-12-03 (2)".
  bool enabled = true;
  double path_m = 3.0;       // agents within this much path of the anchor join its local cloud
  double voxel_m = 0.08;     // one point per voxel of this side
  double min_overlap = 0.3;  // share of the query's local points on a match plane after ICP
  // Largest rotation ICP may apply to the object registration's estimate (that estimate is within a degree or two;
  // a larger turn is ICP sliding on geometry that pins the rotation poorly).
  double max_correction_rad = 0.05;

  std::string check() const;
  void print(std::FILE* out) const;
};

// The verifier's buffers (budgets/: loop_closure.local_map_keyframes and local_map_points).
struct LocalMapCapacities {
  std::uint32_t keyframes = 0;  // keyframe clouds one local cloud may gather (the rest of the window is skipped)
  std::uint32_t points = 0;     // per local cloud after thinning (evenly strided beyond)
};

// A local cloud in its anchor's camera frame.
struct LocalCloud {
  std::vector<Eigen::Vector3d> points;   // capacity fixed at init
  std::vector<Eigen::Vector3d> normals;
  std::uint32_t keyframes = 0;
};

// Builds local clouds and registers them; one per detector.
class LocalMapVerifier {
 public:
  // Buffers are reserved only when config.enabled.
  bool init(const LocalMapConfig& config, const LocalMapCapacities& capacities, std::string* error);
  const LocalMapConfig& config() const { return config_; }
  const LocalMapCapacities& capacities() const { return capacities_; }

  // Local cloud of an anchor: begin, add each keyframe cloud with its camera's (odometric) pose, finish.
  void begin(const Eigen::Isometry3d& world_T_anchor);
  bool add(const DepthCloud& cloud, const Eigen::Isometry3d& world_T_camera);  // false: the gather buffer is full
  void finish(LocalCloud* out);

  // ICP of the query's local cloud onto the match's from `initial` (match_T_query, the anchors' frames).
  IcpResult register_clouds(const LocalCloud& query, const LocalCloud& match, const Eigen::Isometry3d& initial,
                            const IcpConfig& icp, const GravityPrior* gravity = nullptr);

  LocalCloud& query_cloud() { return query_; }
  LocalCloud& match_cloud() { return match_; }
  std::size_t bytes() const;

 private:
  LocalMapConfig config_;
  LocalMapCapacities capacities_;
  Eigen::Isometry3d anchor_T_world_ = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> gather_points_, gather_normals_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> voxel_keys_;  // (voxel key, gathered point)
  LocalCloud query_, match_;
  // The match cloud's voxel grid for nearest neighbours: (cell key, point) sorted by key.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> grid_;
};

}  // namespace qsg::loop_closure

// A keyframe's depth as a small cloud with normals, and the refinement of a loop closure by point-to-plane ICP
// between two agents' clouds: a named refinement pass over the coarse estimate of object registration (object
// centroids from partial views are off by about a decimetre; depth is off by millimetres). It keeps the refined
// estimate only where the clouds overlap (share of the query's points within inlier_m of a match point) and the
// correction stays small; otherwise the coarse estimate stands.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>

#include "core/loop_closure/appearance.h"
#include "core/loop_closure/gravity.h"

namespace qsg::loop_closure {

inline constexpr std::size_t kMaxCloudPoints = 512;

struct DepthCloud {
  std::uint32_t count = 0;
  std::array<std::array<std::int16_t, 3>, kMaxCloudPoints> points_mm;  // camera frame
  std::array<std::array<std::int8_t, 3>, kMaxCloudPoints> normals;     // unit normal * 127
};

struct IcpConfig {
  bool enabled = true;
  double max_depth_m = 4.0;
  std::uint32_t iterations = 15;
  double start_inlier_m = 0.3;  // correspondence gate of the first iteration, shrinking to inlier_m
  double inlier_m = 0.05;       // final gate, and the point-to-plane distance of an overlapping point
  double neighbour_m = 0.2;     // overlap: a query point with a match point this near (clouds are sparse) ...
  double min_overlap = 0.3;     // ... within inlier_m of its plane; at least this share of the query's points
  // The geometry must pin every direction: the smallest eigenvalue of the normal equations' rotation and
  // translation blocks over the largest at least this (a wall and a floor leave a translation free: ICP slides).
  double min_constraint_ratio = 0.05;
  // A pair counts only when the query point's normal, as the estimate turns it, is within this angle of the match
  // point's: a point of one surface paired with a point of another (a wall's foot with the floor, a chair's seat
  // with its back, what one view sees and the other does not) pulls the estimate off by centimetres while the
  // residual stays small. Pi: no check (the plain point-to-plane ICP).
  double max_normal_angle_rad = 0.5;
  double max_correction_m = 0.5;  // beyond these from the coarse estimate the refinement is not trusted
  double max_correction_rad = 0.15;
  // Odometry with an IMU observes roll and pitch, so two agents' relative tilt is the odometry's: ICP estimates
  // yaw and translation only (4 DOF) and leaves the tilt as the odometry has it (given a GravityPrior).
  bool gravity_aligned = true;

  std::string check() const;
  void print(std::FILE* out) const;
};

// Samples up to kMaxCloudPoints points on a regular grid of the depth image with their normals (from the
// neighbouring pixels). False when fewer than 32 points have depth.
bool make_depth_cloud(const GreyDepthView& view, double max_depth_m, DepthCloud* out);

// Why an ICP result is not trusted (the first test it fails, in this order), for the detector's counters.
enum class IcpRefusal : std::uint8_t {
  kNone,        // trusted
  kNoOverlap,   // too few points or pairs to estimate, or under min_overlap of the query's points on a match plane
  kDegenerate,  // a direction the geometry leaves free (min_constraint_ratio)
  kCorrection,  // the correction from the initial estimate beyond max_correction_m / _rad
};

struct IcpResult {
  bool ok = false;
  IcpRefusal refusal = IcpRefusal::kNoOverlap;
  Eigen::Isometry3d match_T_query = Eigen::Isometry3d::Identity();
  double overlap = 0.0;
  double rmse_m = 0.0;
  double constraint_ratio = 0.0;  // min over the rotation and translation blocks (see IcpConfig)
  std::uint32_t iterations = 0;
};

// Refines `initial` (match_T_query, camera frames) by point-to-plane ICP of the query's cloud onto the match's;
// 4 DOF about `gravity` when given and config.gravity_aligned (the estimate's tilt is first set to the odometry's,
// then only rotations about the vertical and translations are estimated), else 6 DOF.
IcpResult refine_icp(const DepthCloud& query, const DepthCloud& match, const Eigen::Isometry3d& initial,
                     const IcpConfig& config, const GravityPrior* gravity = nullptr);

// The nearest match point to p within sqrt(gate2), for the ICP below.
class NearestIndex {
 public:
  virtual ~NearestIndex() = default;
  virtual bool nearest(const Eigen::Vector3d& p, double gate2, std::uint32_t* best) const = 0;
};

// Every match point tried: the reference the grid below must agree with.
class BruteForceIndex final : public NearestIndex {
 public:
  BruteForceIndex(const Eigen::Vector3d* points, std::uint32_t count) : points_(points), count_(count) {}
  bool nearest(const Eigen::Vector3d& p, double gate2, std::uint32_t* best) const override;

 private:
  const Eigen::Vector3d* points_;
  std::uint32_t count_;
};

// The match points by cubic cell of side `cell`: (cell key, point) pairs sorted by key, so that the 27 cells around
// a query point hold every match point within one cell side. Exact for any gate up to the cell's side (ICP's gates
// are start_inlier_m and neighbour_m at most); a keyframe's 512 points are looked up among a few dozen, not all.
class GridIndex final : public NearestIndex {
 public:
  using Cell = std::pair<std::uint64_t, std::uint32_t>;
  // A point's cell key (three 21-bit cell coordinates); false beyond +-2^20 cells of the origin.
  static bool cell_key(const Eigen::Vector3d& p, double cell, std::uint64_t* key);
  // Fills cells[0, n) from points (at most `capacity` of them) and sorts them; n.
  static std::size_t build(const Eigen::Vector3d* points, std::uint32_t count, double cell, Cell* cells,
                           std::size_t capacity);
  GridIndex(const Cell* cells, std::size_t num_cells, const Eigen::Vector3d* points, double cell)
      : cells_(cells), num_cells_(num_cells), points_(points), cell_(cell) {}
  bool nearest(const Eigen::Vector3d& p, double gate2, std::uint32_t* best) const override;

 private:
  const Cell* cells_;
  std::size_t num_cells_;
  const Eigen::Vector3d* points_;
  double cell_;
};

// The ICP itself, over any clouds: query points qp with unit normals qn (query frame), match points mp with unit
// normals mn (match frame) found through `index`; a pair counts when their normals agree (max_normal_angle_rad).
// The result is trusted (ok) with at least min_overlap of the query's points on a match plane, every direction it
// estimates constrained and the correction within the config's bounds. With `gravity` (and
// config.gravity_aligned) it estimates yaw about the vertical and translation (GravityPrior).
IcpResult point_to_plane_icp(const Eigen::Vector3d* qp, const Eigen::Vector3d* qn, std::uint32_t query_count,
                             const Eigen::Vector3d* mp, const Eigen::Vector3d* mn, const NearestIndex& index,
                             const Eigen::Isometry3d& initial, const IcpConfig& config, double min_overlap,
                             const GravityPrior* gravity = nullptr);

}  // namespace qsg::loop_closure

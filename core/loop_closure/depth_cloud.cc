#include "core/loop_closure/depth_cloud.h"

#include "core/loop_closure/detector_params.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace qsg::loop_closure {

std::string IcpConfig::check() const {
  if (std::string why = params::check(icp_params_table(), *this); !why.empty()) return why;
  if (!(max_depth_m > 0.0 && max_depth_m <= 100.0)) return "max_depth_m must be in (0, 100] m";
  if (iterations < 1 || iterations > 200) return "iterations must be in [1, 200]";
  if (!(inlier_m > 0.0 && start_inlier_m >= inlier_m && start_inlier_m <= 5.0))
    return "0 < inlier_m <= start_inlier_m <= 5 m";
  if (!(min_overlap > 0.0 && min_overlap <= 1.0)) return "min_overlap must be in (0, 1]";
  if (!(neighbour_m >= inlier_m && neighbour_m <= 5.0)) return "neighbour_m must be in [inlier_m, 5] m";
  if (!(min_constraint_ratio >= 0.0 && min_constraint_ratio <= 1.0)) return "min_constraint_ratio must be in [0, 1]";
  if (!(max_correction_m > 0.0 && max_correction_rad > 0.0))
    return "max_correction_m and max_correction_rad must be positive";
  if (!(max_normal_angle_rad > 0.0 && max_normal_angle_rad <= M_PI)) return "max_normal_angle_rad must be in (0, pi]";
  return "";
}

void IcpConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "icp refinement: %s, %u iterations, gate %.2f -> %.2f m, normals within %.2f rad, overlap >= %.2f, "
               "correction <= %.2f m and %.3f rad, %s\n",
               enabled ? "on" : "off", iterations, start_inlier_m, inlier_m, max_normal_angle_rad, min_overlap,
               max_correction_m, max_correction_rad,
               gravity_aligned ? "yaw + translation (gravity aligned)" : "full SE(3)");
}

bool make_depth_cloud(const GreyDepthView& v, double max_depth_m, DepthCloud* out) {
  out->count = 0;
  if (v.depth_m == nullptr || v.width < 8 || v.height < 8 || v.fx <= 0.0 || v.fy <= 0.0) return false;
  // A grid of about kMaxCloudPoints cells over the image.
  const double cell = std::sqrt(static_cast<double>(v.width) * v.height / kMaxCloudPoints);
  const int step = std::max(2, static_cast<int>(std::ceil(cell)));
  const auto point = [&](int x, int y, Eigen::Vector3d* p) {
    const float d = v.depth_m[y * v.width + x];
    if (!(d > 0.05f && d <= max_depth_m)) return false;
    *p = Eigen::Vector3d((x - v.cx) / v.fx * d, (y - v.cy) / v.fy * d, d);
    return true;
  };
  for (int y = step / 2; y + 1 < v.height && out->count < kMaxCloudPoints; y += step)
    for (int x = step / 2; x + 1 < v.width && out->count < kMaxCloudPoints; x += step) {
      Eigen::Vector3d p, px, py;
      if (!point(x, y, &p) || !point(x + 1, y, &px) || !point(x, y + 1, &py)) continue;
      Eigen::Vector3d n = (px - p).cross(py - p);
      if (n.norm() < 1e-9 || (px - p).norm() > 0.05 || (py - p).norm() > 0.05) continue;  // an edge: no normal
      n.normalize();
      if (n.dot(p) > 0.0) n = -n;  // towards the camera
      const std::size_t i = out->count++;
      for (int k = 0; k < 3; ++k) {
        out->points_mm[i][k] = static_cast<std::int16_t>(std::lround(p[k] * 1000.0));
        out->normals[i][k] = static_cast<std::int8_t>(std::lround(n[k] * 127.0));
      }
    }
  return out->count >= 32;
}

namespace {

Eigen::Vector3d point_of(const DepthCloud& c, std::size_t i) {
  return Eigen::Vector3d(c.points_mm[i][0], c.points_mm[i][1], c.points_mm[i][2]) * 1e-3;
}
Eigen::Vector3d normal_of(const DepthCloud& c, std::size_t i) {
  return Eigen::Vector3d(c.normals[i][0], c.normals[i][1], c.normals[i][2]).normalized();
}

}  // namespace

namespace {

// The estimate with the odometry's tilt: the smallest rotation that takes the query's vertical, as the estimate
// maps it, onto the match's, applied to the estimate's rotation.
Eigen::Isometry3d with_gravity_tilt(const Eigen::Isometry3d& estimate, const GravityPrior& g) {
  Eigen::Isometry3d out = estimate;
  out.linear() = (Eigen::Quaterniond::FromTwoVectors(estimate.linear() * g.query_up, g.match_up) *
                  Eigen::Quaterniond(estimate.linear()))
                     .normalized()
                     .toRotationMatrix();
  return out;
}

double eigen_ratio(const Eigen::Matrix3d& m) {
  const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m).eigenvalues();
  return e(2) > 0.0 ? std::max(0.0, e(0)) / e(2) : 0.0;
}

}  // namespace

IcpResult point_to_plane_icp(const Eigen::Vector3d* qp, const Eigen::Vector3d* qn, std::uint32_t query_count,
                             const Eigen::Vector3d* mp, const Eigen::Vector3d* mn, const NearestIndex& index,
                             const Eigen::Isometry3d& initial, const IcpConfig& config, double min_overlap,
                             const GravityPrior* gravity) {
  IcpResult r;
  const bool four_dof = gravity != nullptr && config.gravity_aligned;
  const double min_normal_cos = std::cos(config.max_normal_angle_rad);
  const bool check_normals = qn != nullptr && config.max_normal_angle_rad < M_PI;
  const auto agree = [&](const Eigen::Isometry3d& T, std::uint32_t i, std::uint32_t j) {
    return !check_normals || (T.linear() * qn[i]).dot(mn[j]) >= min_normal_cos;
  };
  const Eigen::Vector3d up = four_dof ? gravity->match_up.normalized() : Eigen::Vector3d::UnitZ();
  Eigen::Isometry3d T = four_dof ? with_gravity_tilt(initial, *gravity) : initial;
  for (std::uint32_t it = 0; it < config.iterations; ++it) {
    const double gate = std::max(config.inlier_m, config.start_inlier_m * std::pow(0.7, it));
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    std::uint32_t pairs = 0;
    for (std::uint32_t i = 0; i < query_count; ++i) {
      const Eigen::Vector3d p = T * qp[i];
      std::uint32_t j = 0;
      if (!index.nearest(p, gate * gate, &j) || !agree(T, i, j)) continue;
      // Point to plane: r = n . (p - m), p = exp(xi) T q ~ p + w x p + v; 4 DOF: w = theta up, so the first
      // column is (p x n) . up and the next two are unused.
      const double res = mn[j].dot(p - mp[j]);
      Eigen::Matrix<double, 6, 1> J;
      if (four_dof)
        J << p.cross(mn[j]).dot(up), 0.0, 0.0, mn[j];
      else
        J << p.cross(mn[j]), mn[j];
      H += J * J.transpose();
      g += J * res;
      ++pairs;
    }
    r.iterations = it + 1;
    if (pairs < 24) return r;
    H.diagonal().array() += 1e-6;
    const Eigen::Matrix<double, 6, 1> xi = -H.ldlt().solve(g);
    const Eigen::Vector3d w = four_dof ? Eigen::Vector3d(xi(0) * up) : Eigen::Vector3d(xi.head<3>());
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    const double angle = w.norm();
    if (angle > 1e-12) step.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
    step.translation() = xi.tail<3>();
    T = step * T;
    if (xi.norm() < 1e-5) break;
  }
  std::uint32_t inliers = 0;
  double sum = 0.0;
  Eigen::Matrix3d Hr = Eigen::Matrix3d::Zero(), Ht = Eigen::Matrix3d::Zero();
  for (std::uint32_t i = 0; i < query_count; ++i) {
    const Eigen::Vector3d p = T * qp[i];
    std::uint32_t j = 0;
    if (!index.nearest(p, config.neighbour_m * config.neighbour_m, &j) || !agree(T, i, j)) continue;
    const double d = mn[j].dot(p - mp[j]);
    if (std::abs(d) > config.inlier_m) continue;
    ++inliers;
    sum += d * d;
    const Eigen::Vector3d c = p.cross(mn[j]);
    Hr += c * c.transpose();
    Ht += mn[j] * mn[j].transpose();
  }
  // Every direction pinned, the tilt's too at 4 DOF: a view that leaves a tilt free is one whose yaw and
  // translation are weak as well (a wall and a floor).
  r.constraint_ratio = std::min(eigen_ratio(Hr), eigen_ratio(Ht));
  r.overlap = query_count > 0 ? static_cast<double>(inliers) / query_count : 0.0;
  r.rmse_m = inliers > 0 ? std::sqrt(sum / inliers) : 0.0;
  r.match_T_query = T;
  const Eigen::Isometry3d correction = initial.inverse() * T;
  const bool small_correction = correction.translation().norm() <= config.max_correction_m &&
                                Eigen::AngleAxisd(correction.linear()).angle() <= config.max_correction_rad;
  r.refusal = !(r.overlap >= min_overlap)                            ? IcpRefusal::kNoOverlap
              : !(r.constraint_ratio >= config.min_constraint_ratio) ? IcpRefusal::kDegenerate
              : !small_correction                                    ? IcpRefusal::kCorrection
                                                                     : IcpRefusal::kNone;
  r.ok = r.refusal == IcpRefusal::kNone;
  return r;
}

bool BruteForceIndex::nearest(const Eigen::Vector3d& p, double gate2, std::uint32_t* best) const {
  double best_d2 = gate2;
  bool found = false;
  for (std::uint32_t j = 0; j < count_; ++j) {
    const double d2 = (points_[j] - p).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      *best = j;
      found = true;
    }
  }
  return found;
}

namespace {
constexpr std::int64_t kCellOffset = std::int64_t{1} << 20;  // cells per axis either side of the origin
constexpr std::uint64_t kCellMask = (std::uint64_t{1} << 21) - 1;
}  // namespace

bool GridIndex::cell_key(const Eigen::Vector3d& p, double cell, std::uint64_t* key) {
  std::uint64_t k = 0;
  for (int a = 0; a < 3; ++a) {
    const double c = std::floor(p[a] / cell);
    if (!(c > -static_cast<double>(kCellOffset) && c < static_cast<double>(kCellOffset - 1))) return false;
    k = (k << 21) | static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + kCellOffset);
  }
  *key = k;
  return true;
}

std::size_t GridIndex::build(const Eigen::Vector3d* points, std::uint32_t count, double cell, Cell* cells,
                             std::size_t capacity) {
  std::size_t n = 0;
  for (std::uint32_t j = 0; j < count && n < capacity; ++j) {
    std::uint64_t key = 0;
    if (cell_key(points[j], cell, &key)) cells[n++] = Cell{key, j};
  }
  std::sort(cells, cells + n);
  return n;
}

bool GridIndex::nearest(const Eigen::Vector3d& p, double gate2, std::uint32_t* best) const {
  std::uint64_t centre = 0;
  if (!cell_key(p, cell_, &centre)) return false;
  double best_d2 = gate2;
  bool found = false;
  const std::int64_t cx = static_cast<std::int64_t>((centre >> 42) & kCellMask);
  const std::int64_t cy = static_cast<std::int64_t>((centre >> 21) & kCellMask);
  const std::int64_t cz = static_cast<std::int64_t>(centre & kCellMask);
  const Cell* end = cells_ + num_cells_;
  // z is the key's lowest field, so a column's three cells (z - 1 to z + 1) are one run of keys: one search each.
  for (std::int64_t dx = -1; dx <= 1; ++dx)
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      const std::uint64_t column =
          (static_cast<std::uint64_t>(cx + dx) << 42) | (static_cast<std::uint64_t>(cy + dy) << 21);
      const std::uint64_t first = column | static_cast<std::uint64_t>(cz - 1),
                          last = column | static_cast<std::uint64_t>(cz + 1);
      for (const Cell* it = std::lower_bound(cells_, end, Cell{first, 0}); it != end && it->first <= last; ++it) {
        const double d2 = (points_[it->second] - p).squaredNorm();
        if (d2 < best_d2) {
          best_d2 = d2;
          *best = it->second;
          found = true;
        }
      }
    }
  return found;
}

IcpResult refine_icp(const DepthCloud& query, const DepthCloud& match, const Eigen::Isometry3d& initial,
                     const IcpConfig& config, const GravityPrior* gravity) {
  if (query.count < 32 || match.count < 32) return IcpResult{};
  Eigen::Vector3d mp[kMaxCloudPoints], mn[kMaxCloudPoints], qp[kMaxCloudPoints], qn[kMaxCloudPoints];
  for (std::uint32_t j = 0; j < match.count; ++j) {
    mp[j] = point_of(match, j);
    mn[j] = normal_of(match, j);
  }
  for (std::uint32_t i = 0; i < query.count; ++i) {
    qp[i] = point_of(query, i);
    qn[i] = normal_of(query, i);
  }
  // The grid's cell is the largest gate ICP asks for, so its lookups are exact.
  const double cell = std::max(config.start_inlier_m, config.neighbour_m);
  GridIndex::Cell cells[kMaxCloudPoints];
  const std::size_t num_cells = GridIndex::build(mp, match.count, cell, cells, kMaxCloudPoints);
  return point_to_plane_icp(qp, qn, query.count, mp, mn, GridIndex(cells, num_cells, mp, cell), initial, config,
                            config.min_overlap, gravity);
}

}  // namespace qsg::loop_closure

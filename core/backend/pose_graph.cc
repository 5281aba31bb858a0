// Ceres implementation of the SE(3) pose-graph optimizer: input checks, residual, gauge fixing and solve.
#include "core/backend/pose_graph.h"

#include <Eigen/Cholesky>
#include <ceres/autodiff_cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <utility>

#include "core/backend/ceres_compat.h"
#include "core/backend/chordal_init.h"

namespace qsg::backend {
namespace {

constexpr int kResidualDim = 6;
constexpr int kTranslationDim = 3;
constexpr int kQuaternionDim = 4;
constexpr int kStateDim = kTranslationDim + kQuaternionDim;
// A quaternion this short carries no direction to normalize towards.
constexpr double kMinQuaternionNorm = 1e-6;

using Vector6d = Eigen::Matrix<double, kResidualDim, 1>;
using Matrix6d = Eigen::Matrix<double, kResidualDim, kResidualDim>;

// Tangent-space error of one edge, whitened: [R_from^T (t_to - t_from) - t_meas; 2 vec(q_meas^-1 q_from^-1 q_to)]
// (with a full information matrix the translation part is rotated into the measurement's `to` frame, as g2o's),
// times sqrt(weight) when a weight is given (GNC's loop-closure weights, read at every evaluation).
class RelativePoseResidual {
 public:
  RelativePoseResidual(const Pose3& measured_from_T_to, const Matrix6d& sqrt_information, bool translation_in_to_frame,
                       const double* weight)
      : measured_t_m_(measured_from_T_to.t_m),
        measured_q_(measured_from_T_to.q),
        sqrt_information_(sqrt_information),
        translation_in_to_frame_(translation_in_to_frame),
        weight_(weight) {}

  template <typename T>
  bool operator()(const T* t_from_ptr, const T* q_from_ptr, const T* t_to_ptr, const T* q_to_ptr,
                  T* residual_ptr) const {
    using Vector3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vector3T> t_from(t_from_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_from(q_from_ptr);
    const Eigen::Map<const Vector3T> t_to(t_to_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_to(q_to_ptr);

    const Eigen::Quaternion<T> q_from_inv = q_from.conjugate();
    const Vector3T t_from_to = q_from_inv * (t_to - t_from);
    // |2 vec(q_err)| = 2 |sin(angle / 2)| whatever the sign of q_err, so q and -q need no special case.
    const Eigen::Quaternion<T> q_err = measured_q_.template cast<T>().conjugate() * (q_from_inv * q_to);

    Eigen::Matrix<T, kResidualDim, 1> raw;
    raw.template head<3>() = t_from_to - measured_t_m_.template cast<T>();
    if (translation_in_to_frame_) raw.template head<3>() = measured_q_.template cast<T>().conjugate() * raw.template head<3>();
    raw.template tail<3>() = T(2.0) * q_err.vec();
    Eigen::Map<Eigen::Matrix<T, kResidualDim, 1>> residual(residual_ptr);
    residual = sqrt_information_.template cast<T>() * raw;
    if (weight_ != nullptr) residual *= T(std::sqrt(*weight_));
    return true;
  }

 private:
  Eigen::Vector3d measured_t_m_;
  Eigen::Quaterniond measured_q_;
  Matrix6d sqrt_information_;
  bool translation_in_to_frame_ = false;
  const double* weight_ = nullptr;
};

// RotationPrior's residual: 2 vec(q_prior^-1 q) / sigma.
class RotationPriorResidual {
 public:
  RotationPriorResidual(const Eigen::Quaterniond& q, double sigma_rad) : q_inv_(q.conjugate()), inv_sigma_(1.0 / sigma_rad) {}
  template <typename T>
  bool operator()(const T* q_ptr, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_ptr);
    const Eigen::Quaternion<T> q_err = q_inv_.template cast<T>() * q;
    Eigen::Map<Eigen::Matrix<T, 3, 1>> residual(residual_ptr);
    residual = T(2.0 * inv_sigma_) * q_err.vec();
    return true;
  }

 private:
  Eigen::Quaterniond q_inv_;
  double inv_sigma_ = 1.0;
};

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  char buffer[256];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof(buffer), fmt, args);
  va_end(args);
  return buffer;
}

PoseGraphResult invalid(std::string message) {
  PoseGraphResult result;
  result.status = PoseGraphStatus::kInvalidInput;
  result.message = "invalid input: " + std::move(message);
  return result;
}

bool all_finite(const Pose3& pose) { return pose.t_m.allFinite() && pose.q.coeffs().allFinite(); }

// Empty string when the config is usable.
std::string check_config(const PoseGraphConfig& config) {
  if (config.max_iterations < 1) return format("max_iterations is %d, must be >= 1", config.max_iterations);
  if (!(config.function_tolerance > 0.0 && config.function_tolerance < 1.0))
    return format("function_tolerance is %g, must be in (0, 1)", config.function_tolerance);
  if (config.prefilter_pairwise_consistency || (config.gnc_cluster_trials > 0 && config.gnc_cluster_screen)) {
    if (std::string error = check(config.pairwise_consistency); !error.empty()) return error;
  }
  if (config.num_threads < 1) return format("num_threads is %d, must be >= 1", config.num_threads);
  if (config.loop_closure_loss != RobustLoss::kNone &&
      !(std::isfinite(config.loop_closure_loss_scale_sigma) && config.loop_closure_loss_scale_sigma > 0.0)) {
    return format("loop_closure_loss_scale_sigma is %g, must be finite and > 0", config.loop_closure_loss_scale_sigma);
  }
  if (config.loop_closure_loss == RobustLoss::kGncTls) {
    if (config.gnc_max_outer_iterations < 1)
      return format("gnc_max_outer_iterations is %d, must be >= 1", config.gnc_max_outer_iterations);
    if (!(config.gnc_mu_factor > 1.0 && config.gnc_mu_factor <= 10.0))
      return format("gnc_mu_factor is %g, must be in (1, 10]", config.gnc_mu_factor);
    if (config.gnc_inner_iterations < (config.gnc_chordal_solves ? 0 : 1))
      return format("gnc_inner_iterations is %d, must be >= 1 (>= 0 with gnc_chordal_solves)",
                    config.gnc_inner_iterations);
    if (config.gnc_tls_refine_rounds < 0)
      return format("gnc_tls_refine_rounds is %d, must be >= 0", config.gnc_tls_refine_rounds);
    if (config.gnc_cluster_trials < 0)
      return format("gnc_cluster_trials is %d, must be >= 0", config.gnc_cluster_trials);
    if (config.gnc_cluster_trials > 0 && config.gnc_cluster_min_closures < 1)
      return "gnc_cluster_min_closures is 0, must be >= 1";
    if (config.gnc_cluster_trial_iterations < 0)
      return format("gnc_cluster_trial_iterations is %d, must be >= 0 (0: max_iterations)",
                    config.gnc_cluster_trial_iterations);
  }
  return {};
}

std::string check_edge(std::size_t index, const RelativePoseEdge& edge, std::size_t num_poses) {
  const char* kind = edge.is_loop_closure ? "loop closure" : "odometry";
  if (edge.from >= num_poses || edge.to >= num_poses) {
    return format("edge %zu (%s %u -> %u): pose index out of range, graph has %zu poses", index, kind, edge.from,
                  edge.to, num_poses);
  }
  if (edge.from == edge.to) return format("edge %zu (%s): connects pose %u to itself", index, kind, edge.from);
  if (!all_finite(edge.measured_from_T_to)) {
    return format("edge %zu (%s %u -> %u): measurement is not finite", index, kind, edge.from, edge.to);
  }
  if (edge.measured_from_T_to.q.norm() < kMinQuaternionNorm) {
    return format("edge %zu (%s %u -> %u): measured quaternion has zero norm", index, kind, edge.from, edge.to);
  }
  if (edge.has_information) {
    const Eigen::LLT<Matrix6d> llt(edge.information);
    if (!edge.information.allFinite() || !edge.information.isApprox(edge.information.transpose(), 1e-9) ||
        llt.info() != Eigen::Success) {
      return format("edge %zu (%s %u -> %u): information matrix must be finite, symmetric and positive definite",
                    index, kind, edge.from, edge.to);
    }
    return {};
  }
  const bool sigmas_ok = edge.sigma_t_m.allFinite() && edge.sigma_rot_rad.allFinite() &&
                         edge.sigma_t_m.minCoeff() > 0.0 && edge.sigma_rot_rad.minCoeff() > 0.0;
  if (!sigmas_ok) {
    return format("edge %zu (%s %u -> %u): sigmas must be finite and > 0 (sigma_t_m %g %g %g, sigma_rot_rad %g %g %g)",
                  index, kind, edge.from, edge.to, edge.sigma_t_m.x(), edge.sigma_t_m.y(), edge.sigma_t_m.z(),
                  edge.sigma_rot_rad.x(), edge.sigma_rot_rad.y(), edge.sigma_rot_rad.z());
  }
  return {};
}

// Null for kNone: Ceres then applies plain least squares.
ceres::LossFunction* make_loss(RobustLoss loss, double scale_sigma) {
  switch (loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale_sigma);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale_sigma);
    case RobustLoss::kNone:
    case RobustLoss::kGncTls:  // weights in the residuals, not a loss
      break;
  }
  return nullptr;
}

// W with |W r|^2 = r^T Information r: diag(1 / sigma), or the transposed Cholesky factor of the information.
Matrix6d sqrt_information(const RelativePoseEdge& edge) {
  if (edge.has_information) {
    const Matrix6d upper = Eigen::LLT<Matrix6d>(edge.information).matrixU();
    return upper;
  }
  Vector6d inv_sigma;
  inv_sigma << edge.sigma_t_m.cwiseInverse(), edge.sigma_rot_rad.cwiseInverse();
  return inv_sigma.asDiagonal();
}

// GNC-TLS weight of a whitened residual norm r at surrogate parameter mu, threshold c (Yang et al. 2020, eq. 14).
double gnc_tls_weight(double r, double c, double mu) {
  const double r2 = r * r, c2 = c * c;
  if (r2 >= (mu + 1.0) / mu * c2) return 0.0;
  if (r2 <= mu / (mu + 1.0) * c2) return 1.0;
  return c / r * std::sqrt(mu * (mu + 1.0)) - mu;
}

// Union-find root with path halving; components decide which pose holds each one's gauge.
std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

// Loop closures grouped into runs (PoseGraphConfig::gnc_cluster_trials): closures a and b are linked when both their
// lower and their higher pose indices are within `gap` of each other's; clusters are the linked components. Sorted
// by lower index, each closure is compared only with those whose lower index is within the gap.
std::vector<std::vector<std::size_t>> closure_clusters(const std::vector<RelativePoseEdge>& edges,
                                                       const std::vector<bool>& excluded, std::uint32_t gap) {
  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < edges.size(); ++k)
    if (edges[k].is_loop_closure && !excluded[k]) order.push_back(k);
  const auto lo = [&edges](std::size_t k) { return std::min(edges[k].from, edges[k].to); };
  const auto hi = [&edges](std::size_t k) { return std::max(edges[k].from, edges[k].to); };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return lo(a) < lo(b); });
  std::vector<std::uint32_t> parent(order.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (std::size_t a = 0; a < order.size(); ++a) {
    for (std::size_t b = a + 1; b < order.size() && lo(order[b]) - lo(order[a]) <= gap; ++b) {
      const std::uint32_t ha = hi(order[a]), hb = hi(order[b]);
      if ((ha > hb ? ha - hb : hb - ha) > gap) continue;
      const std::uint32_t ra = find_root(parent, static_cast<std::uint32_t>(a));
      const std::uint32_t rb = find_root(parent, static_cast<std::uint32_t>(b));
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  std::vector<std::vector<std::size_t>> clusters;
  std::vector<std::size_t> index_of_root(order.size(), SIZE_MAX);
  for (std::size_t a = 0; a < order.size(); ++a) {
    const std::uint32_t r = find_root(parent, static_cast<std::uint32_t>(a));
    if (index_of_root[r] == SIZE_MAX) {
      index_of_root[r] = clusters.size();
      clusters.emplace_back();
    }
    clusters[index_of_root[r]].push_back(order[a]);
  }
  return clusters;
}

// One solve of optimize_pose_graph's input: the state (a copy of the poses), the Ceres problem over it, and GNC's
// loop-closure weights, which the residuals read at every evaluation. Closures in `excluded` (rejected by the
// pairwise-consistency prefilter) get weight 0 and no residual block.
class GraphSolve {
 public:
  GraphSolve(const PoseGraphConfig& config, const std::vector<Pose3>& poses, const std::vector<RelativePoseEdge>& edges,
             const std::vector<bool>& excluded, const std::vector<RotationPrior>& rotation_priors)
      : config_(config),
        edges_(edges),
        rotation_priors_(rotation_priors),
        excluded_(excluded),
        gnc_(config.loop_closure_loss == RobustLoss::kGncTls),
        loop_closure_loss_(make_loss(config.loop_closure_loss, config.loop_closure_loss_scale_sigma),
                           ceres::TAKE_OWNERSHIP),
        problem_(problem_options()),
        state_(poses.size() * kStateDim),
        weights_(edges.size(), 1.0) {
    for (std::size_t i = 0; i < poses.size(); ++i) {
      Eigen::Map<Eigen::Vector3d>(t_block(i)) = poses[i].t_m;
      Eigen::Map<Eigen::Quaterniond>(q_block(i)) = poses[i].q.normalized();
    }
    initial_state_ = state_;
    for (std::size_t k = 0; k < edges.size(); ++k)
      if (excluded_[k]) weights_[k] = 0.0;
    add_residuals();
  }

  // Ceres' options, or an error when this Ceres has no usable linear solver.
  bool configure(std::string* error) {
    options_.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options_.max_num_iterations = config_.max_iterations;
    options_.function_tolerance = config_.function_tolerance;
    options_.num_threads = config_.num_threads;
    options_.logging_type = ceres::SILENT;
    options_.minimizer_progress_to_stdout = false;
    if (options_.IsValid(error)) return true;
    // A Ceres built without any sparse library; dense QR is fine at the sizes the backend sees.
    options_.linear_solver_type = ceres::DENSE_QR;
    return options_.IsValid(error);
  }

  // Runs the configured strategy; the summary of the last Ceres solve.
  ceres::Solver::Summary run(PoseGraphResult* result) {
    // Reported under the configured loss, whatever the warm start uses, so initial and final cost compare.
    problem_.Evaluate(ceres::Problem::EvaluateOptions(), &result->initial_cost, nullptr, nullptr, nullptr);
    if (gnc_ && has_loop_closure_) return solve_gnc(result);
    ceres::Solver::Summary summary;
    if (warm_start()) {
      // Cauchy alone discards a correct closure that starts many sigmas away on a drifted trajectory; convex Huber
      // pulls every closure in first, then Cauchy lets go of the ones that still disagree.
      loop_closure_loss_.Reset(make_loss(RobustLoss::kHuber, config_.loop_closure_loss_scale_sigma),
                               ceres::TAKE_OWNERSHIP);
      solve(options_, &summary, result);
      loop_closure_loss_.Reset(make_loss(RobustLoss::kCauchy, config_.loop_closure_loss_scale_sigma),
                               ceres::TAKE_OWNERSHIP);
      if (!summary.IsSolutionUsable()) return summary;
    }
    solve(options_, &summary, result);
    return summary;
  }

  bool warm_start() const {
    return config_.huber_warm_start && config_.loop_closure_loss == RobustLoss::kCauchy && has_loop_closure_;
  }
  bool state_finite() const {
    return std::all_of(state_.begin(), state_.end(), [](double v) { return std::isfinite(v); });
  }

  // Writes the solution back and fills the per-edge residuals, weights and the downweighted count.
  void finish(std::vector<Pose3>& poses, PoseGraphResult* result) {
    for (std::size_t i = 0; i < poses.size(); ++i) {
      poses[i].t_m = Eigen::Map<const Eigen::Vector3d>(t_block(i));
      poses[i].q = Eigen::Map<const Eigen::Quaterniond>(q_block(i)).normalized();
    }
    result->edge_residual_sigma.resize(edges_.size());
    for (std::size_t k = 0; k < edges_.size(); ++k) {
      const double norm = unweighted_residual(k);
      result->edge_residual_sigma[k] = norm;
      const bool off =
          gnc_ || excluded_[k] ? weights_[k] == 0.0 : norm > config_.loop_closure_loss_scale_sigma;
      if (edges_[k].is_loop_closure && config_.loop_closure_loss != RobustLoss::kNone && off)
        ++result->num_loop_closures_downweighted;
    }
    if (gnc_ || config_.prefilter_pairwise_consistency) result->edge_weight = weights_;
  }

 private:
  static ceres::Problem::Options problem_options() {
    ceres::Problem::Options o;
    o.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    o.enable_fast_removal = true;  // GNC takes the closures it switched off out of each solve
    return o;
  }
  double* t_block(std::size_t i) { return &state_[i * kStateDim]; }
  double* q_block(std::size_t i) { return &state_[i * kStateDim + kTranslationDim]; }

  // One residual per edge (for reporting), a block in the problem per edge not excluded; holds each connected
  // component's lowest-index pose when fix_first_pose (the gauge).
  void add_residuals() {
    const std::size_t num_poses = state_.size() / kStateDim;
    std::vector<std::uint32_t> parent(num_poses);
    std::iota(parent.begin(), parent.end(), 0u);
    std::vector<bool> in_problem(num_poses, false);
    anchored_.assign(num_poses, false);
    auto add_pose = [&](std::uint32_t i) {
      if (in_problem[i]) return;
      in_problem[i] = true;
      problem_.AddParameterBlock(t_block(i), kTranslationDim);
      problem_.AddParameterBlock(q_block(i), kQuaternionDim);
      ceres_compat::set_quaternion_manifold(problem_, q_block(i));
    };
    residuals_.reserve(edges_.size());
    blocks_.assign(edges_.size(), nullptr);
    for (std::size_t k = 0; k < edges_.size(); ++k) {
      const RelativePoseEdge& edge = edges_[k];
      Pose3 measured = edge.measured_from_T_to;
      measured.q.normalize();
      residuals_.emplace_back(measured, sqrt_information(edge), edge.has_information,
                              gnc_ && edge.is_loop_closure ? &weights_[k] : nullptr);
      if (excluded_[k]) continue;
      has_loop_closure_ = has_loop_closure_ || edge.is_loop_closure;
      add_pose(edge.from);
      add_pose(edge.to);
      blocks_[k] = add_edge_block(k);
      const std::uint32_t a = find_root(parent, edge.from);
      const std::uint32_t b = find_root(parent, edge.to);
      // The smaller index becomes the root, so each root is its component's lowest-index pose.
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
    for (std::uint32_t i = 0; i < num_poses; ++i) anchored_[i] = !in_problem[i] || i < config_.hold_first_poses;
    for (std::uint32_t i = 0; i < num_poses && i < config_.hold_first_poses; ++i) {
      if (!in_problem[i]) continue;
      problem_.SetParameterBlockConstant(t_block(i));
      problem_.SetParameterBlockConstant(q_block(i));
    }
    for (const RotationPrior& prior : rotation_priors_) {
      if (prior.pose < config_.hold_first_poses || !in_problem[prior.pose]) continue;
      using Cost = ceres::AutoDiffCostFunction<RotationPriorResidual, 3, kQuaternionDim>;
      problem_.AddResidualBlock(new Cost(new RotationPriorResidual(prior.q.normalized(), prior.sigma_rad)), nullptr,
                                q_block(prior.pose));
    }
    if (!config_.fix_first_pose) return;
    for (std::uint32_t i = 0; i < num_poses; ++i) {
      if (i < config_.hold_first_poses) continue;
      if (in_problem[i] && find_root(parent, i) == i) {
        anchored_[i] = true;
        problem_.SetParameterBlockConstant(t_block(i));
        problem_.SetParameterBlockConstant(q_block(i));
      }
    }
  }

  // Edge k's residual block (its functor is residuals_[k]); a loop closure's under the configured loss.
  ceres::ResidualBlockId add_edge_block(std::size_t k) {
    const RelativePoseEdge& e = edges_[k];
    using Cost = ceres::AutoDiffCostFunction<RelativePoseResidual, kResidualDim, kTranslationDim, kQuaternionDim,
                                             kTranslationDim, kQuaternionDim>;
    ceres::LossFunction* const rho =
        e.is_loop_closure && config_.loop_closure_loss != RobustLoss::kNone ? &loop_closure_loss_ : nullptr;
    return problem_.AddResidualBlock(new Cost(new RelativePoseResidual(residuals_[k])), rho, t_block(e.from),
                                     q_block(e.from), t_block(e.to), q_block(e.to));
  }

  void solve(const ceres::Solver::Options& options, ceres::Solver::Summary* summary, PoseGraphResult* result) {
    if (gnc_) match_blocks_to_weights();
    ceres::Solve(options, &problem_, summary);
    result->iterations += summary->num_successful_steps + summary->num_unsuccessful_steps;
    result->solver_time_s += summary->total_time_in_seconds;  // replaced by the injected clock's, when given
  }

  // GNC: a closure of weight 0 adds nothing to the cost or the gradient, but its block still joins two poses in the
  // normal equations; random wrong closures join far-apart poses and fill the sparse factorization in. It leaves the
  // problem while its weight is 0 and comes back when the weight does (its functor is kept in residuals_).
  void match_blocks_to_weights() {
    for (std::size_t k = 0; k < edges_.size(); ++k) {
      const RelativePoseEdge& e = edges_[k];
      if (!e.is_loop_closure || excluded_[k]) continue;
      if (weights_[k] == 0.0 && blocks_[k] != nullptr) {
        problem_.RemoveResidualBlock(blocks_[k]);
        blocks_[k] = nullptr;
      } else if (weights_[k] != 0.0 && blocks_[k] == nullptr) {
        blocks_[k] = add_edge_block(k);
      }
    }
  }

  // Whitened residual norm of edge k at the current state, without its GNC weight.
  double unweighted_residual(std::size_t k) {
    const RelativePoseEdge& e = edges_[k];
    const double w = weights_[k];
    weights_[k] = 1.0;
    Vector6d v;
    residuals_[k](t_block(e.from), q_block(e.from), t_block(e.to), q_block(e.to), v.data());
    weights_[k] = w;
    return v.norm();
  }
  void loop_closure_residuals(std::vector<double>* r) {
    r->assign(edges_.size(), 0.0);
    for (std::size_t k = 0; k < edges_.size(); ++k)
      if (edges_[k].is_loop_closure && !excluded_[k]) (*r)[k] = unweighted_residual(k);
  }

  // Graduated non-convexity: least squares with every closure first, then the TLS surrogate from convex (mu small)
  // to the truncated loss, re-weighting the closures after each weighted solve; last, one solve with the weights
  // rounded to 0 or 1.
  ceres::Solver::Summary solve_gnc(PoseGraphResult* result) {
    const double c = config_.loop_closure_loss_scale_sigma;
    const bool chordal = config_.gnc_chordal_solves;
    ceres::Solver::Summary summary;
    // From the chordal estimate the first solve only has to give the residuals GNC starts from: it is one of the
    // weighted solves. Without it, least squares to convergence from the caller's poses.
    if (!weighted_solve(chordal ? config_.gnc_inner_iterations : config_.max_iterations, &summary, result))
      return summary;
    std::vector<double> r;
    loop_closure_residuals(&r);
    const double r_max = *std::max_element(r.begin(), r.end());
    if (r_max <= c && !chordal) return summary;
    double mu = c * c / std::max(2.0 * r_max * r_max - c * c, 1e-12);
    for (int outer = 0; outer < config_.gnc_max_outer_iterations && r_max > c; ++outer) {
      double undecided = 0.0;
      for (std::size_t k = 0; k < edges_.size(); ++k) {
        if (!edges_[k].is_loop_closure || excluded_[k]) continue;
        weights_[k] = gnc_tls_weight(r[k], c, mu);
        undecided += weights_[k] * (1.0 - weights_[k]);
      }
      const bool usable = weighted_solve(config_.gnc_inner_iterations, &summary, result);
      ++result->gnc_outer_iterations;
      if (!usable) return summary;
      loop_closure_residuals(&r);
      if (undecided < 1e-6 && outer > 0) break;  // every weight 0 or 1: the surrogate is the TLS loss here
      mu *= config_.gnc_mu_factor;
    }
    decide_by_residuals(r);
    // The inliers decided, the last solve starts again from the caller's poses: the annealing's path went through
    // states bent by the outliers, from which least squares can settle in another basin.
    state_ = initial_state_;
    chordal_reset(result);
    solve(options_, &summary, result);
    refine_tls(&summary, result);
    if (config_.gnc_cluster_trials > 0 && summary.IsSolutionUsable()) search_clusters(&summary, result);
    return summary;
  }

  // One of GNC's weighted solves: Ceres for at most `iterations`, from the chordal estimate under the current
  // weights with gnc_chordal_solves. With none (gnc_inner_iterations 0), the chordal estimate is the solve; should
  // it fail, a full Ceres solve stands in. False when the solve's result is not usable.
  bool weighted_solve(int iterations, ceres::Solver::Summary* summary, PoseGraphResult* result) {
    if (chordal_reset(result) && iterations == 0) return state_finite();
    ceres::Solver::Options options = options_;
    options.max_num_iterations = iterations > 0 ? iterations : config_.max_iterations;
    solve(options, summary, result);
    return summary->IsSolutionUsable();
  }

  // PoseGraphConfig::gnc_chordal_solves: the free poses to the chordal estimate under the current weights (kept as
  // they are when the linear solve fails). True when they were moved.
  bool chordal_reset(PoseGraphResult* result) {
    if (!config_.gnc_chordal_solves) return false;
    const std::size_t n = state_.size() / kStateDim;
    std::vector<Pose3> p(n);
    for (std::size_t i = 0; i < n; ++i) {
      p[i].t_m = Eigen::Map<const Eigen::Vector3d>(t_block(i));
      p[i].q = Eigen::Map<const Eigen::Quaterniond>(q_block(i));
    }
    ChordalStats stats;
    const bool ok =
        chordal_initialize(edges_, weights_, anchored_, &p, config_.chordal_weighting, config_.chordal_solver, &stats);
    result->chordal += stats;
    if (!ok) return false;
    for (std::size_t i = 0; i < n; ++i) {
      Eigen::Map<Eigen::Vector3d>(t_block(i)) = p[i].t_m;
      Eigen::Map<Eigen::Quaterniond>(q_block(i)) = p[i].q.normalized();
    }
    return true;
  }

  // Each closure's weight rounded by its residual `r` (loop_closure_residuals): 1 within the threshold, else 0.
  // True when a weight changed.
  bool decide_by_residuals(const std::vector<double>& r) {
    bool changed = false;
    for (std::size_t k = 0; k < edges_.size(); ++k) {
      if (!edges_[k].is_loop_closure || excluded_[k]) continue;
      const double w = r[k] <= config_.loop_closure_loss_scale_sigma ? 1.0 : 0.0;
      changed = changed || w != weights_[k];
      weights_[k] = w;
    }
    return changed;
  }

  // The truncated least-squares fixed point from GNC's solution (PoseGraphConfig::gnc_tls_refine_rounds).
  void refine_tls(ceres::Solver::Summary* summary, PoseGraphResult* result) {
    std::vector<double> r;
    for (int round = 0; round < config_.gnc_tls_refine_rounds && summary->IsSolutionUsable(); ++round) {
      loop_closure_residuals(&r);
      if (!decide_by_residuals(r)) return;
      solve(options_, summary, result);
      ++result->gnc_refine_rounds;
    }
  }

  // The truncated least-squares cost at the current state: every edge's half squared whitened residual, a loop
  // closure's capped at the threshold (weights aside), plus the rotation priors'.
  double tls_cost() {
    match_blocks_to_weights();
    double cost = 0.0;  // the problem's: odometry, priors and the closures of weight 1
    problem_.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
    const double c2 = config_.loop_closure_loss_scale_sigma * config_.loop_closure_loss_scale_sigma;
    for (std::size_t k = 0; k < edges_.size(); ++k) {
      if (!edges_[k].is_loop_closure || excluded_[k]) continue;
      const double r = unweighted_residual(k);
      cost += 0.5 * std::min(r * r, c2) - 0.5 * weights_[k] * r * r;
    }
    return cost;
  }

  // PoseGraphConfig::gnc_cluster_trials: the local search over clusters of switched-off closures, from the rounded
  // TLS solution. `summary` stays the last kept solve's.
  void search_clusters(ceres::Solver::Summary* summary, PoseGraphResult* result) {
    const std::vector<std::vector<std::size_t>> clusters =
        closure_clusters(edges_, excluded_, config_.gnc_cluster_gap_poses);
    std::unique_ptr<PairwiseConsistencyScreen> screen;
    if (config_.gnc_cluster_screen)
      screen =
          std::make_unique<PairwiseConsistencyScreen>(config_.pairwise_consistency, state_.size() / kStateDim, edges_);
    const auto switched_off = [this](const std::vector<std::size_t>& cluster) {
      std::vector<std::size_t> off;
      for (const std::size_t k : cluster)
        if (weights_[k] == 0.0) off.push_back(k);
      return off;
    };
    double cost = tls_cost();
    // Sweeps over the clusters (the most closures switched off first) until one keeps nothing: a kept trial moves the
    // graph, and a cluster tried before it may fit now.
    for (bool kept = true; kept && result->gnc_cluster_trials < config_.gnc_cluster_trials;) {
      kept = false;
      std::vector<std::pair<std::size_t, std::size_t>> order;  // (closures switched off, cluster)
      for (std::size_t i = 0; i < clusters.size(); ++i) {
        const std::size_t n = switched_off(clusters[i]).size();
        if (n >= config_.gnc_cluster_min_closures) order.emplace_back(n, i);
      }
      std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
      for (const auto& [size, index] : order) {
        if (result->gnc_cluster_trials >= config_.gnc_cluster_trials) break;
        const std::vector<std::size_t> off = switched_off(clusters[index]);  // an earlier trial may have taken some
        if (off.size() < config_.gnc_cluster_min_closures) continue;
        if (screen && screen->largest_consistent_subset(off) < config_.gnc_cluster_min_closures) {
          ++result->gnc_clusters_screened_out;
          continue;
        }
        ++result->gnc_cluster_trials;
        if (try_cluster(off, 1.0, &cost, summary, result)) {
          kept = true;
          ++result->gnc_clusters_readmitted;
        }
      }
      // Lone closures: the only one kept in their cluster, the largest residual first. A wrong closure the graph
      // bent to fit has nothing beside it; switched off, the bend relaxes.
      std::vector<std::pair<double, std::size_t>> lone;  // (residual, closure)
      for (const std::vector<std::size_t>& cluster : clusters) {
        std::size_t on = 0, last = 0;
        for (const std::size_t k : cluster) {
          if (weights_[k] == 0.0) continue;
          ++on;
          last = k;
        }
        if (on == 1) lone.emplace_back(unweighted_residual(last), last);
      }
      std::sort(lone.begin(), lone.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
      for (std::size_t i = 0; i < lone.size() && i < config_.gnc_cluster_lone_trials; ++i) {
        if (result->gnc_cluster_trials >= config_.gnc_cluster_trials) break;
        if (weights_[lone[i].second] == 0.0) continue;  // an earlier trial dropped it
        ++result->gnc_cluster_trials;
        if (try_cluster({lone[i].second}, 0.0, &cost, summary, result)) {
          kept = true;
          ++result->gnc_lone_dropped;
        }
      }
      if (kept) {
        refine_tls(summary, result);
        cost = tls_cost();
      }
    }
  }

  // One trial: the closures switched on (weight 1) or off (0), solve, every closure re-decided by its residual,
  // solve again. Kept (true, `cost` and `summary` updated) when the TLS cost falls; otherwise the state before it
  // is restored.
  bool try_cluster(const std::vector<std::size_t>& cluster, double weight, double* cost,
                   ceres::Solver::Summary* summary, PoseGraphResult* result) {
    const std::vector<double> state = state_;
    const std::vector<double> weights = weights_;
    for (const std::size_t k : cluster) weights_[k] = weight;
    ceres::Solver::Options options = options_;
    if (config_.gnc_cluster_trial_iterations > 0) options.max_num_iterations = config_.gnc_cluster_trial_iterations;
    ceres::Solver::Summary trial;
    solve(options, &trial, result);
    if (trial.IsSolutionUsable()) {
      std::vector<double> r;
      loop_closure_residuals(&r);
      decide_by_residuals(r);
      if (weight == 0.0)  // a closure switched off stays off: the graph may not have relaxed past it in one solve
        for (const std::size_t k : cluster) weights_[k] = 0.0;
      solve(options, &trial, result);
    }
    const double trial_cost = trial.IsSolutionUsable() && state_finite() ? tls_cost() : *cost;
    if (trial_cost < *cost * (1.0 - 1e-9)) {
      *cost = trial_cost;
      *summary = trial;
      return true;
    }
    state_ = state;
    weights_ = weights;
    return false;
  }

  const PoseGraphConfig& config_;
  const std::vector<RelativePoseEdge>& edges_;
  const std::vector<RotationPrior>& rotation_priors_;
  const std::vector<bool>& excluded_;
  const bool gnc_;
  bool has_loop_closure_ = false;
  // Shared by every loop closure, wrapped so the warm start can swap it between solves; declared before the
  // problem, which only borrows it.
  ceres::LossFunctionWrapper loop_closure_loss_;
  ceres::Problem problem_;
  ceres::Solver::Options options_;
  std::vector<double> state_;
  std::vector<double> initial_state_;
  std::vector<bool> anchored_;  // per pose: held in the solve, or in no edge (the chordal estimate keeps it)
  std::vector<double> weights_;
  std::vector<RelativePoseResidual> residuals_;
  std::vector<ceres::ResidualBlockId> blocks_;  // per edge: its block in the problem, or null (excluded, weight 0)
};
}  // namespace

const char* to_string(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone:
      return "none";
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
    case RobustLoss::kGncTls:
      return "gnc_tls";
  }
  return "?";
}

const char* to_string(PoseGraphStatus status) {
  switch (status) {
    case PoseGraphStatus::kConverged:
      return "converged";
    case PoseGraphStatus::kMaxIterations:
      return "max_iterations";
    case PoseGraphStatus::kInvalidInput:
      return "invalid_input";
    case PoseGraphStatus::kSolverFailed:
      return "solver_failed";
  }
  return "?";
}

std::string PoseGraphConfig::check() const { return check_config(*this); }

void PoseGraphConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "pose_graph: loop_closure_loss=%s loop_closure_loss_scale_sigma=%g huber_warm_start=%s "
               "max_iterations=%d gnc_max_outer_iterations=%d gnc_mu_factor=%g gnc_inner_iterations=%d "
               "gnc_tls_refine_rounds=%d gnc_cluster_trials=%d gnc_cluster_gap_poses=%u gnc_cluster_min_closures=%u "
               "gnc_cluster_lone_trials=%u gnc_cluster_trial_iterations=%d gnc_cluster_screen=%s "
               "gnc_chordal_solves=%s chordal_weighting=%s chordal_solver=%s fix_first_pose=%s num_threads=%d "
               "prefilter_pairwise_consistency=%s\n",
               to_string(loop_closure_loss), loop_closure_loss_scale_sigma, huber_warm_start ? "true" : "false",
               max_iterations, gnc_max_outer_iterations, gnc_mu_factor, gnc_inner_iterations, gnc_tls_refine_rounds,
               gnc_cluster_trials, gnc_cluster_gap_poses, gnc_cluster_min_closures, gnc_cluster_lone_trials,
               gnc_cluster_trial_iterations, gnc_cluster_screen ? "true" : "false",
               gnc_chordal_solves ? "true" : "false",
               chordal_weighting == ChordalWeighting::kAnisotropic ? "anisotropic" : "isotropic",
               chordal_solver == ChordalSolver::kIterative ? "iterative" : "direct", fix_first_pose ? "true" : "false",
               num_threads, prefilter_pairwise_consistency ? "true" : "false");
  if (prefilter_pairwise_consistency || (gnc_cluster_trials > 0 && gnc_cluster_screen)) pairwise_consistency.print(out);
}

void PoseGraphResult::print(std::FILE* out) const {
  std::fprintf(out,
               "pose_graph result: status=%s iterations=%d initial_cost=%g final_cost=%g "
               "loop_closures_downweighted=%u message=\"%s\"\n",
               to_string(status), iterations, initial_cost, final_cost, num_loop_closures_downweighted,
               message.c_str());
}

namespace {
PoseGraphResult optimize(const PoseGraphConfig& config, std::vector<Pose3>& poses,
                         const std::vector<RelativePoseEdge>& edges, const std::vector<RotationPrior>& priors);
}  // namespace

PoseGraphResult optimize_pose_graph(const PoseGraphConfig& config, std::vector<Pose3>& poses,
                                    const std::vector<RelativePoseEdge>& edges) {
  return optimize_pose_graph(config, poses, edges, {});
}

PoseGraphResult optimize_pose_graph(const PoseGraphConfig& config, std::vector<Pose3>& poses,
                                    const std::vector<RelativePoseEdge>& edges,
                                    const std::vector<RotationPrior>& rotation_priors) {
  if (config.clock_s == nullptr) return optimize(config, poses, edges, rotation_priors);
  const double start_s = config.clock_s();
  PoseGraphResult result = optimize(config, poses, edges, rotation_priors);
  result.solver_time_s = config.clock_s() - start_s;
  return result;
}

namespace {
PoseGraphResult optimize(const PoseGraphConfig& config, std::vector<Pose3>& poses,
                         const std::vector<RelativePoseEdge>& edges, const std::vector<RotationPrior>& priors) {
  if (std::string error = check_config(config); !error.empty()) return invalid(std::move(error));
  if (poses.empty()) return invalid("empty graph: no poses");
  // Indices are uint32 in the edges; a larger graph could not be addressed.
  if (poses.size() > UINT32_MAX) return invalid(format("%zu poses exceed the uint32 index range", poses.size()));
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!all_finite(poses[i])) return invalid(format("pose %zu is not finite", i));
    if (poses[i].q.norm() < kMinQuaternionNorm) return invalid(format("pose %zu has a zero-norm quaternion", i));
  }
  for (std::size_t i = 0; i < edges.size(); ++i) {
    if (std::string error = check_edge(i, edges[i], poses.size()); !error.empty()) return invalid(std::move(error));
  }
  for (std::size_t i = 0; i < priors.size(); ++i) {
    const RotationPrior& p = priors[i];
    if (p.pose >= poses.size() || !p.q.coeffs().allFinite() || p.q.norm() < kMinQuaternionNorm ||
        !(std::isfinite(p.sigma_rad) && p.sigma_rad > 0.0))
      return invalid(format("rotation prior %zu (pose %u): pose out of range, quaternion not usable or sigma not > 0",
                            i, p.pose));
  }
  PoseGraphResult result;
  if (edges.empty()) {
    for (Pose3& pose : poses) pose.q.normalize();
    result.status = PoseGraphStatus::kConverged;
    result.message = "no edges: nothing to optimize";
    return result;
  }
  std::vector<bool> excluded(edges.size(), false);
  if (config.prefilter_pairwise_consistency) {
    result.pairwise = select_consistent_loop_closures(config.pairwise_consistency, poses.size(), edges);
    excluded = result.pairwise.rejected;
  }

  // Solve on a copy so a failed solve leaves the caller's poses as they were.
  GraphSolve graph(config, poses, edges, excluded, priors);
  std::string options_error;
  if (!graph.configure(&options_error)) {
    result.status = PoseGraphStatus::kSolverFailed;
    result.message = "solver failed: options rejected: " + options_error;
    return result;
  }
  const ceres::Solver::Summary summary = graph.run(&result);
  result.final_cost = summary.final_cost;
  if (!summary.IsSolutionUsable() || !graph.state_finite()) {
    const bool gnc = config.loop_closure_loss == RobustLoss::kGncTls;
    result.status = PoseGraphStatus::kSolverFailed;
    result.message = std::string("solver failed") +
                     (gnc                  ? " (a GNC weighted solve): "
                      : graph.warm_start() ? " (Huber warm start or Cauchy solve): "
                                           : ": ") +
                     summary.message;
    return result;
  }
  result.status = summary.termination_type == ceres::NO_CONVERGENCE ? PoseGraphStatus::kMaxIterations
                                                                     : PoseGraphStatus::kConverged;
  graph.finish(poses, &result);
  result.message = format("%s after %d iterations, cost %.6g -> %.6g: ", to_string(result.status), result.iterations,
                          result.initial_cost, result.final_cost) +
                   summary.message;
  return result;
}

}  // namespace

}  // namespace qsg::backend

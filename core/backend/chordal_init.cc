// Weighted chordal initialization: sparse linear least-squares solves (rotations, then translations), with
// Gauss-Newton steps on the rotations between them when anisotropic.
#include "core/backend/chordal_init.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace qsg::backend {
namespace {

// kAnisotropic: Gauss-Newton steps on the rotations after the relaxation. On a graph without wrong closures they
// converge to a step under 1e-6 rad in 2-4 (cubicle: 4); with wrong closures still weighted they may not, and the
// cap bounds each estimate's cost at 1 + 5 solves of the rotation system.
constexpr int kRotationRefineIterations = 5;

// kIterative: the relative residual |b - H x| / |b| conjugate gradients stop at. Gauss-Newton steps on the
// rotations too: solved loosely, their 5 steps from a relaxation under GNC's intermediate weights end metres from
// where exact ones do (bench/results/pose_graph.md).
constexpr double kIterativeTolerance = 1e-10;

// kIterative's preconditioner keeps whole the edges between poses at most this far apart in the graph's numbering
// (a pose graph is numbered along its trajectory: odometry and the scan matches between nearby poses). They
// factor with fill-in bounded by the band; the edges beyond it (revisits, wrong closures) are the random ones that
// conjugate gradients handle in few iterations.
constexpr std::uint32_t kPreconditionerBand = 10;

// An edge's rotation and translation precisions: the information's diagonal blocks (its translation-rotation
// coupling is left out: the two solves are separate), or 1 / sigma^2 on the diagonal. In the residual's frames
// (pose3.h): rotation in the `to` frame, translation in the `from` frame or, with an information matrix, the `to`
// frame.
void precisions(const RelativePoseEdge& e, Eigen::Matrix3d* lambda_t, Eigen::Matrix3d* lambda_r) {
  if (e.has_information) {
    *lambda_t = 0.5 * (e.information.topLeftCorner<3, 3>() + e.information.topLeftCorner<3, 3>().transpose());
    *lambda_r = 0.5 * (e.information.bottomRightCorner<3, 3>() + e.information.bottomRightCorner<3, 3>().transpose());
    return;
  }
  *lambda_t = e.sigma_t_m.cwiseInverse().cwiseAbs2().asDiagonal();
  *lambda_r = e.sigma_rot_rad.cwiseInverse().cwiseAbs2().asDiagonal();
}

// The weighted edges kIterative's preconditioner keeps whole: those within kPreconditionerBand, and a maximum
// spanning forest of the free poses (the anchored ones counted as one node) by each edge's strength in one system,
// its weight times the trace of its precision there (Kruskal's order, the strongest first), so that the
// preconditioner reaches every free pose whatever the numbering.
std::vector<bool> preconditioner_edges(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                                       const std::vector<int>& free_index, std::size_t n, bool rotation) {
  std::vector<std::uint32_t> order;
  std::vector<double> strength(edges.size(), 0.0);
  Eigen::Matrix3d lambda_t, lambda_r;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    if (!(weights[k] > 0.0) || edges[k].from >= n || edges[k].to >= n ||
        (free_index[edges[k].from] < 0 && free_index[edges[k].to] < 0))
      continue;
    precisions(edges[k], &lambda_t, &lambda_r);
    strength[k] = weights[k] * (rotation ? lambda_r : lambda_t).trace();
    order.push_back(static_cast<std::uint32_t>(k));
  }
  std::stable_sort(order.begin(), order.end(),
                   [&strength](std::uint32_t a, std::uint32_t b) { return strength[a] > strength[b]; });
  // Union-find over the poses plus one node (n) for all the anchored ones.
  std::vector<std::uint32_t> parent(n + 1);
  for (std::size_t i = 0; i <= n; ++i) parent[i] = static_cast<std::uint32_t>(i);
  const auto root = [&parent](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const auto node = [&](std::uint32_t pose) { return free_index[pose] >= 0 ? pose : static_cast<std::uint32_t>(n); };
  std::vector<bool> kept(edges.size(), false);
  for (const bool band : {true, false}) {
    for (const std::uint32_t k : order) {
      const std::uint32_t span =
          edges[k].from > edges[k].to ? edges[k].from - edges[k].to : edges[k].to - edges[k].from;
      if (kept[k] || (band && span > kPreconditionerBand)) continue;
      const std::uint32_t a = root(node(edges[k].from)), b = root(node(edges[k].to));
      if (!band && a == b) continue;
      parent[a] = b;
      kept[k] = true;
    }
  }
  return kept;
}

// The normal equations H X = B of a sum of 3-block equations over the free poses (3 unknowns each), and, for
// kIterative, the preconditioner M: the equations of the edges preconditioner_edges keeps whole plus the block
// diagonal of the others, a subgraph preconditioner (Dellaert, Carlson, Ila, Ni, Thorpe, IROS 2010). M is SPD (H
// restricted to a subgraph that reaches every free pose, plus positive semidefinite blocks) and factors with
// little fill-in. It carries the odometry chain and its nearby scan matches, whose long thin shape is what makes a
// diagonal preconditioner need tens of thousands of iterations, and each pose's anisotropic 3x3 block, which a
// diagonal one sees only along the axes of the world.
class NormalEquations {
 public:
  // `solver`: kDirect builds H alone, kIterative its preconditioner M too.
  NormalEquations(int num_free, int columns, ChordalSolver solver)
      : preconditioned_(solver == ChordalSolver::kIterative), b_(Eigen::MatrixXd::Zero(3 * num_free, columns)) {}

  // Adds the normal equations of |r + J_i x_i + J_j x_j|^2_lambda (one column) to H x = b; a fixed end
  // (index < 0) contributes nothing.
  void add_weighted(const Eigen::Matrix3d& j_i, const Eigen::Matrix3d& j_j, const Eigen::Matrix3d& lambda,
                    const Eigen::Vector3d& r, int free_i, int free_j, bool whole) {
    if (free_i >= 0) b_.middleRows<3>(3 * free_i) -= j_i.transpose() * lambda * r;
    if (free_j >= 0) b_.middleRows<3>(3 * free_j) -= j_j.transpose() * lambda * r;
    add_blocks(j_i.transpose() * lambda * j_i, j_j.transpose() * lambda * j_j, j_i.transpose() * lambda * j_j, free_i,
               free_j, whole);
  }

  // Adds one 3-block equation A_i x_i + A_j x_j = c (weight k) to the normal equations; an anchored pose's term
  // moves to the right-hand side. x_i, c and B have 3 columns (rotations: one per row of R).
  void add_equation(const Eigen::Matrix3d& a_i, const Eigen::Matrix3d& a_j, const Eigen::Matrix3d& c, double k,
                    int free_i, int free_j, const Eigen::Matrix3d& known_i, const Eigen::Matrix3d& known_j,
                    bool whole) {
    Eigen::Matrix3d rhs = c;
    if (free_i < 0) rhs -= a_i * known_i;
    if (free_j < 0) rhs -= a_j * known_j;
    if (free_i >= 0) b_.middleRows<3>(3 * free_i) += k * a_i.transpose() * rhs;
    if (free_j >= 0) b_.middleRows<3>(3 * free_j) += k * a_j.transpose() * rhs;
    add_blocks(k * a_i.transpose() * a_i, k * a_j.transpose() * a_j, k * a_i.transpose() * a_j, free_i, free_j, whole);
  }

  // Solves H X = B (ChordalSolver). `step`: X is a Gauss-Newton step, for which conjugate gradients stopped at
  // their iteration cap still give a descent direction (a truncated Newton step, which the caller's line search
  // guards): kept instead of a direct solve. False when a factorization fails (a singular system).
  bool solve(bool step, Eigen::MatrixXd* x, ChordalStats* stats) const {
    ++stats->systems;
    const auto n = static_cast<int>(b_.rows());
    Eigen::SparseMatrix<double> h(n, n);
    h.setFromTriplets(h_.begin(), h_.end());
    if (preconditioned_) {
      Eigen::SparseMatrix<double> m(n, n);
      m.setFromTriplets(m_.begin(), m_.end());
      const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> preconditioner(m);
      if (preconditioner.info() == Eigen::Success) {
        const Outcome outcome = conjugate_gradients(h, preconditioner, x, stats);
        if (outcome == Outcome::kConverged || (outcome == Outcome::kCapped && step)) {
          ++(outcome == Outcome::kConverged ? stats->iterative : stats->truncated);
          return true;
        }
      }
      ++stats->direct_fallbacks;
    }
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(h);
    if (ldlt.info() != Eigen::Success) return false;
    *x = ldlt.solve(b_);
    return ldlt.info() == Eigen::Success && x->allFinite();
  }

 private:
  using Triplets = std::vector<Eigen::Triplet<double>>;
  enum class Outcome { kConverged, kCapped, kFailed };

  static void add_block(int r, int c, const Eigen::Matrix3d& m, Triplets* h) {
    for (int u = 0; u < 3; ++u)
      for (int v = 0; v < 3; ++v) h->emplace_back(3 * r + u, 3 * c + v, m(u, v));
  }

  void add_blocks(const Eigen::Matrix3d& ii, const Eigen::Matrix3d& jj, const Eigen::Matrix3d& ij, int free_i,
                  int free_j, bool whole) {
    for (Triplets* t : {&h_, &m_}) {
      if (t == &m_ && !preconditioned_) break;
      if (free_i >= 0) add_block(free_i, free_i, ii, t);
      if (free_j >= 0) add_block(free_j, free_j, jj, t);
      if (free_i >= 0 && free_j >= 0 && (t == &h_ || whole)) {
        add_block(free_i, free_j, ij, t);
        add_block(free_j, free_i, ij.transpose(), t);
      }
    }
  }

  // Preconditioned conjugate gradients from X = 0, column by column, to kIterativeTolerance within 2 * unknowns
  // iterations. kFailed on a curvature p^T H p <= 0 or a non-finite value (H not positive definite).
  Outcome conjugate_gradients(const Eigen::SparseMatrix<double>& h,
                              const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>& m, Eigen::MatrixXd* x,
                              ChordalStats* stats) const {
    const Eigen::Index n = b_.rows();
    const Eigen::Index cap = 2 * n;
    *x = Eigen::MatrixXd::Zero(n, b_.cols());
    Outcome outcome = Outcome::kConverged;
    Eigen::VectorXd r, z, p, hp;
    for (Eigen::Index c = 0; c < b_.cols(); ++c) {
      r = b_.col(c);
      const double stop = kIterativeTolerance * r.norm();
      if (!(r.norm() > stop)) continue;
      z = m.solve(r);
      p = z;
      double rz = r.dot(z);
      Eigen::Index it = 0;
      for (; it < cap && r.norm() > stop; ++it) {
        hp = h * p;
        const double curvature = p.dot(hp);
        if (!(curvature > 0.0) || !std::isfinite(rz)) return Outcome::kFailed;
        const double alpha = rz / curvature;
        x->col(c) += alpha * p;
        r -= alpha * hp;
        z = m.solve(r);
        const double rz_next = r.dot(z);
        p = z + (rz_next / rz) * p;
        rz = rz_next;
      }
      stats->iterations += it;
      if (!x->col(c).allFinite()) return Outcome::kFailed;
      if (r.norm() > stop) outcome = Outcome::kCapped;
    }
    return outcome;
  }

  bool preconditioned_;
  Triplets h_, m_;
  Eigen::MatrixXd b_;
};

Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// An edge's rotation residual theta = log(R_ij^T R_i^T R_j) (the `to` frame, as pose_graph's residual).
Eigen::Vector3d rotation_residual(const RelativePoseEdge& e, const std::vector<Eigen::Matrix3d>& rotation) {
  const Eigen::AngleAxisd err(e.measured_from_T_to.q.normalized().toRotationMatrix().transpose() *
                              rotation[e.from].transpose() * rotation[e.to]);
  return err.angle() * err.axis();
}

// sum_k w_k theta_k^T lambda_r theta_k over the weighted edges with a free end.
double rotation_cost(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                     const std::vector<int>& free_index, const std::vector<Eigen::Matrix3d>& rotation) {
  const std::size_t n = rotation.size();
  double cost = 0.0;
  Eigen::Matrix3d lambda_t, lambda_r;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (!(weights[k] > 0.0) || e.from >= n || e.to >= n || (free_index[e.from] < 0 && free_index[e.to] < 0)) continue;
    precisions(e, &lambda_t, &lambda_r);
    const Eigen::Vector3d theta = rotation_residual(e, rotation);
    cost += weights[k] * theta.dot(lambda_r * theta);
  }
  return cost;
}

// R exp([d]) for every free pose, d its 3 entries of x scaled by `step`.
void retract(const Eigen::MatrixXd& x, double step, const std::vector<int>& free_index,
             const std::vector<Eigen::Matrix3d>& from, std::vector<Eigen::Matrix3d>* to) {
  *to = from;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (free_index[i] < 0) continue;
    const Eigen::Vector3d d = step * x.middleRows<3>(3 * free_index[i]);
    if (d.norm() > 0.0)
      (*to)[i] = nearest_rotation(from[i] * Eigen::AngleAxisd(d.norm(), d.normalized()).toRotationMatrix());
  }
}

// Gauss-Newton on the rotations alone with each edge's full rotation precision: residual theta = log(R_ij^T R_i^T
// R_j), perturbations R <- R exp([delta]), Jacobians -R_j^T R_i and I (small residuals). The chordal relaxation
// solves each column of R on its own, so an edge sure of one axis and vague on the others cannot be weighted as it
// states; these steps from its estimate can. A step is taken only where it lowers the weighted rotation cost
// (halved up to 4 times, else the refinement stops): with wrong closures still weighted, their large residuals
// break the small-residual model, and unguarded steps of several radians followed. Stops after `iterations` or a
// step under 1e-6 rad. False when a solve fails (the rotations as they were before the failing step).
bool refine_rotations(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                      const std::vector<int>& free_index, const std::vector<bool>& whole, int num_free, int iterations,
                      ChordalSolver solver, ChordalStats* stats, std::vector<Eigen::Matrix3d>* rotation) {
  const std::size_t n = rotation->size();
  Eigen::MatrixXd x;
  Eigen::Matrix3d lambda_t, lambda_r;
  std::vector<Eigen::Matrix3d> candidate;
  double cost = rotation_cost(edges, weights, free_index, *rotation);
  for (int it = 0; it < iterations; ++it) {
    NormalEquations system(num_free, 1, solver);
    for (std::size_t k = 0; k < edges.size(); ++k) {
      const RelativePoseEdge& e = edges[k];
      if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
      const int fi = free_index[e.from], fj = free_index[e.to];
      if (fi < 0 && fj < 0) continue;
      precisions(e, &lambda_t, &lambda_r);
      lambda_r *= weights[k];
      const Eigen::Vector3d theta = rotation_residual(e, *rotation);
      const Eigen::Matrix3d j_i = -(*rotation)[e.to].transpose() * (*rotation)[e.from];
      system.add_weighted(j_i, Eigen::Matrix3d::Identity(), lambda_r, theta, fi, fj, whole[k]);
    }
    if (!system.solve(true, &x, stats)) return false;
    double step = 1.0, candidate_cost = cost;
    for (int halving = 0; halving <= 4; ++halving, step *= 0.5) {
      retract(x, step, free_index, *rotation, &candidate);
      candidate_cost = rotation_cost(edges, weights, free_index, candidate);
      if (candidate_cost < cost) break;
    }
    if (!(candidate_cost < cost)) break;
    rotation->swap(candidate);
    cost = candidate_cost;
    double largest = 0.0;
    for (int i = 0; i < num_free; ++i) largest = std::max(largest, step * x.middleRows<3>(3 * i).norm());
    if (largest < 1e-6) break;
  }
  return true;
}

}  // namespace

bool chordal_initialize(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                        const std::vector<bool>& anchored, std::vector<Pose3>* poses, ChordalWeighting weighting,
                        ChordalSolver solver, ChordalStats* stats) {
  ChordalStats local;
  if (stats == nullptr) stats = &local;
  const std::size_t n = poses->size();
  if (anchored.size() != n || weights.size() != edges.size()) return false;
  // Components of the weighted edges: a pose is free when its component holds an anchor (the gauge); one in a
  // component without, or in none, keeps its value.
  std::vector<std::uint32_t> parent(n);
  for (std::size_t i = 0; i < n; ++i) parent[i] = static_cast<std::uint32_t>(i);
  const auto root = [&parent](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t k = 0; k < edges.size(); ++k)
    if (weights[k] > 0.0 && edges[k].from < n && edges[k].to < n) parent[root(edges[k].from)] = root(edges[k].to);
  std::vector<bool> component_anchored(n, false);
  bool any_anchor = false;
  for (std::size_t i = 0; i < n; ++i) {
    any_anchor = any_anchor || anchored[i];
    if (anchored[i]) component_anchored[root(static_cast<std::uint32_t>(i))] = true;
  }
  if (!any_anchor) return false;
  std::vector<int> free_index(n, -1);
  int num_free = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!anchored[i] && component_anchored[root(static_cast<std::uint32_t>(i))]) free_index[i] = num_free++;
  if (num_free == 0) return true;
  std::vector<Eigen::Matrix3d> rotation(n);
  for (std::size_t i = 0; i < n; ++i) rotation[i] = (*poses)[i].q.normalized().toRotationMatrix();

  // Rotations: R_j = R_i R_ij at the edge's mean rotation precision, one row of R at a time: R_j^T = R_ij^T R_i^T,
  // unknowns X_i = R_i^T. Each column of R is solved on its own, so no per-axis weight fits here: kAnisotropic
  // refines the projected estimate with the full precisions instead.
  const std::vector<bool> whole = solver == ChordalSolver::kIterative
                                      ? preconditioner_edges(edges, weights, free_index, n, true)
                                      : std::vector<bool>(edges.size(), false);
  NormalEquations relaxation(num_free, 3, solver);
  Eigen::MatrixXd x;
  Eigen::Matrix3d lambda_t, lambda_r;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
    precisions(e, &lambda_t, &lambda_r);
    const Eigen::Matrix3d r_ij = e.measured_from_T_to.q.normalized().toRotationMatrix();
    relaxation.add_equation(-r_ij.transpose(), Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero(),
                            weights[k] * lambda_r.trace() / 3.0, free_index[e.from], free_index[e.to],
                            rotation[e.from].transpose(), rotation[e.to].transpose(), whole[k]);
  }
  if (!relaxation.solve(false, &x, stats)) return false;
  std::vector<Eigen::Matrix3d> solved = rotation;
  for (std::size_t i = 0; i < n; ++i)
    if (free_index[i] >= 0) solved[i] = nearest_rotation(x.middleRows<3>(3 * free_index[i]).transpose());
  if (weighting == ChordalWeighting::kAnisotropic &&
      !refine_rotations(edges, weights, free_index, whole, num_free, kRotationRefineIterations, solver, stats, &solved))
    return false;

  // Translations with those rotations: (t_j - t_i - R_i t_ij)^T P (t_j - t_i - R_i t_ij), P the edge's translation
  // precision in the world frame (M^T lambda_t M, M the residual frame's rotation R_ij^T R_i^T or R_i^T), or its
  // mean times I when isotropic: 3x3 blocks of a weighted Laplacian.
  const std::vector<bool> translation_whole = solver == ChordalSolver::kIterative
                                                  ? preconditioner_edges(edges, weights, free_index, n, false)
                                                  : std::vector<bool>(edges.size(), false);
  NormalEquations translation(num_free, 1, solver);
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
    precisions(e, &lambda_t, &lambda_r);
    Eigen::Matrix3d p = (lambda_t.trace() / 3.0) * Eigen::Matrix3d::Identity();
    if (weighting == ChordalWeighting::kAnisotropic) {
      Eigen::Matrix3d m = solved[e.from].transpose();
      if (e.has_information) m = e.measured_from_T_to.q.normalized().toRotationMatrix().transpose() * m;
      p = m.transpose() * lambda_t * m;
    }
    p *= weights[k];
    // Residual t_j - t_i - d: a known end moves to the right-hand side.
    Eigen::Vector3d rhs = solved[e.from] * e.measured_from_T_to.t_m;
    const int fi = free_index[e.from], fj = free_index[e.to];
    if (fi < 0) rhs += (*poses)[e.from].t_m;
    if (fj < 0) rhs -= (*poses)[e.to].t_m;
    translation.add_weighted(-Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Identity(), p, -rhs, fi, fj,
                             translation_whole[k]);
  }
  if (!translation.solve(false, &x, stats)) return false;
  for (std::size_t i = 0; i < n; ++i) {
    if (free_index[i] < 0) continue;
    (*poses)[i].t_m = x.middleRows<3>(3 * free_index[i]);
    (*poses)[i].q = Eigen::Quaterniond(solved[i]);
  }
  return true;
}

}  // namespace qsg::backend

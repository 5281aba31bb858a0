// Weighted chordal initialization: sparse linear least-squares solves (rotations, then translations), with
// Gauss-Newton steps on the rotations between them when anisotropic.
#include "core/backend/chordal_init.h"

#include <Eigen/Geometry>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace qsg::backend {
namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// kAnisotropic: Gauss-Newton steps on the rotations after the relaxation. On a graph without wrong closures they
// converge to a step under 1e-6 rad in 2-4 (cubicle: 4); with wrong closures still weighted they may not, and the
// cap bounds each estimate's cost at 1 + 5 factorizations of the rotation system.
constexpr int kRotationRefineIterations = 5;

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

// H's 3x3 block (r, c) += m.
void add_block(int r, int c, const Eigen::Matrix3d& m, Triplets* h) {
  for (int u = 0; u < 3; ++u)
    for (int v = 0; v < 3; ++v) h->emplace_back(3 * r + u, 3 * c + v, m(u, v));
}

// Adds the normal equations of |r + J_i x_i + J_j x_j|^2_lambda (3-vectors x) to H x = b over the free poses; a
// fixed end (index < 0) contributes nothing.
void add_weighted(const Eigen::Matrix3d& j_i, const Eigen::Matrix3d& j_j, const Eigen::Matrix3d& lambda,
                  const Eigen::Vector3d& r, int free_i, int free_j, Triplets* h, Eigen::MatrixXd* b) {
  if (free_i >= 0) {
    add_block(free_i, free_i, j_i.transpose() * lambda * j_i, h);
    b->middleRows<3>(3 * free_i) -= j_i.transpose() * lambda * r;
  }
  if (free_j >= 0) {
    add_block(free_j, free_j, j_j.transpose() * lambda * j_j, h);
    b->middleRows<3>(3 * free_j) -= j_j.transpose() * lambda * r;
  }
  if (free_i >= 0 && free_j >= 0) {
    add_block(free_i, free_j, j_i.transpose() * lambda * j_j, h);
    add_block(free_j, free_i, j_j.transpose() * lambda * j_i, h);
  }
}

// Adds one 3-block equation A_i x_i + A_j x_j = c (weight k) to the normal equations H x = B over the free poses;
// an anchored pose's term moves to the right-hand side. x_i, c and B have 3 columns (rotations: one per row of R).
void add_equation(const Eigen::Matrix3d& a_i, const Eigen::Matrix3d& a_j, const Eigen::Matrix3d& c, double k,
                  int free_i, int free_j, const Eigen::Matrix3d& known_i, const Eigen::Matrix3d& known_j, Triplets* h,
                  Eigen::MatrixXd* b) {
  Eigen::Matrix3d rhs = c;
  if (free_i < 0) rhs -= a_i * known_i;
  if (free_j < 0) rhs -= a_j * known_j;
  if (free_i >= 0) {
    add_block(free_i, free_i, k * a_i.transpose() * a_i, h);
    b->middleRows<3>(3 * free_i) += k * a_i.transpose() * rhs;
  }
  if (free_j >= 0) {
    add_block(free_j, free_j, k * a_j.transpose() * a_j, h);
    b->middleRows<3>(3 * free_j) += k * a_j.transpose() * rhs;
  }
  if (free_i >= 0 && free_j >= 0) {
    add_block(free_i, free_j, k * a_i.transpose() * a_j, h);
    add_block(free_j, free_i, k * a_j.transpose() * a_i, h);
  }
}

// Solves H X = B (ChordalSolver). False when the factorization fails (a singular system).
bool solve(const Triplets& h, const Eigen::MatrixXd& b, ChordalSolver solver, Eigen::MatrixXd* x, ChordalStats* stats) {
  ++stats->systems;
  const auto n = static_cast<int>(b.rows());
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(h.begin(), h.end());
  if (solver == ChordalSolver::kIterative) {
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg(m);
    cg.setTolerance(1e-10);
    *x = cg.solve(b);
    if (cg.info() == Eigen::Success && x->allFinite()) {
      ++stats->iterative;
      return true;
    }
    ++stats->direct_fallbacks;
  }
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(m);
  if (ldlt.info() != Eigen::Success) return false;
  *x = ldlt.solve(b);
  return ldlt.info() == Eigen::Success && x->allFinite();
}

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
                      const std::vector<int>& free_index, int num_free, int iterations, ChordalSolver solver,
                      ChordalStats* stats, std::vector<Eigen::Matrix3d>* rotation) {
  const std::size_t n = rotation->size();
  Triplets h;
  Eigen::MatrixXd b, x;
  Eigen::Matrix3d lambda_t, lambda_r;
  std::vector<Eigen::Matrix3d> candidate;
  double cost = rotation_cost(edges, weights, free_index, *rotation);
  for (int it = 0; it < iterations; ++it) {
    h.clear();
    b = Eigen::MatrixXd::Zero(3 * num_free, 1);
    for (std::size_t k = 0; k < edges.size(); ++k) {
      const RelativePoseEdge& e = edges[k];
      if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
      const int fi = free_index[e.from], fj = free_index[e.to];
      if (fi < 0 && fj < 0) continue;
      precisions(e, &lambda_t, &lambda_r);
      lambda_r *= weights[k];
      const Eigen::Vector3d theta = rotation_residual(e, *rotation);
      const Eigen::Matrix3d j_i = -(*rotation)[e.to].transpose() * (*rotation)[e.from];
      add_weighted(j_i, Eigen::Matrix3d::Identity(), lambda_r, theta, fi, fj, &h, &b);
    }
    if (!solve(h, b, solver, &x, stats)) return false;
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
  Triplets h;
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(3 * num_free, 3), x;
  Eigen::Matrix3d lambda_t, lambda_r;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
    precisions(e, &lambda_t, &lambda_r);
    const Eigen::Matrix3d r_ij = e.measured_from_T_to.q.normalized().toRotationMatrix();
    add_equation(-r_ij.transpose(), Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero(),
                 weights[k] * lambda_r.trace() / 3.0, free_index[e.from], free_index[e.to],
                 rotation[e.from].transpose(), rotation[e.to].transpose(), &h, &b);
  }
  if (!solve(h, b, solver, &x, stats)) return false;
  std::vector<Eigen::Matrix3d> solved = rotation;
  for (std::size_t i = 0; i < n; ++i)
    if (free_index[i] >= 0) solved[i] = nearest_rotation(x.middleRows<3>(3 * free_index[i]).transpose());
  if (weighting == ChordalWeighting::kAnisotropic &&
      !refine_rotations(edges, weights, free_index, num_free, kRotationRefineIterations, solver, stats, &solved))
    return false;

  // Translations with those rotations: (t_j - t_i - R_i t_ij)^T P (t_j - t_i - R_i t_ij), P the edge's translation
  // precision in the world frame (M^T lambda_t M, M the residual frame's rotation R_ij^T R_i^T or R_i^T), or its
  // mean times I when isotropic: 3x3 blocks of a weighted Laplacian.
  h.clear();
  b = Eigen::MatrixXd::Zero(3 * num_free, 1);
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
    add_weighted(-Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Identity(), p, -rhs, fi, fj, &h, &b);
  }
  if (!solve(h, b, solver, &x, stats)) return false;
  for (std::size_t i = 0; i < n; ++i) {
    if (free_index[i] < 0) continue;
    (*poses)[i].t_m = x.middleRows<3>(3 * free_index[i]);
    (*poses)[i].q = Eigen::Quaterniond(solved[i]);
  }
  return true;
}

}  // namespace qsg::backend

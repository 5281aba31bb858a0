// Weighted chordal initialization: two sparse linear least-squares solves (rotations, then translations).
#include "core/backend/chordal_init.h"

#include <Eigen/SVD>
#include <Eigen/SparseCholesky>

#include <cstdint>

namespace qsg::backend {
namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// Isotropic precisions of an edge's translation and rotation: the mean of the information's diagonal blocks' traces,
// or of 1 / sigma^2.
void precisions(const RelativePoseEdge& e, double* kt, double* kr) {
  if (e.has_information) {
    *kt = e.information.topLeftCorner<3, 3>().trace() / 3.0;
    *kr = e.information.bottomRightCorner<3, 3>().trace() / 3.0;
    return;
  }
  *kt = e.sigma_t_m.cwiseInverse().squaredNorm() / 3.0;
  *kr = e.sigma_rot_rad.cwiseInverse().squaredNorm() / 3.0;
}

// Adds one 3-block equation A_i x_i + A_j x_j = c (weight k) to the normal equations H x = B over the free poses;
// an anchored pose's term moves to the right-hand side. x_i, c and B have 3 columns (rotations: one per row of R).
void add_equation(const Eigen::Matrix3d& a_i, const Eigen::Matrix3d& a_j, const Eigen::Matrix3d& c, double k,
                  int free_i, int free_j, const Eigen::Matrix3d& known_i, const Eigen::Matrix3d& known_j, Triplets* h,
                  Eigen::MatrixXd* b) {
  Eigen::Matrix3d rhs = c;
  if (free_i < 0) rhs -= a_i * known_i;
  if (free_j < 0) rhs -= a_j * known_j;
  const auto block = [&](int r, int col, const Eigen::Matrix3d& m) {
    for (int x = 0; x < 3; ++x)
      for (int y = 0; y < 3; ++y) h->emplace_back(3 * r + x, 3 * col + y, k * m(x, y));
  };
  if (free_i >= 0) {
    block(free_i, free_i, a_i.transpose() * a_i);
    b->middleRows<3>(3 * free_i) += k * a_i.transpose() * rhs;
  }
  if (free_j >= 0) {
    block(free_j, free_j, a_j.transpose() * a_j);
    b->middleRows<3>(3 * free_j) += k * a_j.transpose() * rhs;
  }
  if (free_i >= 0 && free_j >= 0) {
    block(free_i, free_j, a_i.transpose() * a_j);
    block(free_j, free_i, a_j.transpose() * a_i);
  }
}

// Solves H X = B. False when the factorization fails (a singular system).
bool solve(const Triplets& h, const Eigen::MatrixXd& b, Eigen::MatrixXd* x) {
  const auto n = static_cast<int>(b.rows());
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(h.begin(), h.end());
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

}  // namespace

bool chordal_initialize(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                        const std::vector<bool>& anchored, std::vector<Pose3>* poses) {
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

  // Rotations: R_j = R_i R_ij, one row of R at a time: R_j^T = R_ij^T R_i^T, unknowns X_i = R_i^T.
  Triplets h;
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(3 * num_free, 3), x;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
    double kt = 0.0, kr = 0.0;
    precisions(e, &kt, &kr);
    const Eigen::Matrix3d r_ij = e.measured_from_T_to.q.normalized().toRotationMatrix();
    add_equation(-r_ij.transpose(), Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero(), weights[k] * kr,
                 free_index[e.from], free_index[e.to], rotation[e.from].transpose(), rotation[e.to].transpose(), &h,
                 &b);
  }
  if (!solve(h, b, &x)) return false;
  std::vector<Eigen::Matrix3d> solved = rotation;
  for (std::size_t i = 0; i < n; ++i)
    if (free_index[i] >= 0) solved[i] = nearest_rotation(x.middleRows<3>(3 * free_index[i]).transpose());

  // Translations with those rotations: t_j - t_i = R_i t_ij. The precisions are isotropic, so the normal equations
  // are the weighted graph Laplacian over the free poses (one scalar per pose) with the three axes as columns.
  h.clear();
  b = Eigen::MatrixXd::Zero(num_free, 3);
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (!(weights[k] > 0.0) || e.from >= n || e.to >= n) continue;
    double kt = 0.0, kr = 0.0;
    precisions(e, &kt, &kr);
    const double w = weights[k] * kt;
    // Residual t_j - t_i - d: a known end moves to the right-hand side.
    Eigen::RowVector3d rhs = (solved[e.from] * e.measured_from_T_to.t_m).transpose();
    const int fi = free_index[e.from], fj = free_index[e.to];
    if (fi < 0) rhs += (*poses)[e.from].t_m.transpose();
    if (fj < 0) rhs -= (*poses)[e.to].t_m.transpose();
    if (fi >= 0) {
      h.emplace_back(fi, fi, w);
      b.row(fi) -= w * rhs;
    }
    if (fj >= 0) {
      h.emplace_back(fj, fj, w);
      b.row(fj) += w * rhs;
    }
    if (fi >= 0 && fj >= 0) {
      h.emplace_back(fi, fj, -w);
      h.emplace_back(fj, fi, -w);
    }
  }
  if (!solve(h, b, &x)) return false;
  for (std::size_t i = 0; i < n; ++i) {
    if (free_index[i] < 0) continue;
    (*poses)[i].t_m = x.row(free_index[i]).transpose();
    (*poses)[i].q = Eigen::Quaterniond(solved[i]);
  }
  return true;
}

}  // namespace qsg::backend

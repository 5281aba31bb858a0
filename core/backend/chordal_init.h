// Weighted chordal initialization of an SE(3) pose graph: a global estimate that needs no initial guess.
//
// Rotations first (Martinec and Pajdla, CVPR 2007; Carlone, Tron, Daniilidis, Dellaert, ICRA 2015): minimize
// sum_k w_k kr_k |R_j - R_i R_ij|_F^2 over unconstrained 3x3 matrices, a sparse linear least-squares problem, then
// project each onto SO(3). Then translations: sum_k w_k |t_j - t_i - R_i t_ij|^2_P with those rotations, linear
// again. The papers weigh each edge by its mean precisions (kIsotropic: kr_k for rotations, P = kt_k I), which
// misleads on a graph whose edges are sure of some axes and vague on others (cubicle.g2o: planar odometry sure of
// height, roll and pitch, scan matches sure of x, y and heading, 5 orders of magnitude apart): the odometry's
// sure axes lend it weight on its vague heading. kAnisotropic, the default, keeps each axis's own precision: a few
// Gauss-Newton steps on the rotations alone with the full rotation precision after the relaxation (which solves
// each column of R on its own and so cannot; a step is kept only where it lowers that cost), and P the edge's
// translation precision rotated into the world frame.
// Anchored poses keep their values and hold the gauge; a pose no weighted edge ties to an anchor keeps its value
// too. Runs on the backend thread: it allocates.
#pragma once

#include <vector>

#include "core/backend/pose3.h"

namespace qsg::backend {

enum class ChordalWeighting { kIsotropic, kAnisotropic };

// How the linear systems are solved. kDirect: sparse LDL^T (Eigen's simplicial factorization), exact, and fast
// while the graph is nearly a chain; wrong closures still weighted join random far-apart poses and fill the factor
// in (cubicle with 50 % wrong closures: minutes a system). kIterative: conjugate gradients to a relative residual
// of 1e-10, preconditioned by a subgraph of the weighted edges factored whole (those between poses near each other
// in the numbering, and a spanning tree) plus the block diagonal of the rest (Dellaert, Carlson, Ila, Ni, Thorpe,
// IROS 2010): the subgraph carries the long chain that a diagonal preconditioner cannot, the far edges' random
// links (revisits, wrong closures) converge fast. A system not solved within the iteration cap (twice the
// unknowns) is solved directly, except a Gauss-Newton step on the rotations, which keeps the truncated iterate
// (still a descent direction; its line search guards it).
enum class ChordalSolver { kDirect, kIterative };

// What one chordal_initialize did: linear systems solved; by conjugate gradients (kIterative) converged, stopped
// at the cap as a truncated Gauss-Newton step, or solved directly after they did not converge; and the conjugate
// gradient iterations, over all systems and columns.
struct ChordalStats {
  int systems = 0;
  int iterative = 0;
  int truncated = 0;
  int direct_fallbacks = 0;
  long long iterations = 0;
  ChordalStats& operator+=(const ChordalStats& o) {
    systems += o.systems;
    iterative += o.iterative;
    truncated += o.truncated;
    direct_fallbacks += o.direct_fallbacks;
    iterations += o.iterations;
    return *this;
  }
};

// Overwrites the poses that are not anchored with the chordal estimate. weights: per edge (0 switches it off, e.g. a
// rejected loop closure); anchored: per pose. False, and poses untouched, without an anchor, with weights or anchors
// of the wrong size, or when a linear solve fails.
bool chordal_initialize(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                        const std::vector<bool>& anchored, std::vector<Pose3>* poses,
                        ChordalWeighting weighting = ChordalWeighting::kAnisotropic,
                        ChordalSolver solver = ChordalSolver::kDirect, ChordalStats* stats = nullptr);

}  // namespace qsg::backend

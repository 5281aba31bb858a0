// Hides the Ceres 1.14 -> 2.1 API change (LocalParameterization -> Manifold) behind one helper per use.
// Include only from .cc files: the public backend headers stay Ceres-free.
#pragma once

#include <ceres/problem.h>
#include <ceres/version.h>

// Manifold arrived in Ceres 2.1 and LocalParameterization is gone in 2.2, so 2.1 is the switch point.
#if CERES_VERSION_MAJOR > 2 || (CERES_VERSION_MAJOR == 2 && CERES_VERSION_MINOR >= 1)
#define QSG_CERES_HAS_MANIFOLD 1
#include <ceres/manifold.h>
#else
#define QSG_CERES_HAS_MANIFOLD 0
#include <ceres/local_parameterization.h>
#endif

namespace qsg::backend::ceres_compat {

// Keeps the Eigen-ordered quaternion block `q` (x, y, z, w) on the unit sphere during the solve.
// The problem takes ownership of the manifold (default Problem::Options in both versions).
inline void set_quaternion_manifold(ceres::Problem& problem, double* q) {
#if QSG_CERES_HAS_MANIFOLD
  problem.SetManifold(q, new ceres::EigenQuaternionManifold);
#else
  problem.SetParameterization(q, new ceres::EigenQuaternionParameterization);
#endif
}

}  // namespace qsg::backend::ceres_compat

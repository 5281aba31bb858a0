// Weighted chordal initialization of an SE(3) pose graph: a global, linear estimate that needs no initial guess.
//
// Rotations first (Martinec and Pajdla, CVPR 2007; Carlone, Tron, Daniilidis, Dellaert, ICRA 2015): minimize
// sum_k w_k kr_k |R_j - R_i R_ij|_F^2 over unconstrained 3x3 matrices, a sparse linear least-squares problem, then
// project each onto SO(3). Then translations: sum_k w_k kt_k |t_j - t_i - R_i t_ij|^2 with those rotations, linear
// again. kr_k, kt_k are the edge's mean rotation and translation precisions (isotropic: chordal distance has no
// axes). Anchored poses keep their values and hold the gauge; a pose no weighted edge ties to an anchor keeps its
// value too. Runs on the backend thread: it allocates.
#pragma once

#include <vector>

#include "core/backend/pose3.h"

namespace qsg::backend {

// Overwrites the poses that are not anchored with the chordal estimate. weights: per edge (0 switches it off, e.g. a
// rejected loop closure); anchored: per pose. False, and poses untouched, without an anchor, with weights or anchors
// of the wrong size, or when a linear solve fails.
bool chordal_initialize(const std::vector<RelativePoseEdge>& edges, const std::vector<double>& weights,
                        const std::vector<bool>& anchored, std::vector<Pose3>* poses);

}  // namespace qsg::backend

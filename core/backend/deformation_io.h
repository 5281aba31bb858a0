// A deformation problem as a text file, to reproduce a solve offline (bench/loop_closure/dg_solve): the nodes'
// initial poses, every edge with its information, where the loop closures start, and optionally each agent's true
// position (the simulator's or a dataset's) so a solve can be scored without re-running the mission. Written by the
// app when QSG_DUMP_DEFORMATION names a file (firmware_app/pipeline_loop_closure.cc).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

#include "core/backend/deformation_graph.h"

namespace qsg::backend {

struct DeformationProblemFile {
  DeformationProblem problem;
  std::vector<Eigen::Vector3d> truth_m;  // per agent, or empty
  std::vector<Eigen::Quaterniond> truth_q;  // per agent when the file has the true orientations too, or empty
};

// truth_q (optional, one per agent with truth_m): the true orientations, written after each true position.
bool write_deformation_problem(const std::string& path, const DeformationProblem& problem,
                               const std::vector<Eigen::Vector3d>& truth_m, std::string* error,
                               const std::vector<Eigen::Quaterniond>& truth_q = {});
// False with the line in `error` for an unreadable or malformed file (indices out of range, counts that disagree).
bool read_deformation_problem(const std::string& path, DeformationProblemFile* out, std::string* error);

}  // namespace qsg::backend

// g2o text pose graphs: VERTEX_SE3:QUAT id x y z qx qy qz qw; EDGE_SE3:QUAT i j x y z qx qy qz qw and the 21 entries
// of the upper triangle of the 6x6 information matrix, row by row, over g2o's error [t; vec(q)].
#include "core/backend/g2o_file.h"

#include <Eigen/Cholesky>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <unordered_map>

namespace qsg::backend {
namespace {

bool fail(std::string* error, const std::string& path, std::size_t line, const std::string& why) {
  if (error != nullptr) *error = path + ":" + std::to_string(line) + ": " + why;
  return false;
}

bool finite_all(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

bool positive_definite(const Eigen::MatrixXd& m) { return Eigen::LLT<Eigen::MatrixXd>(m).info() == Eigen::Success; }

}  // namespace

bool read_g2o_pose_graph(const std::string& path, G2oPoseGraph* graph, std::string* error,
                         const G2oReadOptions& options) {
  *graph = G2oPoseGraph{};
  std::ifstream in(path);
  if (!in) return fail(error, path, 0, "cannot open");
  std::unordered_map<std::int64_t, std::uint32_t> index;
  struct PendingEdge {
    std::int64_t from, to;
    RelativePoseEdge edge;
    std::size_t line;
  };
  std::vector<PendingEdge> pending;
  std::string text;
  std::size_t line_number = 0;
  while (std::getline(in, text)) {
    ++line_number;
    std::istringstream line(text);
    std::string tag;
    if (!(line >> tag) || tag[0] == '#') continue;
    if (tag == "VERTEX_SE3:QUAT") {
      std::int64_t id = 0;
      double v[7];
      if (!(line >> id >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6]) || !finite_all(v, 7))
        return fail(error, path, line_number, "VERTEX_SE3:QUAT needs an id and 7 finite numbers");
      if (!index.emplace(id, static_cast<std::uint32_t>(graph->poses.size())).second)
        return fail(error, path, line_number, "vertex id " + std::to_string(id) + " given twice");
      Pose3 p;
      p.t_m = Eigen::Vector3d(v[0], v[1], v[2]);
      p.q = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
      if (p.q.norm() < 1e-6) return fail(error, path, line_number, "vertex quaternion has zero norm");
      p.q.normalize();
      graph->poses.push_back(p);
      graph->vertex_ids.push_back(id);
    } else if (tag == "EDGE_SE3:QUAT") {
      PendingEdge e;
      e.line = line_number;
      double v[7], info[21];
      if (!(line >> e.from >> e.to >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6]) || !finite_all(v, 7))
        return fail(error, path, line_number, "EDGE_SE3:QUAT needs two ids and 7 finite numbers");
      for (double& x : info)
        if (!(line >> x)) return fail(error, path, line_number, "EDGE_SE3:QUAT needs 21 information entries");
      if (!finite_all(info, 21)) return fail(error, path, line_number, "information entries must be finite");
      e.edge.measured_from_T_to.t_m = Eigen::Vector3d(v[0], v[1], v[2]);
      e.edge.measured_from_T_to.q = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
      if (e.edge.measured_from_T_to.q.norm() < 1e-6)
        return fail(error, path, line_number, "edge quaternion has zero norm");
      e.edge.measured_from_T_to.q.normalize();
      Eigen::Matrix<double, 6, 6> omega;
      for (int r = 0, k = 0; r < 6; ++r)
        for (int c = r; c < 6; ++c, ++k) omega(r, c) = omega(c, r) = info[k];
      // g2o's rotation error is vec(q), this residual's 2 vec(q): halve the rotation rows and columns.
      Eigen::Matrix<double, 6, 1> s;
      s << 1.0, 1.0, 1.0, 0.5, 0.5, 0.5;
      e.edge.information = s.asDiagonal() * omega * s.asDiagonal();
      e.edge.has_information = true;
      Eigen::Matrix<double, 6, 6>& m = e.edge.information;
      if (!positive_definite(m)) {
        const bool blocks =
            positive_definite(m.topLeftCorner<3, 3>()) && positive_definite(m.bottomRightCorner<3, 3>());
        if (!options.drop_indefinite_coupling || !blocks)
          return fail(error, path, line_number,
                      blocks ? "information matrix is not positive definite (its translation and rotation blocks "
                               "are: G2oReadOptions::drop_indefinite_coupling would zero their coupling)"
                             : "information matrix is not positive definite");
        m.topRightCorner<3, 3>().setZero();
        m.bottomLeftCorner<3, 3>().setZero();
        ++graph->couplings_dropped;
      }
      pending.push_back(e);
    } else {
      ++graph->lines_skipped;
    }
  }
  graph->edges.reserve(pending.size());
  for (PendingEdge& e : pending) {
    const auto a = index.find(e.from), b = index.find(e.to);
    if (a == index.end() || b == index.end())
      return fail(error, path, e.line, "edge to an unknown vertex (" + std::to_string(e.from) + " -> " +
                                           std::to_string(e.to) + ")");
    e.edge.from = a->second;
    e.edge.to = b->second;
    e.edge.is_loop_closure = std::llabs(e.to - e.from) != 1;
    graph->num_loop_closures += e.edge.is_loop_closure ? 1 : 0;
    graph->edges.push_back(e.edge);
  }
  return true;
}

}  // namespace qsg::backend

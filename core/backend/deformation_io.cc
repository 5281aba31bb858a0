// The deformation problem's text format (version 1):
//   qsg_deformation_problem 1
//   sizes AGENTS CONTROL_POINTS PLACES FIRST_CLOSURE LOOP_CLOSURES EDGES TRUTH(0|1)
//   p tx ty tz qx qy qz qw [time_ns]             one per node: agents, control points, places; an agent's line
//                                                may end with its chain node's time (every agent's or none)
//   o x y z time_ns [node_id]                    one per control point and place: odometric position, time seen;
//                                                a place's may end with its node id (every place's or none)
//   e from to loop_closure info(0|1) tx ty tz qx qy qz qw  then 6 sigmas, or the 36 information entries; a loop
//                                                closure's may end with its id (ChainLoopClosure::id; every one's or
//                                                none): a sequence of solves carries decisions by id and agent time
//   t x y z [qx qy qz qw]                        one per agent when TRUTH is 1 (the orientation optional)
#include "core/backend/deformation_io.h"

#include <cstdio>
#include <fstream>
#include <sstream>

namespace qsg::backend {

bool write_deformation_problem(const std::string& path, const DeformationProblem& problem,
                               const std::vector<Eigen::Vector3d>& truth_m, std::string* error,
                               const std::vector<Eigen::Quaterniond>& truth_q) {
  const DeformationResult& r = problem.result;
  const bool truth = !truth_m.empty() && truth_m.size() == r.agents;
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (f == nullptr) return *error = "cannot write '" + tmp + "'", false;
  std::fprintf(f, "qsg_deformation_problem 1\nsizes %zu %zu %zu %zu %zu %zu %d\n", r.agents, r.control_points, r.places,
               problem.first_closure, r.loop_closures, problem.edges.size(), truth ? 1 : 0);
  const bool agent_times = problem.agent_times_ns.size() == r.agents;
  for (std::size_t k = 0; k < problem.poses.size(); ++k) {
    const Pose3& p = problem.poses[k];
    std::fprintf(f, "p %.17g %.17g %.17g %.17g %.17g %.17g %.17g", p.t_m.x(), p.t_m.y(), p.t_m.z(), p.q.x(), p.q.y(),
                 p.q.z(), p.q.w());
    if (agent_times && k < r.agents)
      std::fprintf(f, " %llu", static_cast<unsigned long long>(problem.agent_times_ns[k]));
    std::fputc('\n', f);
  }
  // A place's line ends with its node id (a control point's has none): a sequence of solves matches places by it.
  const bool ids = problem.place_ids.size() == r.places;
  for (std::size_t i = 0; i < problem.originals.size(); ++i) {
    std::fprintf(f, "o %.17g %.17g %.17g %llu", problem.originals[i].x(), problem.originals[i].y(),
                 problem.originals[i].z(), static_cast<unsigned long long>(problem.times_ns[i]));
    if (ids && i >= r.control_points)
      std::fprintf(f, " %llu", static_cast<unsigned long long>(problem.place_ids[i - r.control_points]));
    std::fputc('\n', f);
  }
  const bool closure_ids = problem.closure_ids.size() == r.loop_closures;
  for (std::size_t k = 0; k < problem.edges.size(); ++k) {
    const RelativePoseEdge& e = problem.edges[k];
    const Pose3& m = e.measured_from_T_to;
    std::fprintf(f, "e %u %u %d %d %.17g %.17g %.17g %.17g %.17g %.17g %.17g", e.from, e.to, e.is_loop_closure ? 1 : 0,
                 e.has_information ? 1 : 0, m.t_m.x(), m.t_m.y(), m.t_m.z(), m.q.x(), m.q.y(), m.q.z(), m.q.w());
    if (e.has_information) {
      for (int i = 0; i < 36; ++i) std::fprintf(f, " %.17g", e.information(i / 6, i % 6));
    } else {
      for (int i = 0; i < 3; ++i) std::fprintf(f, " %.17g", e.sigma_t_m[i]);
      for (int i = 0; i < 3; ++i) std::fprintf(f, " %.17g", e.sigma_rot_rad[i]);
    }
    if (closure_ids && e.is_loop_closure)
      std::fprintf(f, " %llu", static_cast<unsigned long long>(problem.closure_ids[k - problem.first_closure]));
    std::fputc('\n', f);
  }
  const bool with_q = truth && truth_q.size() == truth_m.size();
  if (truth)
    for (std::size_t k = 0; k < truth_m.size(); ++k) {
      const Eigen::Vector3d& t = truth_m[k];
      std::fprintf(f, "t %.17g %.17g %.17g", t.x(), t.y(), t.z());
      if (with_q)
        std::fprintf(f, " %.17g %.17g %.17g %.17g", truth_q[k].x(), truth_q[k].y(), truth_q[k].z(), truth_q[k].w());
      std::fputc('\n', f);
    }
  const bool ok = std::fflush(f) == 0 && std::ferror(f) == 0;
  std::fclose(f);
  if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) return *error = "cannot write '" + path + "'", false;
  return true;
}

bool read_deformation_problem(const std::string& path, DeformationProblemFile* out, std::string* error) {
  std::ifstream in(path);
  if (!in) return *error = "cannot read '" + path + "'", false;
  std::string line, tag;
  std::size_t line_no = 0;
  const auto fail = [&](const std::string& what) {
    *error = path + ":" + std::to_string(line_no) + ": " + what;
    return false;
  };
  const auto next = [&](std::istringstream* s) {
    if (!std::getline(in, line)) return false;
    ++line_no;
    s->clear();
    s->str(line);
    return true;
  };
  std::istringstream s;
  int version = 0;
  if (!next(&s) || !(s >> tag >> version) || tag != "qsg_deformation_problem" || version != 1)
    return fail("not a version-1 deformation problem");
  std::size_t A = 0, C = 0, P = 0, first = 0, closures = 0, num_edges = 0;
  int truth = 0;
  if (!next(&s) || !(s >> tag >> A >> C >> P >> first >> closures >> num_edges >> truth) || tag != "sizes" ||
      first > num_edges || closures > num_edges - first || A < 2 || A + C + P > (1u << 30) || num_edges > (1u << 30))
    return fail("bad sizes line");
  DeformationProblem& p = out->problem;
  p = DeformationProblem{};
  p.result.agents = A;
  p.result.control_points = C;
  p.result.places = P;
  p.result.loop_closures = closures;
  p.first_closure = first;
  const std::size_t N = A + C + P;
  p.poses.resize(N);
  for (std::size_t k = 0; k < N; ++k) {
    Pose3& pose = p.poses[k];
    double q[4];
    if (!next(&s) || !(s >> tag >> pose.t_m.x() >> pose.t_m.y() >> pose.t_m.z() >> q[0] >> q[1] >> q[2] >> q[3]) ||
        tag != "p")
      return fail("expected a pose line");
    pose.q = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
    unsigned long long t = 0;
    if (k < A && s >> t) {
      if (p.agent_times_ns.size() != k) return fail("every agent line or none carries a time");
      p.agent_times_ns.push_back(t);
    } else if (k < A && !p.agent_times_ns.empty()) {
      return fail("every agent line or none carries a time");
    }
  }
  p.originals.resize(C + P);
  p.times_ns.resize(C + P);
  for (std::size_t i = 0; i < C + P; ++i) {
    unsigned long long t = 0;
    if (!next(&s) || !(s >> tag >> p.originals[i].x() >> p.originals[i].y() >> p.originals[i].z() >> t) || tag != "o")
      return fail("expected an original-position line");
    p.times_ns[i] = t;
    unsigned long long id = 0;
    if (i >= C && s >> id) {
      if (p.place_ids.size() != i - C) return fail("every place line or none carries a node id");
      p.place_ids.push_back(id);
    } else if (i >= C && !p.place_ids.empty()) {
      return fail("every place line or none carries a node id");
    }
  }
  p.edges.resize(num_edges);
  for (std::size_t k = 0; k < num_edges; ++k) {
    RelativePoseEdge& e = p.edges[k];
    int lc = 0, info = 0;
    double q[4];
    Pose3& m = e.measured_from_T_to;
    if (!next(&s) || !(s >> tag >> e.from >> e.to >> lc >> info >> m.t_m.x() >> m.t_m.y() >> m.t_m.z() >> q[0] >> q[1] >>
                       q[2] >> q[3]) ||
        tag != "e" || e.from >= N || e.to >= N)
      return fail("expected an edge line with nodes in range");
    m.q = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
    e.is_loop_closure = lc != 0;
    e.has_information = info != 0;
    if (e.is_loop_closure != (k >= first && k < first + closures))
      return fail("the loop closures must be edges [first, first + loop closures)");
    if (e.has_information) {
      for (int i = 0; i < 36; ++i)
        if (!(s >> e.information(i / 6, i % 6))) return fail("expected 36 information entries");
    } else {
      for (int i = 0; i < 3; ++i)
        if (!(s >> e.sigma_t_m[i])) return fail("expected 6 sigmas");
      for (int i = 0; i < 3; ++i)
        if (!(s >> e.sigma_rot_rad[i])) return fail("expected 6 sigmas");
    }
    unsigned long long id = 0;
    if (e.is_loop_closure && s >> id) {
      if (p.closure_ids.size() != k - first) return fail("every loop closure line or none carries an id");
      p.closure_ids.push_back(id);
    } else if (e.is_loop_closure && !p.closure_ids.empty()) {
      return fail("every loop closure line or none carries an id");
    }
  }
  out->truth_m.clear();
  out->truth_q.clear();
  if (truth != 0) {
    out->truth_m.resize(A);
    for (std::size_t k = 0; k < A; ++k) {
      Eigen::Vector3d& t = out->truth_m[k];
      if (!next(&s) || !(s >> tag >> t.x() >> t.y() >> t.z()) || tag != "t") return fail("expected a truth line");
      double q[4];
      if (s >> q[0] >> q[1] >> q[2] >> q[3]) {
        if (k != out->truth_q.size()) return fail("every truth line or none carries an orientation");
        out->truth_q.push_back(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized());
      } else if (!out->truth_q.empty()) {
        return fail("every truth line or none carries an orientation");
      }
    }
  }
  return true;
}

}  // namespace qsg::backend

// Pairwise consistency of loop closures: odometry chain prefixes, the cycle test, and a maximum clique by greedy
// start and branch and bound with a greedy-colouring bound (Tomita's MCQ) over bit rows.
#include "core/backend/pairwise_consistency.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace qsg::backend {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Total variances (trace of the covariance) of an edge's translation and rotation residual.
struct EdgeVariance {
  double t = 0.0;
  double r = 0.0;
};

EdgeVariance edge_variance(const RelativePoseEdge& e) {
  if (!e.has_information) return {e.sigma_t_m.squaredNorm(), e.sigma_rot_rad.squaredNorm()};
  const Matrix6d cov = e.information.inverse();
  return {cov.topLeftCorner<3, 3>().trace(), cov.bottomRightCorner<3, 3>().trace()};
}

// The odometry chain composed from pose 0: prefix poses, the segment each pose is in (a missing step starts a new
// one), and prefix sums of the steps' variances for the legs' variances in O(1).
class OdometryChain {
 public:
  OdometryChain(std::size_t n, const std::vector<RelativePoseEdge>& edges)
      : pose_(n), segment_(n, 0), var_t_(n, 0.0), var_r_(n, 0.0), s1_(n, Eigen::Vector3d::Zero()), s2_(n, 0.0) {
    std::vector<const RelativePoseEdge*> step(n, nullptr);  // step k joins k and k + 1
    for (const RelativePoseEdge& e : edges) {
      if (e.is_loop_closure) continue;
      const std::uint32_t lo = std::min(e.from, e.to), hi = std::max(e.from, e.to);
      if (hi == lo + 1 && step[lo] == nullptr) step[lo] = &e;
    }
    for (std::size_t k = 0; k + 1 < n; ++k) {
      const RelativePoseEdge* e = step[k];
      Pose3 o;
      EdgeVariance v;
      if (e != nullptr) {
        o = e->measured_from_T_to;
        o.q.normalize();
        if (e->from != k) o = o.inverse();
        v = edge_variance(*e);
      }
      pose_[k + 1] = pose_[k] * o;
      segment_[k + 1] = segment_[k] + (e == nullptr ? 1 : 0);
      var_t_[k + 1] = var_t_[k] + v.t;
      var_r_[k + 1] = var_r_[k] + v.r;
      // The rotation variance of step k acts at pose k's position (lever sums for var_r |c - p|^2).
      s1_[k + 1] = s1_[k] + v.r * pose_[k].t_m;
      s2_[k + 1] = s2_[k] + v.r * pose_[k].t_m.squaredNorm();
    }
  }

  bool connected(std::uint32_t a, std::uint32_t b) const { return segment_[a] == segment_[b]; }
  Pose3 between(std::uint32_t a, std::uint32_t b) const { return pose_[a].inverse() * pose_[b]; }
  const Pose3& pose(std::uint32_t a) const { return pose_[a]; }

  // The leg a..b's translation variance, its rotation variance, and the translation variance its rotation drift
  // causes at a point c (chain frame): sum over the steps of var_r |c - p_step|^2.
  void leg(std::uint32_t a, std::uint32_t b, const Eigen::Vector3d& c, double* var_t, double* var_r,
           double* lever) const {
    const std::uint32_t lo = std::min(a, b), hi = std::max(a, b);
    *var_t = var_t_[hi] - var_t_[lo];
    *var_r = var_r_[hi] - var_r_[lo];
    const Eigen::Vector3d s1 = s1_[hi] - s1_[lo];
    *lever = std::max(0.0, (s2_[hi] - s2_[lo]) - 2.0 * c.dot(s1) + c.squaredNorm() * *var_r);
  }

 private:
  std::vector<Pose3> pose_;
  std::vector<std::uint32_t> segment_;
  std::vector<double> var_t_, var_r_;
  std::vector<Eigen::Vector3d> s1_;
  std::vector<double> s2_;
};

struct Closure {
  std::uint32_t from = 0, to = 0;
  Pose3 z;  // from_T_to
  EdgeVariance v;
};

enum class PairTest : std::uint8_t { kConsistent, kInconsistent, kUntestable };

// The cycle i -a-> j -odo-> l -b^-1-> k -odo-> i, in i's frame, against the gates.
PairTest test_pair(const OdometryChain& chain, const Closure& a, const Closure& b, double gate) {
  const std::uint32_t i = a.from, j = a.to, k = b.from, l = b.to;
  if (!chain.connected(j, l) || !chain.connected(k, i)) return PairTest::kUntestable;
  const Pose3 cycle = a.z * chain.between(j, l) * b.z.inverse() * chain.between(k, i);
  // Lever points: i's position seen from each leg's chain frame (through closure a for the leg j..l).
  const Eigen::Vector3d i_from_j_leg = (chain.pose(j) * a.z.inverse()).t_m;
  double vt1 = 0, vr1 = 0, lever1 = 0, vt2 = 0, vr2 = 0, lever2 = 0;
  chain.leg(j, l, i_from_j_leg, &vt1, &vr1, &lever1);
  chain.leg(k, i, chain.pose(i).t_m, &vt2, &vr2, &lever2);
  const double lever_b = b.v.r * (chain.pose(l).t_m - i_from_j_leg).squaredNorm() / 3.0;
  const double var_t = a.v.t + b.v.t + vt1 + vt2 + (lever1 + lever2) / 3.0 + lever_b;
  const double var_r = a.v.r + b.v.r + vr1 + vr2;
  const double angle = 2.0 * std::atan2(cycle.q.vec().norm(), std::abs(cycle.q.w()));
  // Per axis: the variances are traces over three axes.
  const bool ok = cycle.t_m.squaredNorm() <= gate * gate * var_t / 3.0 && angle * angle <= gate * gate * var_r / 3.0;
  return ok ? PairTest::kConsistent : PairTest::kInconsistent;
}

using Row = std::vector<std::uint64_t>;

bool test_bit(const Row& r, std::size_t v) { return (r[v >> 6] >> (v & 63)) & 1u; }
void set_bit(Row& r, std::size_t v) { r[v >> 6] |= std::uint64_t{1} << (v & 63); }
void clear_bit(Row& r, std::size_t v) { r[v >> 6] &= ~(std::uint64_t{1} << (v & 63)); }
std::size_t count(const Row& r) {
  std::size_t n = 0;
  for (const std::uint64_t w : r) n += static_cast<std::size_t>(__builtin_popcountll(w));
  return n;
}

// Maximum clique of an undirected graph given as bit rows: Tomita's MCQ (greedy colouring bound, vertices in
// degree order), started from a greedy clique so the bound prunes from the first node; bounded by a node budget.
class MaxClique {
 public:
  MaxClique(const std::vector<Row>& adjacency, std::uint32_t max_nodes)
      : adj_(adjacency), n_(adjacency.size()), max_nodes_(max_nodes) {
    degree_.resize(n_);
    for (std::size_t v = 0; v < n_; ++v) degree_[v] = count(adj_[v]);
    order_.resize(n_);
    std::iota(order_.begin(), order_.end(), std::size_t{0});
    std::stable_sort(order_.begin(), order_.end(), [&](std::size_t a, std::size_t b) { return degree_[a] > degree_[b]; });
  }

  std::vector<std::size_t> solve() {
    greedy();
    Row all((n_ + 63) / 64, 0);
    // Only vertices that could be in a clique larger than the greedy one.
    for (std::size_t v = 0; v < n_; ++v)
      if (degree_[v] + 1 > best_.size()) set_bit(all, v);
    std::vector<std::size_t> current;
    expand(all, &current);
    return best_;
  }
  std::uint32_t nodes() const { return nodes_; }
  bool truncated() const { return truncated_; }

 private:
  // From each of the highest-degree vertices, add the candidate of highest degree while one remains.
  void greedy() {
    const std::size_t starts = std::min<std::size_t>(n_, 16);
    for (std::size_t s = 0; s < starts; ++s) {
      std::vector<std::size_t> clique{order_[s]};
      Row cand = adj_[order_[s]];
      // Candidates only shrink, so one pass in degree order adds what the repeated search would.
      for (const std::size_t v : order_) {
        if (!test_bit(cand, v)) continue;
        clique.push_back(v);
        for (std::size_t w = 0; w < cand.size(); ++w) cand[w] &= adj_[v][w];
      }
      if (clique.size() > best_.size()) best_ = clique;
    }
  }

  void expand(Row p, std::vector<std::size_t>* current) {
    if (++nodes_ > max_nodes_) {
      truncated_ = true;
      return;
    }
    std::vector<std::size_t> vertices;
    std::vector<std::size_t> colour;
    colour_sort(p, &vertices, &colour);
    for (std::size_t idx = vertices.size(); idx-- > 0;) {
      if (truncated_ || current->size() + colour[idx] <= best_.size()) return;
      const std::size_t v = vertices[idx];
      current->push_back(v);
      Row next(p.size());
      for (std::size_t w = 0; w < p.size(); ++w) next[w] = p[w] & adj_[v][w];
      if (count(next) == 0) {
        if (current->size() > best_.size()) best_ = *current;
      } else {
        expand(std::move(next), current);
      }
      current->pop_back();
      clear_bit(p, v);
    }
  }

  // Greedy colouring of p's vertices (in degree order): vertices listed by colour class, colour[k] the number of
  // colours up to vertex k's, a bound on the clique size among vertices[0..k].
  void colour_sort(const Row& p, std::vector<std::size_t>* vertices, std::vector<std::size_t>* colour) const {
    std::vector<std::size_t> pending;
    for (const std::size_t v : order_)
      if (test_bit(p, v)) pending.push_back(v);
    std::vector<std::size_t> rest;
    for (std::size_t c = 1; !pending.empty(); ++c) {
      Row q = p;  // the vertices still allowed in colour class c
      rest.clear();
      for (const std::size_t v : pending) {
        if (!test_bit(q, v)) {
          rest.push_back(v);
          continue;
        }
        for (std::size_t w = 0; w < q.size(); ++w) q[w] &= ~adj_[v][w];
        vertices->push_back(v);
        colour->push_back(c);
      }
      pending.swap(rest);
    }
  }

  const std::vector<Row>& adj_;
  std::size_t n_;
  std::uint32_t max_nodes_;
  std::vector<std::size_t> degree_;
  std::vector<std::size_t> order_;
  std::vector<std::size_t> best_;
  std::uint32_t nodes_ = 0;
  bool truncated_ = false;
};

// The consistency graph over `closures` as bit rows (an untestable pair counts as consistent); the pair tallies
// go to `tallies` when given.
std::vector<Row> consistency_graph(const OdometryChain& chain, const std::vector<Closure>& closures, double gate,
                                   PairwiseConsistencyResult* tallies) {
  const std::size_t n = closures.size();
  std::vector<Row> adjacency(n, Row((n + 63) / 64, 0));
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      const PairTest t = test_pair(chain, closures[a], closures[b], gate);
      if (tallies != nullptr) {
        ++tallies->pairs_tested;
        tallies->pairs_untestable += t == PairTest::kUntestable ? 1 : 0;
        tallies->pairs_consistent += t == PairTest::kInconsistent ? 0 : 1;
      }
      if (t == PairTest::kInconsistent) continue;
      set_bit(adjacency[a], b);
      set_bit(adjacency[b], a);
    }
  }
  return adjacency;
}

}  // namespace

std::string check(const PairwiseConsistencyConfig& config) {
  if (!(std::isfinite(config.threshold_sigma) && config.threshold_sigma > 0.0))
    return "pairwise consistency: threshold_sigma must be finite and > 0";
  if (config.max_clique_nodes < 1) return "pairwise consistency: max_clique_nodes must be at least 1";
  return {};
}

void PairwiseConsistencyConfig::print(std::FILE* out) const {
  std::fprintf(out, "pairwise_consistency: threshold_sigma=%g max_clique_nodes=%u\n", threshold_sigma,
               max_clique_nodes);
}

void PairwiseConsistencyResult::print(std::FILE* out) const {
  std::fprintf(out,
               "pairwise consistency: %u of %u loop closures kept; %u pairs tested, %u consistent, %u untestable; "
               "clique search %u nodes%s%s%s\n",
               kept, loop_closures, pairs_tested, pairs_consistent, pairs_untestable, clique_nodes,
               clique_truncated ? " (truncated)" : "", message.empty() ? "" : "; ", message.c_str());
}

PairwiseConsistencyResult select_consistent_loop_closures(const PairwiseConsistencyConfig& config,
                                                          std::size_t num_poses,
                                                          const std::vector<RelativePoseEdge>& edges) {
  PairwiseConsistencyResult result;
  result.rejected.assign(edges.size(), false);
  if (std::string error = check(config); !error.empty()) {
    result.message = error;
    return result;
  }
  std::vector<Closure> closures;
  std::vector<std::size_t> edge_of;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const RelativePoseEdge& e = edges[k];
    if (e.from >= num_poses || e.to >= num_poses) {
      result.message = "pairwise consistency: an edge's pose index is out of range; nothing rejected";
      return result;
    }
    if (!e.is_loop_closure) continue;
    Closure c{e.from, e.to, e.measured_from_T_to, edge_variance(e)};
    c.z.q.normalize();
    closures.push_back(c);
    edge_of.push_back(k);
  }
  result.loop_closures = static_cast<std::uint32_t>(closures.size());
  result.kept = result.loop_closures;
  if (closures.size() < 2) return result;

  const OdometryChain chain(num_poses, edges);
  const std::size_t n = closures.size();
  const std::vector<Row> adjacency = consistency_graph(chain, closures, config.threshold_sigma, &result);
  MaxClique search(adjacency, config.max_clique_nodes);
  const std::vector<std::size_t> clique = search.solve();
  result.clique_nodes = search.nodes();
  result.clique_truncated = search.truncated();
  std::vector<bool> in_clique(n, false);
  for (const std::size_t v : clique) in_clique[v] = true;
  result.kept = static_cast<std::uint32_t>(clique.size());
  for (std::size_t a = 0; a < n; ++a)
    if (!in_clique[a]) result.rejected[edge_of[a]] = true;
  return result;
}

struct PairwiseConsistencyScreen::Impl {
  Impl(const PairwiseConsistencyConfig& c, std::size_t n, const std::vector<RelativePoseEdge>& e)
      : config(c), num_poses(n), edges(e), chain(n, e) {}
  PairwiseConsistencyConfig config;
  std::size_t num_poses;
  const std::vector<RelativePoseEdge>& edges;
  OdometryChain chain;
};

PairwiseConsistencyScreen::PairwiseConsistencyScreen(const PairwiseConsistencyConfig& config, std::size_t num_poses,
                                                     const std::vector<RelativePoseEdge>& edges)
    : impl_(std::make_unique<Impl>(config, num_poses, edges)) {}

PairwiseConsistencyScreen::~PairwiseConsistencyScreen() = default;

std::size_t PairwiseConsistencyScreen::largest_consistent_subset(const std::vector<std::size_t>& group) const {
  if (group.size() < 2) return group.size();
  std::vector<Closure> closures;
  for (const std::size_t k : group) {
    if (k >= impl_->edges.size()) return group.size();
    const RelativePoseEdge& e = impl_->edges[k];
    if (e.from >= impl_->num_poses || e.to >= impl_->num_poses) return group.size();
    Closure c{e.from, e.to, e.measured_from_T_to, edge_variance(e)};
    c.z.q.normalize();
    closures.push_back(c);
  }
  const std::vector<Row> adjacency = consistency_graph(impl_->chain, closures, impl_->config.threshold_sigma, nullptr);
  MaxClique search(adjacency, impl_->config.max_clique_nodes);
  return search.solve().size();
}

}  // namespace qsg::backend

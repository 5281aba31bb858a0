// Pairwise consistency of loop closures (PCM: Mangelson, Dominic, Eustice, Vasudevan, ICRA 2018), a prefilter in
// front of the robust pose-graph solve. Two closures a = (i -> j) and b = (k -> l) are consistent when the cycle
// i -a-> j -odometry-> l -b^-1-> k -odometry-> i returns to where it started, within the uncertainty of the two
// closures and of the odometry along the two legs. The largest set of mutually consistent closures (a maximum
// clique of the consistency graph) is kept; every other closure is rejected before the solve. Wrong closures agree
// with nothing in particular, right ones agree with each other, so at high outlier rates the clique still holds the
// right ones where a robust loss alone, started from a state bent by the outliers, can settle in a wrong basin.
//
// The odometry between two poses is the composition of the odometry edges along the chain (edges between
// consecutive indices, in either direction); its variance grows with the number of steps, and rotation drift
// grows the translation's with the lever arm. Pairs whose legs leave the chain (a gap in the odometry) cannot be
// tested and count as consistent. Runs on the backend thread, not the real-time path: it allocates (a bit matrix of
// C^2 / 8 bytes for C closures).
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/backend/pose3.h"

namespace qsg::backend {

struct PairwiseConsistencyConfig {
  // Gate on each of the cycle's translation and rotation errors: |e|^2 <= threshold^2 x (the per-axis variance of
  // the cycle: the two closures' and the two odometry legs' variances summed, a third of their trace). First-order
  // variances; a right closure rejected here never comes back (bench/results/pose_graph.md for the choice).
  double threshold_sigma = 5.0;
  // Branch-and-bound nodes of the exact maximum-clique search; when they run out the best clique found so far is
  // used (counted as truncated). The greedy clique it starts from is always complete.
  std::uint32_t max_clique_nodes = 2000000;

  void print(std::FILE* out) const;
};

struct PairwiseConsistencyResult {
  std::vector<bool> rejected;  // per edge, in input order: a loop closure outside the clique (never odometry)
  std::uint32_t loop_closures = 0;
  std::uint32_t kept = 0;
  std::uint32_t pairs_tested = 0;
  std::uint32_t pairs_consistent = 0;
  std::uint32_t pairs_untestable = 0;  // a leg leaves the odometry chain: counted as consistent
  std::uint32_t clique_nodes = 0;      // branch-and-bound nodes used
  bool clique_truncated = false;       // node budget reached: the clique may not be maximum
  std::string message;                 // empty when the input was usable; then nothing is rejected

  void print(std::FILE* out) const;
};

// Empty when the config is usable, else what is wrong.
std::string check(const PairwiseConsistencyConfig& config);

// The closures of `edges` (is_loop_closure) outside the largest pairwise-consistent set. Odometry edges are the
// others; `num_poses` bounds the indices. Invalid input (an index out of range, a bad config) rejects nothing and
// says why in `message`.
PairwiseConsistencyResult select_consistent_loop_closures(const PairwiseConsistencyConfig& config,
                                                          std::size_t num_poses,
                                                          const std::vector<RelativePoseEdge>& edges);

// The same pairwise test over chosen groups of closures, for a search that wants to know whether a group agrees
// with itself (PoseGraphConfig::gnc_cluster_screen): built once over a graph's odometry, then asked for the size of
// any group's largest mutually consistent subset. Allocates (backend thread, not the real-time path).
class PairwiseConsistencyScreen {
 public:
  // `edges` must outlive the screen; their indices must be below num_poses (optimize_pose_graph checks them).
  PairwiseConsistencyScreen(const PairwiseConsistencyConfig& config, std::size_t num_poses,
                            const std::vector<RelativePoseEdge>& edges);
  ~PairwiseConsistencyScreen();
  PairwiseConsistencyScreen(const PairwiseConsistencyScreen&) = delete;
  PairwiseConsistencyScreen& operator=(const PairwiseConsistencyScreen&) = delete;

  // The size of the largest pairwise-consistent subset of `group` (indices into the edges; loop closures). A pair
  // that cannot be tested counts as consistent; a group with an index out of range is returned whole.
  std::size_t largest_consistent_subset(const std::vector<std::size_t>& group) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace qsg::backend

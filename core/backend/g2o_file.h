// Reads 3D pose graphs in g2o's text format (VERTEX_SE3:QUAT, EDGE_SE3:QUAT), the format of the public pose-graph
// benchmarks (parking-garage, cubicle, sphere2500, torus3D, ...), into the backend's poses and edges.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/backend/pose_graph.h"

namespace qsg::backend {

struct G2oPoseGraph {
  std::vector<Pose3> poses;              // the file's initial guess, indexed 0..n-1 in the order of vertex ids
  std::vector<std::int64_t> vertex_ids;  // the file's id of each pose
  // Every edge with its information matrix converted to RelativePoseEdge's residual (rotation 2 vec(q), so g2o's
  // rotation rows and columns are halved). An edge between consecutive ids is odometry, any other a loop closure.
  std::vector<RelativePoseEdge> edges;
  std::size_t num_loop_closures = 0;
  std::size_t lines_skipped = 0;  // other record types (fixed vertices, 2D records, parameters) are counted, not read
  std::size_t couplings_dropped = 0;  // edges whose translation-rotation coupling was zeroed (G2oReadOptions)
};

struct G2oReadOptions {
  // An information matrix that is not positive definite as a whole, while its translation block and its rotation
  // block each are: the coupling between them is larger than any distribution allows (cubicle has 5,021 such edges
  // of 16,869, every one of them with coupling terms, likely from a 2D graph lifted to 3D). false: the file is
  // refused. true: the coupling block is zeroed, which keeps each block's own precision, and the edge is counted
  // in G2oPoseGraph::couplings_dropped. A matrix with an indefinite block is refused either way.
  bool drop_indefinite_coupling = false;
};

// False with the file and line in `error` for an unreadable file, a malformed record, an edge to an unknown vertex,
// a duplicated vertex id, or an information matrix that is not positive definite (see G2oReadOptions).
bool read_g2o_pose_graph(const std::string& path, G2oPoseGraph* graph, std::string* error,
                         const G2oReadOptions& options = {});

}  // namespace qsg::backend

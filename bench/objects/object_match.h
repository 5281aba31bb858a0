// Estimated objects scored against a world's ground-truth objects (objects_eval's metric, shared with
// drift/drift_baseline): a ground-truth object is found, and an estimate correct, when an estimate of the same label
// lies within 0.5 m of the ground-truth box centre, both in the world frame.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "core/reconstruction/semantic_tsdf.h"
#include "core/semantics/labels.h"
#include "drivers/world/world.h"

namespace qsg::bench {

inline constexpr double kObjectMatchRadiusM = 0.5;
// A ground-truth object counts as observed with at least this many mesh vertices of its label in its box grown by
// kObservedMarginM: objects the robot never saw cannot be found by any method.
inline constexpr int kObservedMinVertices = 20;
inline constexpr double kObservedMarginM = 0.15;

struct EstimatedObject {
  semantics::Label label = semantics::kVoid;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
};

struct ObjectMatch {
  std::vector<bool> found;    // per ground-truth object
  std::vector<bool> correct;  // per estimate
  std::size_t num_found = 0, num_correct = 0;
};

inline ObjectMatch match_objects(const world::World& w, const std::vector<EstimatedObject>& estimates) {
  ObjectMatch m;
  m.found.assign(w.objects.size(), false);
  m.correct.assign(estimates.size(), false);
  for (std::size_t j = 0; j < estimates.size(); ++j)
    for (std::size_t i = 0; i < w.objects.size(); ++i) {
      const world::Object& o = w.objects[i];
      if (o.label != estimates[j].label || (o.box.center_m - estimates[j].position_m).norm() > kObjectMatchRadiusM)
        continue;
      m.found[i] = true;
      m.correct[j] = true;
    }
  for (const bool f : m.found) m.num_found += f ? 1 : 0;
  for (const bool c : m.correct) m.num_correct += c ? 1 : 0;
  return m;
}

// Per ground-truth object, the mesh vertices of its label inside its box grown by kObservedMarginM.
inline std::vector<int> object_mesh_vertices(const world::World& w, const reconstruction::Mesh& mesh) {
  std::vector<int> inside(w.objects.size(), 0);
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    const world::Object& o = w.objects[i];
    const Eigen::Vector3d half = o.box.half_extents_m + Eigen::Vector3d::Constant(kObservedMarginM);
    for (const reconstruction::MeshVertex& v : mesh.vertices) {
      if (v.label != o.label) continue;
      const Eigen::Vector3d local = o.box.world_R_box.conjugate() * (Eigen::Vector3d(v.x, v.y, v.z) - o.box.center_m);
      inside[i] += (local.cwiseAbs().array() <= half.array()).all() ? 1 : 0;
    }
  }
  return inside;
}

}  // namespace qsg::bench

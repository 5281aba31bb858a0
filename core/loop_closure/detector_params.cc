#include "core/loop_closure/detector_params.h"

#include <cmath>

namespace qsg::loop_closure {

namespace {
using params::above;
using params::in;
constexpr auto paper = params::Origin::kPaper;
constexpr auto project = params::Origin::kProject;
constexpr auto refinement = params::Origin::kRefinement;
}  // namespace

const params::Table<DescriptorConfig>& descriptor_params_table() {
  static const params::Table<DescriptorConfig> table = [] {
    params::Table<DescriptorConfig> t;
    t.add("radius_m", &DescriptorConfig::radius_m, "m", above(0, 50), paper,
          "places within this graph distance of the agent describe it");
    return t;
  }();
  return table;
}

const params::Table<DetectorConfig>& detector_params_table() {
  using D = DetectorConfig;
  static const params::Table<D> table = [] {
    params::Table<D> t;
    t.add("places_threshold", &D::places_threshold, "", in(0, 1), paper, "places similarity a candidate must reach");
    t.add("objects_threshold", &D::objects_threshold, "", in(0, 1), paper,
          "objects similarity a candidate must reach to be verified");
    t.add("min_time_separation_s", &D::min_time_separation_s, "s", in(0, 86400), project,
          "candidates at least this much older");
    t.add("min_path_separation_m", &D::min_path_separation_m, "m", in(0, 1000), project,
          "candidates at least this much path behind");
    t.add("ratio", &D::ratio, "", above(0, 1), project, "ratio test against the best candidate");
    t.add("distinct_verification_m", &D::distinct_verification_m, "m", in(0, 1000), refinement,
          "a candidate within this much path of one already verified for the query is skipped (0: by rank only)");
    t.flag("propose_unrefined_objects", &D::propose_unrefined_objects, project,
           "object registrations ICP could not refine are proposed too");
    return t;
  }();
  return table;
}

const params::Table<LocalMapConfig>& local_map_params_table() {
  using L = LocalMapConfig;
  static const params::Table<L> table = [] {
    params::Table<L> t;
    t.flag("local_map", &L::enabled, refinement,
           "object registrations the keyframes' ICP cannot refine are refined on the two agents' local maps");
    t.add("local_map_path_m", &L::path_m, "m", above(0, 50), refinement,
          "agents within this much path join an agent's local map");
    t.add("local_map_voxel_m", &L::voxel_m, "m", in(0.01, 1), refinement,
          "a local map keeps one point per voxel of this side");
    t.add("local_map_min_overlap", &L::min_overlap, "", above(0, 1), refinement,
          "share of the query's local-map points on a match plane after ICP");
    t.add("local_map_max_correction_rad", &L::max_correction_rad, "rad", above(0, 3.2), refinement,
          "largest rotation the local-map ICP may apply to the object registration's estimate");
    return t;
  }();
  return table;
}

const params::Table<AppearanceConfig>& appearance_params_table() {
  static const params::Table<AppearanceConfig> table = [] {
    params::Table<AppearanceConfig> t;
    t.flag("appearance_gravity_aligned", &AppearanceConfig::gravity_aligned, refinement,
           "the appearance RANSAC estimates yaw and translation and keeps the odometry's roll and pitch");
    return t;
  }();
  return table;
}

const params::Table<IcpConfig>& icp_params_table() {
  static const params::Table<IcpConfig> table = [] {
    params::Table<IcpConfig> t;
    t.flag("icp_gravity_aligned", &IcpConfig::gravity_aligned, refinement,
           "ICP (keyframes and local maps) estimates yaw and translation and keeps the odometry's roll and pitch");
    t.add("icp_max_normal_angle_rad", &IcpConfig::max_normal_angle_rad, "rad", above(0, M_PI), refinement,
          "ICP pairs a point only with one whose normal is within this angle (pi: no check)");
    return t;
  }();
  return table;
}

const params::Table<RegistrationConfig>& registration_params_table() {
  using R = RegistrationConfig;
  static const params::Table<R> table = [] {
    params::Table<R> t;
    t.add("noise_bound_m", &R::noise_bound_m, "m", above(0, 5), paper, "bound on one object centroid's error");
    t.add("min_inliers", &R::min_inliers, "", in(2, kMaxCorrespondences), paper, "objects a registration must hold");
    return t;
  }();
  return table;
}

}  // namespace qsg::loop_closure

#include "core/reconstruction/reconstruction_params.h"

namespace qsg::reconstruction {

const params::Table<Config>& params_table() {
  using params::above;
  using params::in;
  constexpr auto paper = params::Origin::kPaper;
  constexpr auto project = params::Origin::kProject;
  static const params::Table<Config> table = [&] {
    params::Table<Config> t;
    t.add("voxel_size_m", &Config::voxel_size_m, "m", in(0.02 - 1e-12, 1), paper, "TSDF voxel side");
    t.add("truncation_voxels", &Config::truncation_voxels, "voxels", in(1, 10), paper, "truncation distance");
    t.add("min_range_m", &Config::min_range_m, "m", in(0, 50), project, "depth below this is not integrated");
    t.add("max_range_m", &Config::max_range_m, "m", above(0, 50), project,
          "depth beyond this is not integrated (> min_range_m)");
    t.add("window_radius_m", &Config::window_radius_m, "m", above(0, 500), paper,
          "blocks farther from the robot are archived (> max_range_m)");
    t.add("max_weight", &Config::max_weight, "", above(1, 255), project, "voxel weights saturate here");
    t.add("archive_resolution_m", &Config::archive_resolution_m, "m", above(0, 1), project,
          "archived mesh vertices in one cell of this side are merged");
    t.add("archive_max_resolution_m", &Config::archive_max_resolution_m, "m", above(0, 5), project,
          "a full archive doubles its merge cell up to this (>= archive_resolution_m)");
    t.add("integration_threads", &Config::integration_threads, "", in(1, 8), project,
          "1: the caller's thread; 2..8: the caller plus long-lived workers");
    t.flag("integrate_labels", &Config::integrate_labels, paper, "semantic labels are voted into the voxels");
    return t;
  }();
  return table;
}

}  // namespace qsg::reconstruction

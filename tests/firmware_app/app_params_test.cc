// The app's configuration comes from the parameter tables: default.json is generated from them, and every
// committed config reads back through them.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "core/params/params_json.h"
#include "firmware_app/app_config.h"
#include "firmware_app/app_params.h"

namespace qsg::app {
namespace {

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// firmware_app/config/default.json is exactly what `qsg_app --dump-config` writes for the built-in defaults.
// After adding or changing a setting: build/default/firmware_app/qsg_app --dump-config > firmware_app/config/default.json
TEST(AppParamsTest, DefaultJsonIsGeneratedFromTheTables) {
  const std::string committed = read(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/default.json");
  ASSERT_FALSE(committed.empty());
  const std::string generated = params::dump_json(app_schema(), AppConfig{}, default_config_header());
  EXPECT_EQ(committed, generated) << "regenerate it: qsg_app --dump-config > firmware_app/config/default.json";
  // ... and it reads back to the built-in defaults.
  AppConfig loaded;
  std::string error;
  ASSERT_TRUE(loaded.load(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/default.json", &error)) << error;
  EXPECT_EQ(params::dump_json(app_schema(), loaded, ""), params::dump_json(app_schema(), AppConfig{}, ""));
}

TEST(AppParamsTest, EveryCommittedConfigLoads) {
  for (const char* name : {"mission_8h.json", "replay_every_frame.json"}) {
    AppConfig c;
    std::string error;
    EXPECT_TRUE(c.load(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/" + name, &error)) << name << ": " << error;
  }
}

TEST(AppParamsTest, SetReachesEveryStageAndIsRangeChecked) {
  AppConfig c;
  std::string error;
  ASSERT_TRUE(params::set(app_schema(), &c, "rooms.visible_min_share=0.7", &error)) << error;
  ASSERT_TRUE(params::set(app_schema(), &c, "places.bridge_max_length_m=2", &error)) << error;
  ASSERT_TRUE(params::set(app_schema(), &c, "doors.online=false", &error)) << error;
  ASSERT_TRUE(params::set(app_schema(), &c, "duration_s=12", &error)) << error;
  EXPECT_EQ(c.rooms.visible_min_share, 0.7);
  EXPECT_EQ(c.frontend.places.bridge_max_length_m, 2.0);
  EXPECT_FALSE(c.doors_online);
  EXPECT_EQ(c.duration_s, 12.0);
  EXPECT_FALSE(params::set(app_schema(), &c, "places.voxel_factor=3", &error));
  EXPECT_EQ(error, "places.voxel_factor: must be in [1, 2], got 3");
}

// The agent layer's solver is set like any stage's field, and a combination the solver refuses is refused at load
// time by name, not at the first loop closure.
TEST(AppParamsTest, TheLoopClosureSolverIsSetAndChecked) {
  AppConfig c;
  std::string error;
  const backend::PoseGraphConfig& solver = c.loop_closure.deformation.agents.solver;
  EXPECT_EQ(solver.loop_closure_loss, backend::RobustLoss::kGncTls);
  EXPECT_FALSE(solver.gnc_chordal_solves) << "the app's figures are measured without it";
  ASSERT_TRUE(params::set(app_schema(), &c, "loop_closure.solver_gnc_inner_iterations=0", &error)) << error;
  EXPECT_NE(c.check().find("loop_closure: solver: gnc_inner_iterations is 0"), std::string::npos) << c.check();
  ASSERT_TRUE(params::set(app_schema(), &c, "loop_closure.solver_gnc_chordal_solves=true", &error)) << error;
  ASSERT_TRUE(params::set(app_schema(), &c, "loop_closure.solver_gnc_cluster_trials=16", &error)) << error;
  ASSERT_TRUE(params::set(app_schema(), &c, "loop_closure.solver_chordal_weighting=isotropic", &error)) << error;
  EXPECT_TRUE(solver.gnc_cluster_screen);
  ASSERT_TRUE(params::set(app_schema(), &c, "loop_closure.solver_gnc_cluster_screen=false", &error)) << error;
  EXPECT_FALSE(solver.gnc_cluster_screen);
  ASSERT_TRUE(params::set(app_schema(), &c, "loop_closure.solver_chordal_solver=iterative", &error)) << error;
  EXPECT_EQ(solver.chordal_solver, backend::ChordalSolver::kIterative);
  EXPECT_EQ(c.check(), "");
  EXPECT_TRUE(solver.gnc_chordal_solves);
  EXPECT_EQ(solver.gnc_inner_iterations, 0);
  EXPECT_EQ(solver.gnc_cluster_trials, 16);
  EXPECT_EQ(solver.chordal_weighting, backend::ChordalWeighting::kIsotropic);
  EXPECT_FALSE(params::set(app_schema(), &c, "loop_closure.solver_threshold_sigma=0", &error));
  EXPECT_EQ(error, "loop_closure.solver_threshold_sigma: must be in (0, 1e3] sigma, got 0");
}

// The simulated camera's focal length follows its size however it is set (--set included), and its field of view
// when camera.hfov_deg is set; a bad field is refused by name.
TEST(AppParamsTest, TheSimulatedCameraFollowsItsSizeAndFieldOfView) {
  AppConfig c;
  EXPECT_NEAR(c.sim_camera().intrinsics.fx, 262.5, 1e-12);
  std::string error;
  ASSERT_TRUE(params::set(app_schema(), &c, "camera.width=640", &error)) << error;
  ASSERT_TRUE(params::set(app_schema(), &c, "camera.height=480", &error)) << error;
  messages::CameraIntrinsics k = c.sim_camera().intrinsics;
  EXPECT_NEAR(k.fx, 525.0, 1e-12);
  EXPECT_NEAR(k.fy, 525.0, 1e-12);
  EXPECT_NEAR(k.cx, 319.5, 1e-12);
  EXPECT_NEAR(k.cy, 239.5, 1e-12);
  ASSERT_TRUE(params::set(app_schema(), &c, "camera.hfov_deg=90", &error)) << error;
  k = c.sim_camera().intrinsics;
  EXPECT_NEAR(k.fx, 320.0, 1e-9);
  EXPECT_NEAR(k.fy, 320.0, 1e-9);
  EXPECT_TRUE(c.check().empty()) << c.check();
  ASSERT_TRUE(params::set(app_schema(), &c, "camera.hfov_deg=5", &error)) << error;
  EXPECT_NE(c.check().find("hfov_deg"), std::string::npos) << c.check();
}

}  // namespace
}  // namespace qsg::app

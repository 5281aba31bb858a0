// Tests of the qsg_traj_eval program as a user runs it: exit codes, printed figures and the JSON it writes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/support/test_data.h"
#include "tests/support/emulation.h"

namespace {

struct ToolRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

ToolRun run_tool(const std::string& arguments) {
  ToolRun run;
  const std::string command = std::string("'") + QSG_TRAJ_EVAL_PATH + "' " + arguments + " 2>&1";
  std::FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "qsg_traj_eval_cli_" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(TrajEvalCli, BadArgumentsAndFilesExitNonZero) {
  if (qsg::testing::running_emulated())
    GTEST_SKIP() << "emulated: under qemu-user a test cannot start the arm64 qsg_traj_eval (no binfmt_misc)";
  const std::string good = write_temp("good.txt",
                                      "# t tx ty tz qx qy qz qw\n"
                                      "1.00 0 0 0 0 0 0 1\n1.10 1 0 0 0 0 0 1\n1.20 1 1 0 0 0 0 1\n"
                                      "1.30 1 1 1 0 0 0 1\n");
  const std::string short_line = write_temp("short.txt", "1.00 0 0 0 0 0 0 1\n1.10 1 0 0 0 0 1\n");
  const std::string far = write_temp("far.txt", "100.0 0 0 0 0 0 0 1\n100.1 1 0 0 0 0 0 1\n");

  EXPECT_EQ(run_tool("").exit_code, 2);
  EXPECT_EQ(run_tool(good).exit_code, 2);
  EXPECT_EQ(run_tool(good + " " + good + " " + good).exit_code, 2);
  ToolRun r = run_tool(good + " " + good + " --align affine");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--align"), std::string::npos) << r.output;
  EXPECT_EQ(run_tool(good + " " + good + " --max-dt -0.1").exit_code, 2);
  EXPECT_EQ(run_tool(good + " " + good + " --max-dt 0.02s").exit_code, 2);
  EXPECT_EQ(run_tool(good + " " + good + " --rpe-delta 0").exit_code, 2);
  EXPECT_EQ(run_tool(good + " " + good + " --rpe-delta").exit_code, 2);
  EXPECT_EQ(run_tool(good + " " + good + " --frobnicate 1").exit_code, 2);

  r = run_tool(good + " /nonexistent/estimate.txt");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("/nonexistent/estimate.txt"), std::string::npos) << r.output;
  r = run_tool(good + " " + short_line);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("short.txt:2:"), std::string::npos) << r.output;  // the reader names file and line
  r = run_tool(good + " " + far);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("fewer than 3 associated"), std::string::npos) << r.output;
  EXPECT_EQ(run_tool(good + " " + good + " --json /nonexistent/dir/out.json").exit_code, 1);

  r = run_tool(good + " " + good + " --align none --max-dt 0");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("ATE  rmse 0.0000 m"), std::string::npos) << r.output;
}

TEST(TrajEvalCli, SharedPairWritesFigures) {
  if (qsg::testing::running_emulated())
    GTEST_SKIP() << "emulated: under qemu-user a test cannot start the arm64 qsg_traj_eval (no binfmt_misc)";
  QSG_REQUIRE_SHARED_DATA(groundtruth, "trajectories/groundtruth.txt");
  QSG_REQUIRE_SHARED_DATA(estimated, "trajectories/estimated.txt");
  const std::string json_path = ::testing::TempDir() + "qsg_traj_eval_cli_figures.json";
  std::remove(json_path.c_str());
  const ToolRun r = run_tool(groundtruth + " " + estimated + " --align sim3 --json " + json_path);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("alignment sim3"), std::string::npos) << r.output;

  std::ifstream file(json_path);
  ASSERT_TRUE(file.good()) << r.output;
  const nlohmann::json figures = nlohmann::json::parse(file, nullptr, false);
  ASSERT_TRUE(figures.is_array());
  bool found = false;
  for (const nlohmann::json& f : figures) {
    ASSERT_TRUE(f.contains("name") && f.contains("value") && f.contains("unit") && f.contains("conditions") &&
                f.contains("commit"));
    EXPECT_FALSE(f["commit"].get<std::string>().empty());
    if (f["name"] == "traj_eval.ate_rmse") {
      found = true;
      EXPECT_EQ(f["unit"], "m");
      // The band of the library's test on the same pair (trajectory_error_test.cc).
      EXPECT_GT(f["value"].get<double>(), 0.01);
      EXPECT_LT(f["value"].get<double>(), 0.05);
      EXPECT_NE(f["conditions"].get<std::string>().find("sim3"), std::string::npos);
    }
  }
  EXPECT_TRUE(found);
}

}  // namespace

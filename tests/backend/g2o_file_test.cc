// g2o pose graphs: the public benchmark smallGrid3D read and solved; malformed files refused with file and line.
#include "core/backend/g2o_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "tests/support/temp_dir.h"
#include "tests/support/test_data.h"

namespace qsg::backend {
namespace {

TEST(G2oFile, ReadsAndSolvesSmallGrid3D) {
  QSG_REQUIRE_SHARED_DATA(path, "pose_graphs/smallGrid3D.g2o");
  G2oPoseGraph g;
  std::string error;
  ASSERT_TRUE(read_g2o_pose_graph(path, &g, &error)) << error;
  EXPECT_EQ(g.poses.size(), 125u);
  EXPECT_EQ(g.edges.size(), 297u);
  EXPECT_EQ(g.num_loop_closures, 297u - 124u) << "an edge between consecutive ids is odometry";
  EXPECT_EQ(g.lines_skipped, 0u);
  for (const RelativePoseEdge& e : g.edges) ASSERT_TRUE(e.has_information);
  PoseGraphConfig config;
  config.loop_closure_loss = RobustLoss::kNone;
  config.max_iterations = 100;
  const PoseGraphResult r = optimize_pose_graph(config, g.poses, g.edges);
  ASSERT_TRUE(r.converged()) << r.message;
  std::printf("[ g2o ] smallGrid3D: cost %.6g -> %.6g in %d iterations\n", r.initial_cost, r.final_cost, r.iterations);
  EXPECT_LT(r.final_cost, 0.1 * r.initial_cost);
}

TEST(G2oFile, MalformedFilesNameTheLine) {
  qsg::testing::TempDir dir("qsg_g2o");
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir.file(name)) << text;
    return dir.file(name);
  };
  const std::string v0 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n", v1 = "VERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n";
  const std::string info = " 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n";
  G2oPoseGraph g;
  std::string error;
  EXPECT_TRUE(read_g2o_pose_graph(write("ok.g2o", "# c\n" + v0 + v1 + "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1" + info +
                                                      "FIX 0\n"),
                                  &g, &error))
      << error;
  EXPECT_EQ(g.edges.size(), 1u);
  EXPECT_EQ(g.lines_skipped, 1u);
  EXPECT_FALSE(read_g2o_pose_graph(dir.file("missing.g2o"), &g, &error));
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
  EXPECT_FALSE(read_g2o_pose_graph(write("short.g2o", v0 + "VERTEX_SE3:QUAT 1 1 0 0\n"), &g, &error));
  EXPECT_NE(error.find("short.g2o:2:"), std::string::npos) << error;
  EXPECT_FALSE(read_g2o_pose_graph(write("dup.g2o", v0 + v0), &g, &error));
  EXPECT_NE(error.find("given twice"), std::string::npos) << error;
  EXPECT_FALSE(read_g2o_pose_graph(write("nan.g2o", v0 + "VERTEX_SE3:QUAT 1 nan 0 0 0 0 0 1\n"), &g, &error));
  EXPECT_NE(error.find("nan.g2o:2:"), std::string::npos) << error;
  EXPECT_FALSE(read_g2o_pose_graph(write("unknown.g2o", v0 + "EDGE_SE3:QUAT 0 7 1 0 0 0 0 0 1" + info), &g, &error));
  EXPECT_NE(error.find("unknown vertex"), std::string::npos) << error;
  EXPECT_FALSE(read_g2o_pose_graph(write("info.g2o", v0 + v1 + "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0\n"), &g, &error));
  EXPECT_NE(error.find("21 information entries"), std::string::npos) << error;
  EXPECT_FALSE(read_g2o_pose_graph(
      write("neg.g2o", v0 + v1 + "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 -1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n"), &g,
      &error));
  EXPECT_NE(error.find("positive definite"), std::string::npos) << error;
}

// Translation and rotation blocks each positive definite, their coupling too large (x with roll: 3 against
// sqrt(1 * 1)): refused by default, read with the coupling zeroed and counted when asked. An indefinite block is
// refused either way.
TEST(G2oFile, AnIndefiniteCouplingIsRefusedOrDroppedWhenAsked) {
  qsg::testing::TempDir dir("qsg_g2o_coupling");
  const std::string v0 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n", v1 = "VERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n";
  const std::string coupled = "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 3 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n";
  const std::string bad_block = "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 2 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n";
  std::ofstream(dir.file("coupled.g2o")) << v0 << v1 << coupled;
  std::ofstream(dir.file("block.g2o")) << v0 << v1 << bad_block;
  G2oPoseGraph g;
  std::string error;
  EXPECT_FALSE(read_g2o_pose_graph(dir.file("coupled.g2o"), &g, &error));
  EXPECT_NE(error.find("drop_indefinite_coupling"), std::string::npos) << error;

  G2oReadOptions options;
  options.drop_indefinite_coupling = true;
  ASSERT_TRUE(read_g2o_pose_graph(dir.file("coupled.g2o"), &g, &error, options)) << error;
  ASSERT_EQ(g.edges.size(), 1u);
  EXPECT_EQ(g.couplings_dropped, 1u);
  const Eigen::Matrix<double, 6, 6>& m = g.edges[0].information;
  EXPECT_TRUE((m.topRightCorner<3, 3>().isZero()));
  EXPECT_TRUE((m.bottomLeftCorner<3, 3>().isZero()));
  EXPECT_DOUBLE_EQ(m(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(m(3, 3), 0.25) << "the rotation block keeps its precision (halved rows and columns)";

  EXPECT_FALSE(read_g2o_pose_graph(dir.file("block.g2o"), &g, &error, options));
  EXPECT_NE(error.find("block.g2o:3:"), std::string::npos) << error;
}

// cubicle, the real one: every edge refused is one whose coupling is what makes it indefinite.
TEST(G2oFile, CubicleReadsWithItsIndefiniteCouplingsDropped) {
  QSG_REQUIRE_SHARED_DATA(path, "pose_graphs/cubicle.g2o");
  G2oPoseGraph g;
  std::string error;
  EXPECT_FALSE(read_g2o_pose_graph(path, &g, &error));
  G2oReadOptions options;
  options.drop_indefinite_coupling = true;
  ASSERT_TRUE(read_g2o_pose_graph(path, &g, &error, options)) << error;
  EXPECT_EQ(g.poses.size(), 5750u);
  EXPECT_EQ(g.edges.size(), 16869u);
  EXPECT_EQ(g.couplings_dropped, 5021u);
}

}  // namespace
}  // namespace qsg::backend

// The app maps from odometry: the simulator's drift by default, ground truth, a TUM estimate, a live pose stream
// from qsg_pose_send; frames without a pose are dropped and counted; bad odometry config is refused by name.
#include <gtest/gtest.h>

#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "drivers/replay/trajectory.h"
#include "firmware_app/pipeline.h"
#include "tests/support/emulation.h"

extern char** environ;

namespace qsg::app {
namespace {

AppConfig small_config(const std::string& name) {
  AppConfig c;
  c.output_dir = ::testing::TempDir() + "/qsg_odometry_" + name;
  c.building.num_rooms = 4;
  c.building.seed = 3;
  c.camera.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  c.snapshot_interval_s = 1e6;
  c.telemetry_interval_s = 1e6;
  return c;
}

void run_to_end(Pipeline& p) {
  while (p.step()) {
  }
  std::string error;
  ASSERT_TRUE(p.finish(&error)) << error;
}

TEST(OdometryPipelineTest, TheSimulatedRobotMapsFromDriftingOdometryByDefault) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  AppConfig config = small_config("drift");
  config.loop_closure.enabled = true;
  // One short tour: its revisits register by objects, rarely refined by ICP; this test is about the wiring, so
  // coarse closures are proposed too (lc_eval measures the default on longer tours).
  config.loop_closure.detector.propose_unrefined_objects = true;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  EXPECT_EQ(p.odometry().kind(), OdometrySourceKind::kSimDrift);
  run_to_end(p);
  EXPECT_GT(p.counters().keyframes_integrated, 100u);
  EXPECT_EQ(p.counters().frames_without_pose, 0u);
  EXPECT_EQ(p.odometry().buffer().counters().rejected(), 0u);
  // Scored against the truth the simulator kept: the map was built from poses that drift.
  const metrics::TrajectoryError& e = p.trajectory_error();
  ASSERT_TRUE(e.ok) << e.error;
  EXPECT_GT(e.ate_rmse_m, 0.01);
  EXPECT_LT(e.ate_rmse_m, 2.0);
  EXPECT_EQ(e.associated, p.frontend().agents().chain_size());
  // The pose graph holds the sparsified chain; with no loop closure the odometry is already consistent.
  EXPECT_EQ(p.pose_graph().nodes, p.frontend().agents().chain_size());
  EXPECT_EQ(p.pose_graph().odometry_edges + 1, p.pose_graph().nodes);
  EXPECT_TRUE(p.pose_graph().solve.poses_updated()) << p.pose_graph().solve.message;
  EXPECT_LT(p.pose_graph().solve.final_cost, 1e-9);
  EXPECT_GT(p.counters().agent_sparsified, 0u);
  // The tour revisits its rooms: agents are described, loop closures verified (true ones among them) and the
  // deformation graph solved; the estimate written is the optimized one, the odometry beside it.
  EXPECT_GT(p.counters().agents_described, 10u);
  EXPECT_GE(p.counters().loop_closures, 1u);
  EXPECT_GE(p.counters().loop_closures_true, 1u);
  EXPECT_GE(p.counters().graph_optimizations, 1u);
  EXPECT_EQ(p.counters().graph_optimization_failures, 0u);
  // Every local map refused is counted under one reason.
  const loop_closure::DetectorCounters& dc = p.backend_stage().detector().counters();
  EXPECT_GT(dc.local_map_refused, 0u);
  EXPECT_EQ(dc.local_map_refused, dc.local_map_no_overlap + dc.local_map_degenerate + dc.local_map_correction);
  EXPECT_TRUE(p.odometry_trajectory_error().ok);
  EXPECT_TRUE(std::filesystem::exists(small_config("drift").output_dir + "/trajectory_odometry.txt"));
  EXPECT_TRUE(std::filesystem::exists(small_config("drift").output_dir + "/trajectory_estimate.txt"));
  EXPECT_TRUE(std::filesystem::exists(small_config("drift").output_dir + "/trajectory_ground_truth.txt"));
  // loop_closure.map_in_corrected_frame (on by default): after a solve the frontend maps in its correction. The
  // nodes added since carry it, each mapped at the correction times its odometric pose (the odometry's own pose,
  // written to trajectory_odometry.txt); the last one in the correction in use at the end. (Whether that puts them
  // nearer the truth depends on the closures of the moment: on this one short tour with coarse closures it does
  // not; lc_eval measures it on longer tours.)
  ASSERT_TRUE(config.loop_closure.map_in_corrected_frame);
  EXPECT_GE(p.frame_corrections(), 1u);
  replay::Trajectory odometric;
  ASSERT_TRUE(replay::read_tum_trajectory(config.output_dir + "/trajectory_odometry.txt", &odometric, &error)) << error;
  const agents::AgentLayer& agents = p.frontend().agents();
  ASSERT_EQ(odometric.size(), agents.chain_size());
  double moved_m = 0.0;
  std::size_t corrected = 0;
  for (std::size_t k = 0; k < agents.chain_size(); ++k) {
    const agents::ChainNode& n = agents.chain(k);
    ASSERT_EQ(odometric[k].time_ns, static_cast<std::int64_t>(n.time_ns));
    EXPECT_LT((agents::odometric_pose(n).translation() - odometric[k].world_t_body_m).norm(), 1e-4) << "node " << k;
    if (n.frame_is_identity()) continue;
    ++corrected;
    moved_m += (agents::mapped_pose(n).translation() - odometric[k].world_t_body_m).norm();
  }
  ASSERT_GT(corrected, 10u);
  EXPECT_GT(moved_m / static_cast<double>(corrected), 0.01) << "the corrected nodes are mapped off the odometry";
  const agents::ChainNode& last = agents.chain(agents.chain_size() - 1);
  EXPECT_LT((agents::mapped_pose(last).matrix() - (p.map_T_odom() * agents::odometric_pose(last)).matrix()).norm(),
            1e-9)
      << "the last node is mapped in the correction in use";
}

// The largest distance between a room node and the mean of its places in the final graph (-1: no room with places).
double worst_room_off_its_places(const scene_graph::SceneGraph& g) {
  double worst = -1.0;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kRoom) return;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::size_t count = 0;
    g.for_each_child(n.id, [&](scene_graph::NodeId child) {
      if (const scene_graph::PlaceAttributes* p = g.place(child)) {
        sum += p->position_m;
        ++count;
      }
    });
    if (count == 0) return;
    worst = std::max(worst, (g.room(n.id)->position_m - sum / static_cast<double>(count)).norm());
  });
  return worst;
}

// loop_closure.rooms_after_correction: the final rooms are found on the corrected places, so each room node sits at
// the mean of its places as the correction put them. Off, the rooms are found as mapped and moved with the
// deformation, which does not move them with their places exactly.
TEST(OdometryPipelineTest, RoomsFoundAfterTheCorrectionSitOnTheirCorrectedPlaces) {
  for (const bool after : {true, false}) {
    SCOPED_TRACE(after ? "rooms after the correction" : "rooms as mapped, moved");
    runtime::SteppedClock clock;
    Pipeline p;
    std::string error;
    AppConfig config = small_config(after ? "rooms_after" : "rooms_moved");
    config.loop_closure.enabled = true;
    config.loop_closure.detector.propose_unrefined_objects = true;  // as above: closures on one short tour
    config.loop_closure.reconcile = false;
    config.loop_closure.rooms_after_correction = after;
    ASSERT_TRUE(p.init(config, &clock, &error)) << error;
    run_to_end(p);
    ASSERT_GE(p.counters().graph_optimizations, 1u) << "no correction to test against";
    const double worst = worst_room_off_its_places(p.graph());
    ASSERT_GE(worst, 0.0) << "no room";
    if (after)
      EXPECT_LT(worst, 1e-6);
    else
      EXPECT_GT(worst, 1e-4);
  }
}

TEST(OdometryPipelineTest, GroundTruthAndATumFileOfItMapWithoutError) {
  AppConfig c = small_config("gt");
  c.odometry.source = OdometrySourceKind::kGroundTruth;
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  const std::string tum = c.output_dir + "/body_truth.txt";
  ASSERT_TRUE(replay::write_tum_trajectory(tum, p.ground_truth(), &error)) << error;
  run_to_end(p);
  ASSERT_TRUE(p.trajectory_error().ok) << p.trajectory_error().error;
  EXPECT_LT(p.trajectory_error().ate_max_m, 1e-6);

  // The same path replayed from a file as the robot's estimate (TUM keeps 4 decimals of a second, 0.1 mm).
  AppConfig t = small_config("tum");
  t.odometry.source = OdometrySourceKind::kTum;
  t.odometry.tum_path = tum;
  t.loop_closure.enabled = false;  // this compares the input paths (loop closures would add their own noise)
  runtime::SteppedClock clock2;
  Pipeline q;
  ASSERT_TRUE(q.init(t, &clock2, &error)) << error;
  run_to_end(q);
  EXPECT_EQ(q.odometry().kind(), OdometrySourceKind::kTum);
  ASSERT_TRUE(q.trajectory_error().ok) << q.trajectory_error().error;
  EXPECT_LT(q.trajectory_error().ate_max_m, 0.002);
  EXPECT_GE(q.counters().keyframes_integrated + 2, p.counters().keyframes_integrated);
}

TEST(OdometryPipelineTest, FramesPastTheEndOfTheOdometryAreDroppedAndCounted) {
  AppConfig c = small_config("short");
  runtime::SteppedClock clock0;
  Pipeline probe;
  std::string error;
  ASSERT_TRUE(probe.init(c, &clock0, &error)) << error;
  replay::Trajectory half(probe.ground_truth().begin(),
                          probe.ground_truth().begin() + static_cast<std::ptrdiff_t>(probe.ground_truth().size() / 2));
  const std::string tum = c.output_dir + "/first_half.txt";
  ASSERT_TRUE(replay::write_tum_trajectory(tum, half, &error)) << error;
  c.odometry.source = OdometrySourceKind::kTum;
  c.odometry.tum_path = tum;
  runtime::SteppedClock clock;
  Pipeline p;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  run_to_end(p);
  EXPECT_GT(p.counters().frames_without_pose, 100u);
  EXPECT_EQ(p.counters().frames_without_pose, p.odometry().counters().frames_dropped());
  EXPECT_GT(p.counters().keyframes_integrated, 50u) << "what had a pose was mapped";
}

// A robot's estimate with corrupt lines (truncated, NaN, a quaternion far from unit length) maps from the rest;
// every skipped line is counted. A file with no valid line at all stops start-up, saying why.
TEST(OdometryPipelineTest, MalformedLinesOfATumEstimateAreSkippedAndCounted) {
  AppConfig c = small_config("tum_corrupt");
  runtime::SteppedClock clock0;
  Pipeline probe;
  std::string error;
  ASSERT_TRUE(probe.init(c, &clock0, &error)) << error;
  const std::string clean = c.output_dir + "/clean.txt";
  ASSERT_TRUE(replay::write_tum_trajectory(clean, probe.ground_truth(), &error)) << error;
  std::vector<std::string> lines;
  {
    std::ifstream in(clean);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  ASSERT_GT(lines.size(), 100u);
  lines[20] = lines[20].substr(0, lines[20].size() / 2);  // truncated
  lines[40] += " 7";                                      // a ninth field
  lines[60] = "12.5 nan 0 0 0 0 0 1";
  lines[80] = "13.5 0 0 0 0 0 0 3";  // |q| = 3
  const std::string corrupt = c.output_dir + "/corrupt.txt";
  {
    std::ofstream out(corrupt);
    for (const std::string& line : lines) out << line << "\n";
  }
  c.odometry.source = OdometrySourceKind::kTum;
  c.odometry.tum_path = corrupt;
  c.duration_s = 30.0;  // the corrupt lines lie in the first seconds; the rest of the tour adds nothing here
  runtime::SteppedClock clock;
  Pipeline p;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  EXPECT_EQ(p.odometry().counters().file_lines_skipped, 4u);
  run_to_end(p);
  EXPECT_GT(p.counters().keyframes_integrated, 50u);
  EXPECT_EQ(p.counters().frames_without_pose, 0u);
  ASSERT_TRUE(p.trajectory_error().ok) << p.trajectory_error().error;
  EXPECT_LT(p.trajectory_error().ate_max_m, 0.01) << "a missing sample is interpolated over";

  const std::string garbage = c.output_dir + "/garbage.txt";
  std::ofstream(garbage) << "not a trajectory\n1 2 3\n";
  c.output_dir += "_garbage";
  c.odometry.tum_path = garbage;
  runtime::SteppedClock clock2;
  Pipeline q;
  EXPECT_FALSE(q.init(c, &clock2, &error));
  EXPECT_NE(error.find("no valid pose"), std::string::npos) << error;
  EXPECT_NE(error.find("2 malformed lines"), std::string::npos) << error;
}

// A live stream that never sends anything is a logged fault (a silence) once silence_fault_s has passed, and
// the frames that found no pose are dropped and counted; the run still ends cleanly.
TEST(OdometryPipelineTest, AStreamThatNeverSendsIsASilenceFault) {
  AppConfig c = small_config("mute");
  c.duration_s = 4.0;
  c.odometry.source = OdometrySourceKind::kStream;
  c.odometry.stream_transport = "unix";
  c.odometry.stream_unix_path = c.output_dir + "/mute.sock";
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  run_to_end(p);
  EXPECT_EQ(p.odometry().counters().samples_read, 0u);
  EXPECT_EQ(p.odometry().counters().silences, 1u) << "one fault, logged once, not one per tick";
  EXPECT_GT(p.counters().frames_without_pose, 10u);
  EXPECT_EQ(p.counters().keyframes_integrated, 0u);
}

TEST(OdometryPipelineTest, BadOdometryConfigIsRefusedByName) {
  AppConfig c = small_config("bad");
  c.odometry.source = OdometrySourceKind::kTum;
  EXPECT_NE(c.check().find("tum_path"), std::string::npos) << c.check();
  c = small_config("bad");
  c.driver = Driver::kV4l2;
  c.odometry.source = OdometrySourceKind::kSimDrift;
  EXPECT_NE(c.check().find("sim_drift"), std::string::npos) << c.check();
  c = small_config("bad");
  c.odometry.stream_transport = "tcp";
  EXPECT_NE(c.check().find("stream_transport"), std::string::npos) << c.check();
  c = small_config("bad");
  c.odometry.body_q_camera_xyzw[3] = 2.0;
  EXPECT_NE(c.check().find("body_q_camera_xyzw"), std::string::npos) << c.check();
  c = small_config("bad");
  c.odometry.buffer.max_speed_m_per_s = 0.0;
  EXPECT_NE(c.check().find("max_speed_m_per_s"), std::string::npos) << c.check();
  // A missing TUM file stops start-up with its name.
  c = small_config("bad");
  c.odometry.source = OdometrySourceKind::kTum;
  c.odometry.tum_path = "/nonexistent/estimate.txt";
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  EXPECT_FALSE(p.init(c, &clock, &error));
  EXPECT_NE(error.find("/nonexistent/estimate.txt"), std::string::npos) << error;
}

// End to end on the host: the app listens on a Unix datagram socket, qsg_pose_send streams the tour's true body
// path at its own timestamps, the app (on the wall clock) maps from it.
TEST(OdometryPipelineTest, ALivePoseStreamFromQsgPoseSendFeedsTheMap) {
  if (qsg::testing::running_emulated())
    GTEST_SKIP() << "under qemu-user a test cannot start the arm64 qsg_pose_send (no binfmt_misc), and the app on "
                    "the wall clock could not keep up with a real-time sender";
  AppConfig c = small_config("stream");
  runtime::SteppedClock probe_clock;
  Pipeline probe;
  std::string error;
  ASSERT_TRUE(probe.init(c, &probe_clock, &error)) << error;
  const std::string tum = c.output_dir + "/body_truth.txt";
  ASSERT_TRUE(replay::write_tum_trajectory(tum, probe.ground_truth(), &error)) << error;

  c.lockstep = false;
  c.duration_s = 5.0;
  c.odometry.source = OdometrySourceKind::kStream;
  c.odometry.stream_transport = "unix";
  c.odometry.stream_unix_path = c.output_dir + "/pose.sock";
  runtime::WallClock clock;
  Pipeline p;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  std::vector<std::string> args = {QSG_POSE_SEND_PATH, tum, "--unix", c.odometry.stream_unix_path, "--speed", "1"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ), 0);
  while (p.step()) {
  }
  ASSERT_TRUE(p.finish(&error)) << error;
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_EQ(p.odometry().kind(), OdometrySourceKind::kStream);
  // 30 poses a second for 5 s; a slow build (sanitizers) integrates fewer keyframes, never none.
  EXPECT_GT(p.odometry().counters().samples_read, 60u);
  EXPECT_EQ(p.odometry().counters().source_bad, 0u);
  EXPECT_GT(p.counters().keyframes_integrated, 3u);
  // The sender starts a moment after the app: at most the first frames find no pose.
  EXPECT_LE(p.counters().frames_without_pose, 3u);
  ASSERT_TRUE(p.trajectory_error().ok) << p.trajectory_error().error;
  EXPECT_LT(p.trajectory_error().ate_max_m, 0.01);
}

}  // namespace
}  // namespace qsg::app

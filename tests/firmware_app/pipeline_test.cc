// The app's pipeline in lockstep on the simulated robot: deterministic, no heap allocation per tick in steady
// state, every store below its capacity, outputs written atomically and readable.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <tuple>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/reconstruction/ply_writer.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "drivers/render/ray_scene.h"
#include "drivers/replay/dataset_replay.h"
#include "drivers/sim/exploration.h"
#include "drivers/v4l2/fake_v4l2_device.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/world_query.h"
#include "firmware_app/graph_picture.h"
#include "firmware_app/pipeline.h"
#include "tests/support/allocation_counter.h"
#include "tests/firmware_app/run_app.h"
#include "tests/support/emulation.h"
#include "tests/support/test_data.h"

extern char** environ;

namespace qsg::app {
namespace {

AppConfig small_config(const std::string& name) {
  AppConfig c;
  c.output_dir = ::testing::TempDir() + "/qsg_pipeline_" + name;
  c.building.num_rooms = 4;
  c.building.seed = 3;
  c.camera.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  c.snapshot_interval_s = 1e6;  // snapshots serialise the graph (heap): tested separately
  c.telemetry_interval_s = 1e6;
  return c;
}

// The loop's real-time path alone. Loop closure stays on, so its part on the loop (each agent's keyframe copied
// into a slot, the control points) is measured, but no agent is described (the horizon is past the run): detection
// runs on the backend thread in a real run and uses the heap where its libraries do (ORB features through OpenCV,
// the Ceres solves; its own stores are reserved and faulted in at start-up), and lockstep would run it inline here.
AppConfig real_time_path_config(const std::string& name) {
  AppConfig c = small_config(name);
  c.loop_closure.horizon_s = 3600.0;
  return c;
}

TEST(PipelineTest, LockstepRunIsAllocationFreeInSteadyStateAndWithinCapacity) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(real_time_path_config("steady"), &clock, &error)) << error;
  // Warm-up: the first keyframes allocate nothing either, but give the stores time to reach steady use.
  int steps = 0;
  while (p.counters().keyframes_integrated < 20 && p.step()) ++steps;
  ASSERT_GE(p.counters().keyframes_integrated, 20u);
  const std::uint64_t before = p.counters().keyframes_integrated;
  const std::uint64_t passes_before = p.counters().door_passes;
  EXPECT_NO_ALLOCATIONS({
    for (int k = 0; k < 2000 && p.step(); ++k) {
    }
  });
  EXPECT_GE(p.counters().keyframes_integrated, before + 30) << "the measured steps must include keyframes";
  // ... and online door passes (the backend runs inline in lockstep), with the wall map painted every keyframe.
  EXPECT_GT(p.counters().door_passes, passes_before);
  EXPECT_GT(p.counters().blocks_painted, 0u);
  p.online_doors().for_each_resource([](const memory::ResourceStats& s) {
    EXPECT_EQ(s.failed, 0u) << s.name;
    EXPECT_LE(s.high_water, s.capacity) << s.name;
  });
  EXPECT_EQ(p.counters().keyframes_refused, 0u);
  EXPECT_EQ(p.counters().agent_refused, 0u);
  // Every store of the graph and of the reconstruction stayed below capacity, nothing was refused.
  p.graph().for_each_resource([](const memory::ResourceStats& s) {
    EXPECT_EQ(s.failed, 0u) << s.name;
    EXPECT_LE(s.high_water, s.capacity) << s.name;
  });
  EXPECT_LT(p.reconstruction().active_blocks(), p.reconstruction().capacities().max_blocks);
  EXPECT_EQ(p.reconstruction().counters().blocks_refused, 0u);
  EXPECT_EQ(p.reconstruction().counters().mesh_overflow, 0u);
  // With the stepped clock as the cost clock nothing overruns: the schedule is exactly the table's.
  for (std::size_t i = 0; i < p.scheduler().num_tasks(); ++i) {
    EXPECT_EQ(p.scheduler().task(i).stats.overruns, 0u) << p.scheduler().task(i).budget.name;
    EXPECT_EQ(p.scheduler().task(i).stats.slips, 0u) << p.scheduler().task(i).budget.name;
  }
}

// Minor page faults this thread has taken so far (Linux: RUSAGE_THREAD; lockstep runs every stage on it).
std::uint64_t thread_minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return static_cast<std::uint64_t>(usage.ru_minflt);
}

// The page-fault counterpart of the allocation test above: every arena is touched when it is created
// (core/memory/arena.h) and the loop allocates nothing, so after a warm-up a stretch of ticks (keyframes, frontend
// updates, online door passes and room updates) takes next to no page fault. Counted, not timed. The bound leaves
// room for the few code pages a path runs for the first time and for the stack: 8 faults on the x86 host, and 382
// over the same stretch with Arena::create's pre-faulting taken out (the stores' pages as they first fill).
TEST(PipelineTest, LockstepRunTakesNoPageFaultsAfterStartUp) {
  if (qsg::testing::running_emulated()) GTEST_SKIP() << "under qemu-user the page faults counted are the emulator's";
  if (qsg::testing::address_sanitizer()) GTEST_SKIP() << "AddressSanitizer maps its shadow memory on first use";
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(real_time_path_config("page_faults"), &clock, &error)) << error;
  // Warm-up as long as the measured stretch: every stage runs, and the stack reaches its depth.
  for (int k = 0; k < 2000 && p.step(); ++k) {
  }
  const std::uint64_t keyframes = p.counters().keyframes_integrated;
  const std::uint64_t passes = p.counters().door_passes;
  const std::uint64_t faults_before = thread_minor_faults();
  for (int k = 0; k < 2000 && p.step(); ++k) {
  }
  const std::uint64_t faults = thread_minor_faults() - faults_before;
  std::printf("minor page faults over 2000 ticks after the warm-up: %llu\n", static_cast<unsigned long long>(faults));
  EXPECT_GE(p.counters().keyframes_integrated, keyframes + 30) << "the measured steps must include keyframes";
  EXPECT_GT(p.counters().door_passes, passes);
  EXPECT_LE(faults, 64u) << "the real-time path faulted pages in after start-up";
}

TEST(PipelineTest, TwoLockstepRunsAreIdentical) {
  std::string error, a, b;
  for (std::string* out : {&a, &b}) {
    runtime::SteppedClock clock;
    Pipeline p;
    ASSERT_TRUE(p.init(small_config("determinism"), &clock, &error)) << error;
    for (int k = 0; k < 1500 && p.step(); ++k) {
    }
    *out = scene_graph::write_spark_dsg_json(p.graph());
    *out += std::to_string(p.reconstruction().counters().blocks_meshed) + " " +
            std::to_string(p.reconstruction().active_blocks());
  }
  EXPECT_EQ(a, b);
}

TEST(PipelineTest, StopWritesFinalOutputsAndSnapshotsReplaceAtomically) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  AppConfig config = small_config("outputs");
  config.snapshot_interval_s = 2.0;
  std::filesystem::remove_all(config.output_dir);
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  for (int k = 0; k < 1200 && p.step(); ++k) {  // 6 s of 200 Hz ticks
  }
  p.request_stop();
  EXPECT_FALSE(p.step());
  EXPECT_TRUE(p.done());
  EXPECT_GE(p.counters().snapshots_written, 2u);
  EXPECT_EQ(p.counters().snapshot_failures, 0u);
  ASSERT_TRUE(p.finish(&error)) << error;
  for (const char* name : {"scene_graph.json", "scene_graph_snapshot.json", "mesh.ply", "top_down.png"})
    EXPECT_TRUE(std::filesystem::exists(config.output_dir + "/" + name)) << name;
  EXPECT_FALSE(std::filesystem::exists(config.output_dir + "/scene_graph.json.tmp")) << "no temporary file left";
  // The outputs read back: the graph through the validating importer, the mesh through the PLY reader.
  scene_graph::SceneGraph graph;
  ASSERT_TRUE(graph.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error));
  const scene_graph::JsonImportResult r =
      scene_graph::read_spark_dsg_json_file(config.output_dir + "/scene_graph.json", graph);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(graph.num_nodes(), p.graph().num_nodes());
  reconstruction::Mesh mesh;
  ASSERT_TRUE(reconstruction::read_ply(config.output_dir + "/mesh.ply", &mesh, &error)) << error;
  EXPECT_GT(mesh.triangles.size(), 1000u);
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Every final output replaces its file by rename (issue 36): a hard link to the previous file keeps the previous
// content, which a write in place would have overwritten; no temporary file is left.
TEST(PipelineTest, FinalOutputsReplaceTheirFilesAtomically) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  AppConfig config = small_config("atomic_outputs");
  std::filesystem::remove_all(config.output_dir);
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  const std::vector<std::string> outputs = {"scene_graph.json", "mesh.ply", "top_down.png", "trajectory_estimate.txt",
                                            "trajectory_ground_truth.txt"};
  for (const std::string& name : outputs) {
    std::ofstream(config.output_dir + "/" + name) << "previous " << name;
    std::filesystem::create_hard_link(config.output_dir + "/" + name, config.output_dir + "/old_" + name);
  }
  for (int k = 0; k < 600 && p.step(); ++k) {
  }
  p.request_stop();
  EXPECT_FALSE(p.step());
  ASSERT_TRUE(p.finish(&error)) << error;
  for (const std::string& name : outputs) {
    EXPECT_EQ(file_text(config.output_dir + "/old_" + name), "previous " + name) << name << " was written in place";
    EXPECT_NE(file_text(config.output_dir + "/" + name), "previous " + name) << name << " was not replaced";
    EXPECT_FALSE(std::filesystem::exists(config.output_dir + "/" + name + ".tmp")) << name;
  }
  cv::Mat picture = cv::imread(config.output_dir + "/top_down.png");
  EXPECT_FALSE(picture.empty());
}

// One output that cannot be written (here top_down.png is a folder) is a named error, and every other output is
// still written.
TEST(PipelineTest, AnOutputThatFailsDoesNotTakeTheOthersDown) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  AppConfig config = small_config("picture_fails");
  std::filesystem::remove_all(config.output_dir);
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  std::filesystem::create_directories(config.output_dir + "/top_down.png/occupied");
  for (int k = 0; k < 600 && p.step(); ++k) {
  }
  p.request_stop();
  EXPECT_FALSE(p.step());
  EXPECT_FALSE(p.finish(&error));
  EXPECT_NE(error.find("top_down.png"), std::string::npos) << error;
  for (const char* name : {"scene_graph.json", "mesh.ply", "trajectory_estimate.txt"})
    EXPECT_TRUE(std::filesystem::is_regular_file(config.output_dir + "/" + name)) << name;
  EXPECT_FALSE(std::filesystem::exists(config.output_dir + "/top_down.png.tmp"));
}

// Regression (issue 36): one ground-truth pose 20 km off framed the replay's picture at 100,000 x 100,000 px (30 GB)
// and aborted the app at the very end. The picture's scale drops to keep it within its side limit.
TEST(GraphPictureTest, AFarOffPoseShrinksThePictureInsteadOfGrowingIt) {
  scene_graph::SceneGraph graph;
  std::string error;
  ASSERT_TRUE(graph.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) << error;
  const std::string path = ::testing::TempDir() + "/qsg_far_pose_top_down.png";
  std::vector<Eigen::Vector3d> trajectory = {{0.0, 0.0, 0.0}, {1.0, 1.0, 0.0}, {20000.0, 20000.0, 0.0}, {2.0, 1.0, 0.0}};
  ASSERT_TRUE(write_graph_picture(graph, world::World(), trajectory, path, &error)) << error;
  cv::Mat picture = cv::imread(path);
  ASSERT_FALSE(picture.empty());
  EXPECT_LE(picture.cols, GraphPictureConfig{}.max_side_px);
  EXPECT_LE(picture.rows, GraphPictureConfig{}.max_side_px);
  EXPECT_GT(picture.cols, 1000);  // still the full frame, at a smaller scale
  GraphPictureConfig small;
  small.max_side_px = 512;
  ASSERT_TRUE(write_graph_picture(graph, world::World(), trajectory, path, &error, small)) << error;
  picture = cv::imread(path);
  EXPECT_LE(picture.cols, 512);
  EXPECT_LE(picture.rows, 512);
  // Non-finite or absurd poses are left out of the frame rather than poisoning it.
  trajectory.push_back({std::nan(""), 1.0, 0.0});
  trajectory.push_back({-1e308, 1e308, 0.0});
  EXPECT_TRUE(write_graph_picture(graph, world::World(), trajectory, path, &error, small)) << error;
  small.max_side_px = 10;
  EXPECT_FALSE(write_graph_picture(graph, world::World(), trajectory, path, &error, small));
  EXPECT_NE(error.find("max_side_px must be in [256, 16384]"), std::string::npos) << error;
  std::remove(path.c_str());
}

// When the run finishes, doors found on the final surface close place edges, and the rooms are found again.
TEST(PipelineTest, DoorsFoundWhenTheRunFinishesCloseEdgesAndRoomsFollow) {
  for (const bool doors : {true, false}) {
    runtime::SteppedClock clock;
    Pipeline p;
    std::string error;
    AppConfig config = small_config(doors ? "doors" : "no_doors");
    config.doors_at_finish = doors;
    config.doors_online = false;  // the final stage alone (the online stage has its own test)
    ASSERT_TRUE(p.init(config, &clock, &error)) << error;
    while (p.step()) {
    }
    const std::uint64_t updates = p.counters().backend_updates;
    ASSERT_TRUE(p.finish(&error)) << error;
    EXPECT_EQ(p.counters().door_failures, 0u);
    std::size_t closed = 0;
    p.graph().for_each_edge([&](const scene_graph::EdgeRecord& e) {
      closed += e.info.weighted && e.info.weight <= 0.0 ? 1 : 0;
    });
    // Closed: the edges through the doors and those through walls (the final stage's sight lines).
    EXPECT_EQ(closed, p.counters().door_edges_closed + p.counters().edges_through_walls);
    EXPECT_GT(p.counters().rooms, 0u);
    EXPECT_GT(p.counters().backend_updates, updates) << "the final room update ran";
    if (doors) {
      // The 4-room building has a door per room: they are found and close place edges (a door line that no place
      // edge crosses, at a gap in the mapped walls, closes none).
      EXPECT_GE(p.counters().doors, 2u);
      EXPECT_GE(p.counters().door_edges_closed, 2u);
    } else {
      EXPECT_EQ(p.counters().doors, 0u);
      EXPECT_EQ(p.counters().edges_through_walls, 0u);
      EXPECT_EQ(p.counters().rooms_merged_visible, 0u);
      EXPECT_EQ(closed, 0u);
    }
  }
}

TEST(PipelineTest, OnlineDoorsCloseEdgesForTheRoomsDuringTheRun) {
  for (const bool online : {true, false}) {
    runtime::SteppedClock clock;
    Pipeline p;
    std::string error;
    AppConfig config = small_config(online ? "online_doors" : "no_online_doors");
    config.doors_at_finish = false;
    config.doors_online = online;
    ASSERT_TRUE(p.init(config, &clock, &error)) << error;
    // Off, a part of the run shows it (the test runs under qemu too).
    for (int k = 0; (online || k < 3000) && p.step(); ++k) {
    }
    EXPECT_GT(p.counters().backend_updates, 0u);
    if (online) {
      EXPECT_GT(p.counters().rooms, 0u);
      // The 4-room building's doors are found in the windows around the robot and the room finder reads the place
      // edges through them as closed (the graph's weights stay as the places layer wrote them).
      EXPECT_GE(p.counters().door_passes, p.counters().backend_updates / 5);  // every 4th update
      EXPECT_GE(p.counters().online_doors, 2u);
      EXPECT_EQ(p.online_doors().doors().size(), p.counters().online_doors);
      EXPECT_GT(p.counters().blocks_painted, 0u);
      EXPECT_GT(p.counters().door_pass_max_us, 0u);
      std::size_t closed = 0;
      p.graph().for_each_edge([&](const scene_graph::EdgeRecord& e) {
        const scene_graph::PlaceAttributes* a = p.graph().place(e.source);
        const scene_graph::PlaceAttributes* b = p.graph().place(e.target);
        if (a != nullptr && b != nullptr && p.online_doors().doors().closes(a->position_m, b->position_m)) ++closed;
        EXPECT_FALSE(e.info.weighted && e.info.weight <= 0.0) << "online doors do not write the graph";
      });
      EXPECT_GE(closed, 2u);
    } else {
      EXPECT_FALSE(p.online_doors().initialized());
      EXPECT_EQ(p.counters().door_passes, 0u);
      EXPECT_EQ(p.counters().blocks_painted, 0u);
    }
    ASSERT_TRUE(p.finish(&error)) << error;
  }
}

TEST(PipelineTest, RunsOnAV4l2DepthAndColourPair) {
  // Two fake nodes of one RealSense-style camera (shared clock): a wall 2 m ahead in every depth frame.
  v4l2::FakeClock fake_clock;
  v4l2::FakeV4l2Device::Config dc, cc;
  dc.path = "/dev/fake_depth";
  dc.formats = {{v4l2::FakeV4l2Device::kZ16, 160, 120}};
  cc.path = "/dev/fake_colour";
  cc.formats = {{v4l2::FakeV4l2Device::kYuyv, 160, 120}};
  dc.frame_period_ns = cc.frame_period_ns = 100000000;  // 10 Hz
  v4l2::FakeV4l2Device depth(dc, &fake_clock), colour(cc, &fake_clock);
  depth.set_painter([](const v4l2::FakeFrameInfo& info, std::uint8_t* data, std::size_t) {
    for (int v = 0; v < info.height_px; ++v)
      for (int u = 0; u < info.width_px; ++u) {
        const std::uint16_t mm = 2000;
        std::memcpy(data + v * info.bytes_per_line + 2 * u, &mm, 2);
      }
  });
  AppConfig c = small_config("v4l2");
  c.driver = Driver::kV4l2;
  c.v4l2.depth_device = dc.path;
  c.v4l2.colour_device = cc.path;
  c.v4l2.width = 160;
  c.v4l2.height = 120;
  c.duration_s = 3.0;
  runtime::SteppedClock clock;
  Pipeline p;
  p.set_v4l2_syscalls(&depth, &colour);
  std::string error;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  for (int k = 0; k < 2000; ++k) {
    fake_clock.now_ns += p.scheduler().tick_period_ns();  // the camera's time runs with the loop's
    if (!p.step()) break;
  }
  EXPECT_GE(p.counters().frames_read, 25u);
  EXPECT_GE(p.counters().keyframes_integrated, 3u) << "standing still: one keyframe per max_interval_s";
  EXPECT_EQ(p.counters().frames_bad, 0u);
  EXPECT_EQ(p.camera()->counters().dropped, 0u);
  EXPECT_GT(p.reconstruction().active_blocks(), 0u) << "the wall was integrated";
}

// Each shared RGB-D sample through the app's replay driver: every frame read, posed by the dataset's ground truth
// and integrated with the sample's own camera (the fused surface lies where that camera back-projects the depth).
struct ReplaySample {
  const char* name;
  const char* calibration;  // shipped in drivers/replay/calibration/, or "" (the dataset's own file)
  messages::CameraIntrinsics intrinsics;
  float depth_scale_m;
};

void run_replay_sample(const ReplaySample& sample) {
  const std::string data = ::qsg::testing::shared_data_dir();
  if (data.empty() || !std::filesystem::exists(data + "/rgbd/" + sample.name))
    GTEST_SKIP() << "shared data rgbd/" << sample.name << " not found ($QSG_SHARED_DATA, ../shared/data)";
  AppConfig c = small_config(std::string("replay_") + sample.name);
  c.driver = Driver::kReplay;
  c.replay_path = data + "/rgbd/" + sample.name;
  if (sample.calibration[0] != '\0')
    c.replay.calibration = std::string(QSG_SOURCE_DIR) + "/drivers/replay/calibration/" + sample.calibration;
  // Five frames of a sequence: spaced past the keyframe selector's minimum interval, each a keyframe however
  // little the camera moved.
  c.replay.frame_period_s = 0.2;
  c.keyframes.min_translation_m = 0.0;
  c.keyframes.min_rotation_rad = 0.0;
  c.doors_online = false;
  c.doors_at_finish = false;
  ASSERT_TRUE(c.check().empty()) << c.check();
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  const messages::CameraIntrinsics k = p.camera()->intrinsics();
  EXPECT_EQ(k.width, sample.intrinsics.width);
  EXPECT_EQ(k.height, sample.intrinsics.height);
  EXPECT_EQ(k.fx, sample.intrinsics.fx);
  EXPECT_EQ(k.fy, sample.intrinsics.fy);
  EXPECT_EQ(k.cx, sample.intrinsics.cx);
  EXPECT_EQ(k.cy, sample.intrinsics.cy);
  for (int i = 0; i < 5000 && p.step(); ++i) {
  }
  EXPECT_TRUE(p.done());
  EXPECT_EQ(p.counters().frames_read, 5u);
  EXPECT_EQ(p.counters().frames_bad, 0u);
  EXPECT_EQ(p.counters().keyframes, 5u);
  EXPECT_EQ(p.counters().keyframes_integrated, 5u);
  EXPECT_EQ(p.counters().keyframes_refused, 0u);
  EXPECT_GT(p.reconstruction().active_blocks(), 0u);

  // The first frame back-projected with the sample's camera and pose lands on the fused surface.
  replay::DatasetReplay dataset;
  replay::DatasetReplayConfig rc = c.replay;
  rc.path = c.replay_path;
  ASSERT_TRUE(dataset.open(rc, &error)) << error;
  EXPECT_EQ(dataset.depth_scale_m(), sample.depth_scale_m);
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(dataset.camera().read(*frame, 0), drivers::ReadStatus::kOk);
  const Eigen::Isometry3d world_T_camera = dataset.ground_truth().front().world_T_body();
  const double voxel_m = c.reconstruction.voxel_size_m;
  int checked = 0, on_surface = 0;
  for (int v = 8; v < k.height; v += 16) {
    for (int u = 8; u < k.width; u += 16) {
      const float z = frame->depth_m[v * k.width + u];
      if (!(z > 0.5f && z < 3.5f)) continue;
      const Eigen::Vector3d p_m = world_T_camera * Eigen::Vector3d((u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, z);
      const reconstruction::Voxel* voxel = p.reconstruction().voxel_at(p_m);
      ++checked;
      if (voxel != nullptr && voxel->weight_q > 0 && std::abs(p.reconstruction().sdf_m(*voxel)) < 1.5 * voxel_m)
        ++on_surface;
    }
  }
  EXPECT_GT(checked, 200);
  EXPECT_GT(on_surface, checked * 8 / 10) << on_surface << " of " << checked << " points on the surface";
  std::printf("%s: %llu keyframes integrated, %d of %d back-projected points on the fused surface\n", sample.name,
              static_cast<unsigned long long>(p.counters().keyframes_integrated), on_surface, checked);
}

TEST(PipelineReplayTest, RedwoodSampleIntegratesEveryFrameWithItsCamera) {
  run_replay_sample({"redwood_open3d", "", {640, 480, 525.0, 525.0, 319.5, 239.5}, 0.001f});
}

TEST(PipelineReplayTest, IclNuimSampleIntegratesEveryFrameWithItsNegativeFy) {
  run_replay_sample({"icl_nuim_livingroom5", "icl_nuim.json", {640, 480, 481.2, -480.0, 319.5, 239.5}, 1.0f / 5000.0f});
}

TEST(PipelineReplayTest, Kinect5SampleIntegratesEveryFrameWithItsCamera) {
  run_replay_sample({"kinect5", "slambook2_kinect.json", {640, 480, 518.0, 519.0, 325.5, 253.5}, 0.001f});
}

// A few frames of the small building from the simulated camera at 320x240, written as qsg_simulate writes them
// (TumWriter with calibration.json and groundtruth.txt) into a fresh folder.
void write_simulated_tum(const std::string& dir, int frames) {
  std::filesystem::remove_all(dir);
  std::string error;
  const world::World world = world::generate_building(small_config("replay_sim_source").building);
  render::RayScene scene;
  ASSERT_TRUE(scene.build(world, &error)) << error;
  const world::FreeSpaceIndex free_space(world);
  const sim::ExplorationResult tour = sim::plan_exploration(world, scene, free_space, AppConfig().exploration);
  ASSERT_TRUE(tour.ok) << tour.error;
  sim::SimCamera camera;
  sim::SimCamera::Config cc;
  cc.intrinsics = {320, 240, 262.5, 262.5, 159.5, 119.5};
  cc.rate_hz = 5.0;
  cc.depth_scale_m = 1.0f / 5000.0f;
  ASSERT_TRUE(camera.init(cc, render::Renderer::Config{}, world, tour.trajectory, &error)) << error;
  replay::TumWriter writer;
  ASSERT_TRUE(writer.open(dir, replay::TumWriter::Config{}, &error)) << error;
  auto frame = std::make_unique<messages::RgbdFrame>();
  for (int i = 0; i < frames && camera.read(*frame, 0) == drivers::ReadStatus::kOk; ++i) {
    Eigen::Isometry3d world_T_camera;
    ASSERT_TRUE(camera.camera_pose(frame->sequence, &world_T_camera, nullptr));
    ASSERT_TRUE(writer.write_frame(*frame, &error)) << error;
    ASSERT_TRUE(writer.write_pose(replay::StampedPose::from_isometry(frame->sample_time_ns, world_T_camera), &error))
        << error;
  }
  ASSERT_TRUE(writer.close(&error)) << error;
}

// The depth images a TUM list names, in order.
std::vector<std::string> listed_depth_files(const std::string& dir) {
  std::vector<std::string> files;
  std::ifstream in(dir + "/depth.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, file;
    if (fields >> stamp >> file) files.push_back(dir + "/" + file);
  }
  return files;
}

AppConfig replay_config(const std::string& name, const std::string& dir) {
  AppConfig c = small_config(name);
  c.driver = Driver::kReplay;
  c.replay_path = dir;
  c.keyframes.min_translation_m = 0.0;
  c.keyframes.min_rotation_rad = 0.0;
  return c;
}

void run_to_end(Pipeline& p) {
  for (int i = 0; i < 5000 && p.step(); ++i) {
  }
  EXPECT_TRUE(p.done());
}

// qsg_simulate's output (TumWriter with calibration.json) at 320x240 replays through the app with its own camera.
TEST(PipelineReplayTest, SimulatorOutputAt320x240ReplaysWithItsCamera) {
  const std::string dir = ::testing::TempDir() + "/qsg_pipeline_replay_sim_tum";
  write_simulated_tum(dir, 8);
  std::string error;
  AppConfig c = small_config("replay_sim");
  c.driver = Driver::kReplay;
  c.replay_path = dir;
  c.keyframes.min_translation_m = 0.0;
  c.keyframes.min_rotation_rad = 0.0;
  runtime::SteppedClock clock;
  Pipeline p;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  EXPECT_EQ(p.camera()->intrinsics().width, 320);
  EXPECT_EQ(p.camera()->intrinsics().fx, 262.5);
  EXPECT_EQ(p.camera()->intrinsics().cy, 119.5);
  for (int i = 0; i < 5000 && p.step(); ++i) {
  }
  EXPECT_EQ(p.counters().frames_read, 8u);
  EXPECT_EQ(p.counters().frames_bad, 0u);
  EXPECT_EQ(p.counters().keyframes_integrated, 8u);
  EXPECT_EQ(p.nothing_mapped_reason(), "");
}

// Issue 36, item 4: a missing frame file is counted and skipped, not a start-up error (unless the config asks
// for the check at open).
TEST(PipelineReplayTest, AMissingFileIsCountedAndTheReplayGoesOn) {
  const std::string dir = ::testing::TempDir() + "/qsg_pipeline_replay_missing";
  write_simulated_tum(dir, 8);
  const std::vector<std::string> depth = listed_depth_files(dir);
  ASSERT_EQ(depth.size(), 8u);
  ASSERT_TRUE(std::filesystem::remove(depth[3]));
  std::string error;
  runtime::SteppedClock clock;
  Pipeline p;
  ASSERT_TRUE(p.init(replay_config("replay_missing", dir), &clock, &error)) << error;
  run_to_end(p);
  EXPECT_EQ(p.camera()->counters().missing_files, 1u);
  EXPECT_EQ(p.counters().frames_read, 7u);
  EXPECT_EQ(p.counters().keyframes_integrated, 7u);
  EXPECT_EQ(p.nothing_mapped_reason(), "");
  // The strict check, asked for, refuses the dataset at start-up naming the file.
  AppConfig strict = replay_config("replay_missing_strict", dir);
  strict.replay.check_files_at_open = true;
  Pipeline q;
  EXPECT_FALSE(q.init(strict, &clock, &error));
  EXPECT_NE(error.find("listed file '" + depth[3] + "' not found"), std::string::npos) << error;
  AppConfig loaded;
  std::ofstream(::testing::TempDir() + "/strict_replay.json") << "{\"replay\": {\"check_files_at_open\": true}}";
  ASSERT_TRUE(loaded.load(::testing::TempDir() + "/strict_replay.json", &error)) << error;
  EXPECT_TRUE(loaded.replay.check_files_at_open);
  EXPECT_FALSE(AppConfig().replay.check_files_at_open);
}

// An empty or all-rejected input is named, with the counts that explain it (qsg_app exits 3 on it).
TEST(PipelineReplayTest, AnEmptyOrAllRejectedInputIsNamed) {
  const std::string dir = ::testing::TempDir() + "/qsg_pipeline_replay_rejected";
  std::string error;
  runtime::SteppedClock clock;
  {
    write_simulated_tum(dir, 0);
    Pipeline p;
    EXPECT_FALSE(p.init(replay_config("replay_empty", dir), &clock, &error));
    EXPECT_NE(error.find("replay: '" + dir + "' lists no frames: nothing to map"), std::string::npos) << error;
  }
  {
    write_simulated_tum(dir, 8);
    for (const std::string& f : listed_depth_files(dir)) ASSERT_TRUE(std::filesystem::remove(f));
    Pipeline p;
    ASSERT_TRUE(p.init(replay_config("replay_all_missing", dir), &clock, &error)) << error;
    run_to_end(p);
    EXPECT_EQ(p.nothing_mapped_reason(),
              "no keyframe was integrated: 0 frames read (0 bad, 8 missing files, 0 without a pose, 0 while paused), "
              "0 keyframes (0 refused by the reconstruction)");
  }
  {
    write_simulated_tum(dir, 8);
    // Ground truth that covers none of the frames: every frame is dropped without a pose.
    std::ofstream(dir + "/groundtruth.txt") << "# timestamp tx ty tz qx qy qz qw\n"
                                               "1000.0 0 0 0 0 0 0 1\n1000.1 0 0 0 0 0 0 1\n";
    Pipeline p;
    ASSERT_TRUE(p.init(replay_config("replay_no_pose", dir), &clock, &error)) << error;
    run_to_end(p);
    EXPECT_EQ(p.counters().frames_read, 8u);
    EXPECT_EQ(p.nothing_mapped_reason(),
              "no keyframe was integrated: 8 frames read (0 bad, 0 missing files, 8 without a pose, 0 while paused), "
              "0 keyframes (0 refused by the reconstruction)");
  }
}

using testing::run_app;

// Issue 36 end to end: `qsg_app --convert` on a number outside the double range exits 1 with the reader's named
// error (it aborted, 134), and a replay that maps nothing exits 3 saying why, its outputs written.
TEST(AppExitStatusTest, BadInputEndsWithANamedErrorAndAnExitStatusNotAnAbort) {
  if (qsg::testing::running_emulated())
    GTEST_SKIP() << "under qemu-user a test cannot start the arm64 qsg_app (no binfmt_misc)";
  const std::string dir = ::testing::TempDir() + "/qsg_app_exit_status";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/big.json") << "{\"nodes\": [], \"edges\": [], \"x\": 1e400}";
  std::string output;
  EXPECT_EQ(run_app({"--convert", dir + "/big.json", dir + "/out.json"}, dir + "/convert.log", &output), 1) << output;
  EXPECT_NE(output.find("qsg_app: " + dir + "/big.json: (document): a number outside the double range (number "
                        "overflow parsing '1e400')"),
            std::string::npos)
      << output;

  const std::string data = dir + "/all_missing";
  write_simulated_tum(data, 4);
  for (const std::string& f : listed_depth_files(data)) ASSERT_TRUE(std::filesystem::remove(f));
  EXPECT_EQ(run_app({"--driver", "replay", "--replay", data, "--output", dir + "/out", "--quiet"}, dir + "/replay.log",
                    &output),
            3)
      << output;
  EXPECT_NE(output.find("qsg_app: nothing was mapped: no keyframe was integrated: 0 frames read (0 bad, 4 missing "
                        "files"),
            std::string::npos)
      << output;
  for (const char* name : {"scene_graph.json", "mesh.ply", "top_down.png", "trajectory_estimate.txt"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/out/" + name)) << name;
}

TEST(PipelineTest, MissingRoomWeightsLeaveRoomsUnknownAndTheRunGoesOn) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  AppConfig c = small_config("no_weights");
  c.room_weights_path = "/nonexistent/room_classifier.json";
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  for (int k = 0; k < 3000 && p.step(); ++k) {
  }
  ASSERT_TRUE(p.finish(&error)) << error;
  EXPECT_GT(p.counters().keyframes_integrated, 20u);
  EXPECT_EQ(p.counters().rooms_labelled, 0u);
  p.graph().for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kRoom) {
      EXPECT_EQ(p.graph().room(n.id)->semantic_label, semantics::kRoomUnknown);
    }
  });
}

TEST(PipelineTest, BadConfigAndUnwritableOutputAreClearErrors) {
  runtime::SteppedClock clock;
  std::string error;
  {
    Pipeline p;
    AppConfig c = small_config("bad");
    c.reconstruction.voxel_size_m = 0.001;
    EXPECT_FALSE(p.init(c, &clock, &error));
    EXPECT_NE(error.find("voxel_size_m"), std::string::npos) << error;
  }
  {
    Pipeline p;
    AppConfig c = small_config("unwritable");
    c.output_dir = "/proc/qsg_cannot_write_here";
    EXPECT_FALSE(p.init(c, &clock, &error));
    EXPECT_NE(error.find("output_dir"), std::string::npos) << error;
  }
  std::string why;
  EXPECT_FALSE(write_file_atomically("/proc/qsg_no/x.json", "{}", &why));
  EXPECT_FALSE(why.empty());
}

// Issue 36, item 5: integers must be integers within their type, duplicated keys are errors, and every section is
// range-checked whatever the driver.
TEST(AppConfigTest, RefusesNonsense) {
  const std::string dir = ::testing::TempDir();
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name) << text;
    return dir + "/" + name;
  };
  const std::string deep = "{\"building\": " + std::string(40, '[') + std::string(40, ']') + "}";
  for (const auto& [file, text, expected] : {
           std::tuple{"wrap.json", "{\"gpio\": {\"heartbeat_line\": 4294967296}}",
                      "gpio.heartbeat_line: expected an integer in [-2147483648, 2147483647], got 4294967296"},
           std::tuple{"fraction.json", "{\"building\": {\"num_rooms\": 1.5}}",
                      "building.num_rooms: expected an integer in [-2147483648, 2147483647], got 1.5"},
           std::tuple{"negative_seed.json", "{\"building\": {\"seed\": -1}}",
                      "building.seed: expected an integer in [0, 18446744073709551615], got -1"},
           std::tuple{"width_text.json", "{\"camera\": {\"width\": \"320\"}}", "camera.width: expected an integer"},
           std::tuple{"float_range.json", "{\"segmentation\": {\"min_confidence\": 1e39}}",
                      "segmentation.min_confidence: expected a number within the range of its type, got 1e+39"},
           std::tuple{"overflow.json", "{\"duration_s\": 1e400}",
                      "not valid JSON: a number outside the double range (number overflow parsing '1e400')"},
           std::tuple{"duplicate.json", "{\"duration_s\": 5, \"duration_s\": 6}", "': duration_s: duplicated key"},
           std::tuple{"duplicate_nested.json", "{\"building\": {\"seed\": 1, \"num_rooms\": 4, \"seed\": 2}}",
                      "': building.seed: duplicated key"},
           std::tuple{"deep.json", deep.c_str(), "nested deeper than 32 levels"},
           // Sections of a driver that is not selected are checked all the same.
           std::tuple{"v4l2_unused.json", "{\"driver\": \"sim\", \"v4l2\": {\"width\": 100000}}",
                      "v4l2.width must be in [16, 640] px, got 100000"},
           std::tuple{"v4l2_scale.json", "{\"v4l2\": {\"depth_scale_m\": 0}}", "v4l2.depth_scale_m must be in (0, 1]"},
           std::tuple{"v4l2_fx.json", "{\"v4l2\": {\"fx\": -5}}", "v4l2.fx must be in [0, 1e5] px, got -5"},
           // Upper bounds.
           std::tuple{"snapshot.json", "{\"snapshot_interval_s\": 1e300}", "snapshot_interval_s must be in (0, 1e9]"},
           std::tuple{"duration.json", "{\"duration_s\": 1e12}", "duration_s must be in [0, 1e9]"},
           std::tuple{"deadline.json", "{\"segmentation\": {\"deadline_s\": 1e6}}", "segmentation.deadline_s must be in (0, 60]"},
           std::tuple{"confidence.json", "{\"segmentation\": {\"min_confidence\": 2}}",
                      "segmentation.min_confidence must be in [0, 1]"},
           std::tuple{"trigger.json", "{\"gpio\": {\"trigger_width_s\": 5}}", "gpio.trigger_width_s must be in (0, 1]"},
           std::tuple{"range.json", "{\"reconstruction\": {\"max_range_m\": 1e9, \"window_radius_m\": 2e9}}",
                      "reconstruction.max_range_m must be in (0, 50] m, got 1e9"},
           std::tuple{"archive.json", "{\"reconstruction\": {\"archive_resolution_m\": 1e6}}",
                      "archive_resolution_m must be in (0, 1] m"},
           std::tuple{"keyframe_interval.json", "{\"keyframes\": {\"max_interval_s\": 1e12}}",
                      "keyframes.max_interval_s must be in (0, 3600] s, got 1e12"},
           std::tuple{"keyframe_rotation.json", "{\"keyframes\": {\"min_rotation_rad\": 7}}",
                      "keyframes.min_rotation_rad must be in [0, 3.1416] rad, got 7"},
           std::tuple{"places_window.json", "{\"places\": {\"window_radius_m\": 1e6}}",
                      "places.window_radius_m must be in (0, 100] m, got 1e6"},
       }) {
    AppConfig c;
    std::string error;
    EXPECT_FALSE(c.load(write(file, text), &error)) << file;
    EXPECT_NE(error.find(expected), std::string::npos) << file << ": '" << error << "' does not say '" << expected << "'";
    EXPECT_EQ(error.rfind("config '" + dir + "/" + file + "'", 0), 0u) << error;
  }
  // What is right still loads: integers where integers are due, whole or fractional numbers for doubles.
  AppConfig good;
  std::string error;
  ASSERT_TRUE(good.load(write("good_numbers.json", "{\"building\": {\"seed\": 18446744073709551615, \"num_rooms\": 6},"
                                                   " \"gpio\": {\"heartbeat_line\": 1023, \"trigger_line\": -1},"
                                                   " \"duration_s\": 12, \"snapshot_interval_s\": 2.5}"),
                        &error))
      << error;
  EXPECT_EQ(good.building.seed, 18446744073709551615ull);
  EXPECT_EQ(good.gpio.heartbeat_line, 1023);
  EXPECT_EQ(good.gpio.trigger_line, -1);
  EXPECT_EQ(good.duration_s, 12.0);
}

TEST(AppConfigTest, LoadsKnownKeysAndNamesBadOnes) {
  const std::string dir = ::testing::TempDir();
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name) << text;
    return dir + "/" + name;
  };
  AppConfig c;
  std::string error;
  ASSERT_TRUE(c.load(write("good.json", "// comment\n{\"duration_s\": 12, \"building\": {\"num_rooms\": 6},"
                                        " \"camera\": {\"width\": 640, \"height\": 480}}"),
                     &error))
      << error;
  EXPECT_EQ(c.duration_s, 12.0);
  EXPECT_EQ(c.building.num_rooms, 6);
  EXPECT_EQ(c.camera.intrinsics.width, 640);
  EXPECT_NEAR(c.camera.intrinsics.fx, 525.0, 1e-9);
  EXPECT_FALSE(c.load(write("unknown.json", "{\"building\": {\"rooms\": 6}}"), &error));
  EXPECT_NE(error.find("building.rooms: unknown key"), std::string::npos) << error;
  EXPECT_FALSE(c.load(write("type.json", "{\"lockstep\": 1}"), &error));
  EXPECT_NE(error.find("lockstep: expected true or false"), std::string::npos) << error;
  EXPECT_FALSE(c.load(write("broken.json", "{\"lockstep\": "), &error));
  EXPECT_NE(error.find("not valid JSON"), std::string::npos) << error;
  EXPECT_FALSE(c.load(dir + "/missing.json", &error));
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
  EXPECT_FALSE(c.load(write("driver.json", "{\"driver\": \"usb\"}"), &error));
  EXPECT_NE(error.find("driver"), std::string::npos) << error;
  ASSERT_TRUE(c.load(write("rooms.json", "{\"rooms\": {\"seeding\": \"plateau\", \"min_component_size\": 9}}"),
                     &error))
      << error;
  EXPECT_EQ(c.rooms.seeding, rooms::Seeding::kPlateau);
  EXPECT_EQ(c.rooms.min_component_size, 9u);
  EXPECT_FALSE(c.load(write("seeding.json", "{\"rooms\": {\"seeding\": \"watershed\"}}"), &error));
  EXPECT_NE(error.find("rooms.seeding: expected plateau or persistence"), std::string::npos) << error;
  EXPECT_FALSE(c.load(write("alpha.json", "{\"rooms\": {\"plateau_alpha\": 2}}"), &error));
  EXPECT_NE(error.find("rooms.plateau_alpha"), std::string::npos) << error;
  AppConfig split;
  ASSERT_TRUE(split.load(write("split.json", "{\"rooms\": {\"split_by_extent\": false, \"split_min_component_size\": 4}}"),
                         &error))
      << error;
  EXPECT_FALSE(split.rooms.split_by_extent);
  EXPECT_EQ(split.rooms.split_min_component_size, 4u);
  EXPECT_FALSE(split.load(write("extent.json", "{\"rooms\": {\"split_max_extent_m\": 0.5}}"), &error));
  EXPECT_NE(error.find("rooms.split_max_extent_m"), std::string::npos) << error;
  AppConfig corridor;
  ASSERT_TRUE(corridor.load(write("corridor.json", "{\"rooms\": {\"merge_corridors\": false, "
                                                   "\"corridor_min_neighbours\": 4, \"corridor_min_open_edges\": 12}}"),
                            &error))
      << error;
  EXPECT_FALSE(corridor.rooms.merge_corridors);
  EXPECT_EQ(corridor.rooms.corridor_min_neighbours, 4u);
  EXPECT_EQ(corridor.rooms.corridor_min_open_edges, 12u);
  EXPECT_FALSE(corridor.load(write("corridor_frac.json", "{\"rooms\": {\"corridor_min_open_edges\": 2.5}}"), &error));
  EXPECT_NE(error.find("rooms.corridor_min_open_edges"), std::string::npos) << error;
  AppConfig one_neighbour;  // with the merge on, as by default
  EXPECT_FALSE(one_neighbour.load(write("corridor_one.json", "{\"rooms\": {\"corridor_min_neighbours\": 1}}"), &error));
  EXPECT_NE(error.find("rooms.corridor_min_neighbours"), std::string::npos) << error;
  AppConfig doors;
  ASSERT_TRUE(doors.load(write("doors.json", "{\"doors\": {\"at_finish\": false, \"max_width_m\": 2.0}}"), &error))
      << error;
  EXPECT_FALSE(doors.doors_at_finish);
  EXPECT_EQ(doors.doors.max_width_m, 2.0);
  AppConfig bypass;
  ASSERT_TRUE(bypass.load(write("bypass.json", "{\"doors\": {\"bypass_max_m\": 0, \"bypass_extension_m\": 0.4, "
                                               "\"bypass_max_edge_m\": 2.0}}"),
                          &error))
      << error;
  EXPECT_EQ(bypass.doors.bypass_max_m, 0.0);
  EXPECT_EQ(bypass.doors.bypass_extension_m, 0.4);
  EXPECT_EQ(bypass.doors.bypass_max_edge_m, 2.0);
  EXPECT_FALSE(bypass.load(write("bypass_bad.json", "{\"doors\": {\"bypass_max_edge_m\": -1}}"), &error));
  EXPECT_NE(error.find("bypass_max_edge_m"), std::string::npos) << error;
  AppConfig sight;
  ASSERT_TRUE(sight.load(write("sight.json", "{\"doors\": {\"sight_min_wall_m\": 2.5, \"sight_wall_dilation_m\": 0.1, "
                                             "\"sight_furniture_max_m\": 6.0, \"sight_furniture_min_width_m\": 1.2, "
                                             "\"sight_cut_edges\": false}, \"rooms\": {\"merge_visible\": false, "
                                             "\"close_edges_through_walls\": false, "
                                             "\"visible_min_share\": 0.7, \"visible_samples\": 16, "
                                             "\"visible_local_radius_m\": 3.0, \"visible_local_min_share\": 0.9, "
                                             "\"visible_local_min_places\": 5, \"visible_max_rounds\": 4, "
                                             "\"visible_touching\": false, "
                                             "\"visible_touch_max_clearance_m\": 2.5}}"),
                         &error))
      << error;
  EXPECT_EQ(sight.doors.sight_min_wall_m, 2.5);
  EXPECT_EQ(sight.doors.sight_wall_dilation_m, 0.1);
  EXPECT_FALSE(sight.doors.sight_cut_edges);
  EXPECT_FALSE(sight.rooms.merge_visible);
  EXPECT_FALSE(sight.rooms.close_edges_through_walls);
  EXPECT_EQ(sight.rooms.visible_min_share, 0.7);
  EXPECT_EQ(sight.rooms.visible_samples, 16u);
  EXPECT_EQ(sight.rooms.visible_max_rounds, 4u);
  EXPECT_EQ(sight.doors.sight_furniture_max_m, 6.0);
  EXPECT_EQ(sight.doors.sight_furniture_min_width_m, 1.2);
  EXPECT_EQ(sight.rooms.visible_local_radius_m, 3.0);
  EXPECT_EQ(sight.rooms.visible_local_min_share, 0.9);
  EXPECT_EQ(sight.rooms.visible_local_min_places, 5u);
  EXPECT_FALSE(sight.rooms.visible_touching);
  EXPECT_EQ(sight.rooms.visible_touch_max_clearance_m, 2.5);
  for (const auto& [file, text, field] :
       {std::tuple{"sight_bad.json", "{\"doors\": {\"sight_min_wall_m\": -1}}", "sight_min_wall_m"},
        std::tuple{"visible_frac.json", "{\"rooms\": {\"visible_samples\": 2.5}}", "rooms.visible_samples"},
        std::tuple{"visible_many.json", "{\"rooms\": {\"visible_samples\": 64}}", "visible_samples"},
        std::tuple{"visible_share.json", "{\"rooms\": {\"visible_min_share\": 0}}", "visible_min_share"},
        std::tuple{"furniture_width.json", "{\"doors\": {\"sight_furniture_min_width_m\": 0}}",
                   "sight_furniture_min_width_m"},
        std::tuple{"local_radius.json", "{\"rooms\": {\"visible_local_radius_m\": -1}}", "visible_local_radius_m"},
        std::tuple{"touch_clearance.json", "{\"rooms\": {\"visible_touch_max_clearance_m\": 0}}",
                   "visible_touch_max_clearance_m"},
        std::tuple{"local_places.json", "{\"rooms\": {\"visible_local_min_places\": 1.5}}",
                   "rooms.visible_local_min_places"}}) {
    AppConfig bad;
    EXPECT_FALSE(bad.load(write(file, text), &error)) << file;
    EXPECT_NE(error.find(field), std::string::npos) << error;
  }
  EXPECT_FALSE(doors.load(write("door_widths.json", "{\"doors\": {\"min_width_m\": 3.0}}"), &error));
  EXPECT_NE(error.find("min_width_m"), std::string::npos) << error;
  AppConfig online;
  ASSERT_TRUE(online.load(write("online.json", "{\"doors\": {\"online\": false, \"online_every_n_updates\": 7, "
                                               "\"online_misses_to_drop\": 3}}"),
                          &error))
      << error;
  EXPECT_FALSE(online.doors_online);
  EXPECT_EQ(online.doors_online_every_n, 7u);
  EXPECT_EQ(online.doors.online_misses_to_drop, 3);
  EXPECT_FALSE(online.load(write("online_m.json", "{\"doors\": {\"online_misses_to_drop\": 0}}"), &error));
  EXPECT_NE(error.find("online_misses_to_drop"), std::string::npos) << error;
  EXPECT_FALSE(online.load(write("online_n.json", "{\"doors\": {\"online_every_n_updates\": 0}}"), &error));
  EXPECT_NE(error.find("online_every_n_updates"), std::string::npos) << error;
  EXPECT_FALSE(online.load(write("online_frac.json", "{\"doors\": {\"online_every_n_updates\": 1.5}}"), &error));
  AppConfig replay;
  ASSERT_TRUE(replay.load(write("replay.json", "{\"driver\": \"replay\", \"replay_path\": \"/data/icl\", "
                                               "\"replay\": {\"format\": \"pose_list\", \"calibration\": \"c.json\", "
                                               "\"fx\": 481.2, \"fy\": -480, \"cx\": 319.5, \"cy\": 239.5, "
                                               "\"depth_scale_m\": 0.0002, \"frame_period_s\": 0.1}}"),
                          &error))
      << error;
  EXPECT_EQ(replay.replay.format, "pose_list");
  EXPECT_EQ(replay.replay.calibration, "c.json");
  EXPECT_EQ(replay.replay.fx, 481.2);
  EXPECT_EQ(replay.replay.fy, -480.0);
  EXPECT_EQ(replay.replay.cx, 319.5);
  EXPECT_EQ(replay.replay.cy, 239.5);
  EXPECT_EQ(replay.replay.depth_scale_m, 0.0002);
  EXPECT_EQ(replay.replay.frame_period_s, 0.1);
  for (const auto& [file, text, field] :
       {std::tuple{"replay_format.json", "{\"replay\": {\"format\": \"bag\"}}", "replay.format: expected auto"},
        std::tuple{"replay_fx.json", "{\"replay\": {\"fx\": -1}}", "replay.fx must be 0"},
        std::tuple{"replay_fy.json", "{\"replay\": {\"fy\": 0.5}}", "replay.fy must be 0"},
        std::tuple{"replay_cx.json", "{\"replay\": {\"cx\": 700}}", "replay.cx must be 0"},
        std::tuple{"replay_cy.json", "{\"replay\": {\"cy\": -2}}", "replay.cy must be 0"},
        std::tuple{"replay_scale.json", "{\"replay\": {\"depth_scale_m\": 2}}", "replay.depth_scale_m must be 0"},
        std::tuple{"replay_period.json", "{\"replay\": {\"frame_period_s\": 0}}", "replay.frame_period_s"},
        std::tuple{"replay_key.json", "{\"replay\": {\"focal\": 500}}", "replay.focal: unknown key"},
        std::tuple{"replay_type.json", "{\"replay\": {\"calibration\": 3}}", "replay.calibration: expected a string"}}) {
    AppConfig bad;
    EXPECT_FALSE(bad.load(write(file, text), &error)) << file;
    EXPECT_NE(error.find(field), std::string::npos) << error;
  }
  // The shipped default file loads and equals the built-in defaults where it spells them out.
  AppConfig shipped;
  ASSERT_TRUE(shipped.load(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/default.json", &error)) << error;
  EXPECT_EQ(shipped.building.num_rooms, AppConfig().building.num_rooms);
  EXPECT_EQ(shipped.camera.intrinsics.width, AppConfig().camera.intrinsics.width);
  EXPECT_EQ(shipped.rooms.seeding, AppConfig().rooms.seeding);
  EXPECT_EQ(shipped.rooms.min_component_size, AppConfig().rooms.min_component_size);
  const rooms::Config& sr = shipped.rooms;
  const rooms::Config dr = AppConfig().rooms;
  EXPECT_EQ(sr.split_by_extent, dr.split_by_extent);
  EXPECT_EQ(sr.extent_saturation_m, dr.extent_saturation_m);
  EXPECT_EQ(sr.split_min_extent_m, dr.split_min_extent_m);
  EXPECT_EQ(sr.split_max_extent_m, dr.split_max_extent_m);
  EXPECT_EQ(sr.split_min_persistence_m, dr.split_min_persistence_m);
  EXPECT_EQ(sr.split_min_component_size, dr.split_min_component_size);
  EXPECT_EQ(sr.merge_corridors, dr.merge_corridors);
  EXPECT_EQ(sr.corridor_min_neighbours, dr.corridor_min_neighbours);
  EXPECT_EQ(sr.corridor_min_open_edges, dr.corridor_min_open_edges);
  EXPECT_EQ(sr.merge_visible, dr.merge_visible);
  EXPECT_EQ(sr.close_edges_through_walls, dr.close_edges_through_walls);
  EXPECT_EQ(sr.visible_min_share, dr.visible_min_share);
  EXPECT_EQ(sr.visible_samples, dr.visible_samples);
  EXPECT_EQ(sr.visible_max_rounds, dr.visible_max_rounds);
  EXPECT_EQ(sr.visible_local_radius_m, dr.visible_local_radius_m);
  EXPECT_EQ(sr.visible_local_min_share, dr.visible_local_min_share);
  EXPECT_EQ(sr.visible_local_min_places, dr.visible_local_min_places);
  EXPECT_EQ(sr.visible_touching, dr.visible_touching);
  EXPECT_EQ(sr.visible_touch_max_clearance_m, dr.visible_touch_max_clearance_m);
  EXPECT_EQ(shipped.doors_at_finish, AppConfig().doors_at_finish);
  EXPECT_EQ(shipped.doors_online, AppConfig().doors_online);
  EXPECT_EQ(shipped.doors_online_every_n, AppConfig().doors_online_every_n);
  EXPECT_EQ(shipped.doors.online_misses_to_drop, AppConfig().doors.online_misses_to_drop);
  EXPECT_EQ(shipped.doors.slice_above_robot_m, AppConfig().doors.slice_above_robot_m);
  EXPECT_EQ(shipped.doors.min_width_m, AppConfig().doors.min_width_m);
  EXPECT_EQ(shipped.doors.max_width_m, AppConfig().doors.max_width_m);
  EXPECT_EQ(shipped.doors.min_rise_m, AppConfig().doors.min_rise_m);
  EXPECT_EQ(shipped.doors.rise_reach_m, AppConfig().doors.rise_reach_m);
  EXPECT_EQ(shipped.doors.bypass_max_m, AppConfig().doors.bypass_max_m);
  EXPECT_EQ(shipped.doors.bypass_extension_m, AppConfig().doors.bypass_extension_m);
  EXPECT_EQ(shipped.doors.bypass_max_edge_m, AppConfig().doors.bypass_max_edge_m);
  EXPECT_EQ(shipped.doors.sight_min_wall_m, AppConfig().doors.sight_min_wall_m);
  EXPECT_EQ(shipped.doors.sight_wall_dilation_m, AppConfig().doors.sight_wall_dilation_m);
  EXPECT_EQ(shipped.doors.sight_cut_edges, AppConfig().doors.sight_cut_edges);
  EXPECT_EQ(shipped.doors.sight_furniture_max_m, AppConfig().doors.sight_furniture_max_m);
  EXPECT_EQ(shipped.doors.sight_furniture_min_width_m, AppConfig().doors.sight_furniture_min_width_m);
  const replay::DatasetReplayConfig dz;
  EXPECT_EQ(shipped.replay.format, dz.format);
  EXPECT_EQ(shipped.replay.calibration, dz.calibration);
  EXPECT_EQ(shipped.replay.fx, dz.fx);
  EXPECT_EQ(shipped.replay.fy, dz.fy);
  EXPECT_EQ(shipped.replay.cx, dz.cx);
  EXPECT_EQ(shipped.replay.cy, dz.cy);
  EXPECT_EQ(shipped.replay.depth_scale_m, dz.depth_scale_m);
  EXPECT_EQ(shipped.replay.frame_period_s, dz.frame_period_s);
  EXPECT_EQ(AppConfig().replay.frame_period_s, dz.frame_period_s);
  const AppConfig::Odometry& so = shipped.odometry;
  const AppConfig::Odometry dod = AppConfig().odometry;
  EXPECT_EQ(so.source, dod.source);
  EXPECT_EQ(so.translation_sigma_m_per_sqrt_m, dod.translation_sigma_m_per_sqrt_m);
  EXPECT_EQ(so.yaw_sigma_rad_per_sqrt_m, dod.yaw_sigma_rad_per_sqrt_m);
  EXPECT_EQ(so.seed, dod.seed);
  EXPECT_EQ(so.stream_transport, dod.stream_transport);
  EXPECT_EQ(so.stream_bind_address, dod.stream_bind_address);
  EXPECT_EQ(so.stream_port, dod.stream_port);
  EXPECT_EQ(so.silence_fault_s, dod.silence_fault_s);
  EXPECT_EQ(so.buffer.max_gap_s, dod.buffer.max_gap_s);
  EXPECT_EQ(so.buffer.max_time_jump_s, dod.buffer.max_time_jump_s);
  EXPECT_EQ(so.buffer.max_speed_m_per_s, dod.buffer.max_speed_m_per_s);
  EXPECT_EQ(shipped.exploration.tours, AppConfig().exploration.tours);
  const agents::Config& sa = shipped.frontend.agents;
  const agents::Config da = AppConfig().frontend.agents;
  EXPECT_EQ(sa.min_translation_m, da.min_translation_m);
  EXPECT_EQ(sa.min_rotation_rad, da.min_rotation_rad);
  EXPECT_EQ(sa.max_interval_s, da.max_interval_s);
  EXPECT_EQ(sa.fold_at_fraction, da.fold_at_fraction);
  const places::Config& sp = shipped.frontend.places;
  const places::Config dp = AppConfig().frontend.places;
  EXPECT_EQ(sp.signed_surface_seeds, dp.signed_surface_seeds);
  EXPECT_EQ(sp.correct_projective_distance, dp.correct_projective_distance);
  EXPECT_EQ(sp.bridge_max_fragment_places, dp.bridge_max_fragment_places);
  EXPECT_EQ(sp.hold_distant_fragments, dp.hold_distant_fragments);
  EXPECT_EQ(sp.bridge_path_search, dp.bridge_path_search);
  EXPECT_EQ(sp.merge_revisited_within_m, dp.merge_revisited_within_m);
  EXPECT_EQ(sp.unobserved_obstacle_above_m, dp.unobserved_obstacle_above_m);
}

}  // namespace
}  // namespace qsg::app

// The app's pipeline in lockstep on the simulated robot: deterministic, no heap allocation per tick in steady
// state, every store below its capacity, outputs written atomically and readable.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include "core/reconstruction/ply_writer.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "drivers/v4l2/fake_v4l2_device.h"
#include "firmware_app/pipeline.h"
#include "tests/support/allocation_counter.h"

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

TEST(PipelineTest, LockstepRunIsAllocationFreeInSteadyStateAndWithinCapacity) {
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(small_config("steady"), &clock, &error)) << error;
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
                                             "\"merge_visible_in_window\": true, "
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
  EXPECT_TRUE(sight.rooms.merge_visible_in_window);
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
  EXPECT_EQ(sr.merge_visible_in_window, dr.merge_visible_in_window);
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
  const places::Config& sp = shipped.frontend.places;
  const places::Config dp = AppConfig().frontend.places;
  EXPECT_EQ(sp.signed_surface_seeds, dp.signed_surface_seeds);
  EXPECT_EQ(sp.correct_projective_distance, dp.correct_projective_distance);
  EXPECT_EQ(sp.bridge_max_fragment_places, dp.bridge_max_fragment_places);
  EXPECT_EQ(sp.hold_distant_fragments, dp.hold_distant_fragments);
  EXPECT_EQ(sp.bridge_path_search, dp.bridge_path_search);
  EXPECT_EQ(sp.unobserved_obstacle_above_m, dp.unobserved_obstacle_above_m);
}

}  // namespace
}  // namespace qsg::app

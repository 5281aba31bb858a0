// The app's written outputs as another tool sees them: a clean mesh (no degenerate, duplicated or back-to-back
// triangles, no unreferenced vertices) and a graph whose objects point at that mesh's vertices and whose label
// space names every label it uses.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "core/reconstruction/mesh_cleanup.h"
#include "core/reconstruction/ply_writer.h"
#include "firmware_app/graph_viewer.h"
#include "firmware_app/pipeline.h"

namespace qsg::app {
namespace {

using json = nlohmann::json;

// The slow, obvious check: every triangle's sorted corners into a set.
struct MeshDefects {
  std::size_t repeated_corner = 0, zero_area = 0, same_corners = 0, unreferenced = 0;
};
MeshDefects find_defects(const reconstruction::Mesh& mesh) {
  MeshDefects d;
  std::set<std::array<std::uint32_t, 3>> seen;
  std::vector<bool> used(mesh.vertices.size(), false);
  for (const reconstruction::MeshTriangle& t : mesh.triangles) {
    std::array<std::uint32_t, 3> k{{t.v[0], t.v[1], t.v[2]}};
    for (std::uint32_t v : k) used[v] = true;
    std::sort(k.begin(), k.end());
    if (k[0] == k[1] || k[1] == k[2]) {
      ++d.repeated_corner;
      continue;
    }
    const auto p = [&](std::uint32_t i) {
      return Eigen::Vector3d(mesh.vertices[i].x, mesh.vertices[i].y, mesh.vertices[i].z);
    };
    if ((p(k[1]) - p(k[0])).cross(p(k[2]) - p(k[0])).norm() < 2e-10) ++d.zero_area;
    if (!seen.insert(k).second) ++d.same_corners;
  }
  d.unreferenced = static_cast<std::size_t>(std::count(used.begin(), used.end(), false));
  return d;
}

TEST(MeshCleanupTest, RemovesEveryKindOfDefectAndRenumbers) {
  reconstruction::Mesh m;
  for (int i = 0; i < 6; ++i) m.vertices.push_back({static_cast<float>(i % 2), static_cast<float>(i / 2), 0.0f});
  m.vertices.push_back({9, 9, 9});                                    // 6: unreferenced
  m.vertices.push_back({2, 0, 0});                                    // 7: on the line through 0 and 1
  m.triangles = {{{0, 1, 2}}, {{1, 3, 2}}, {{0, 1, 2}},              // a duplicate
                 {{2, 1, 0}},                                         // back to back with the first
                 {{1, 2, 0}},                                         // the first, rotated: a duplicate
                 {{2, 2, 3}},                                         // a repeated corner
                 {{0, 1, 7}},                                         // zero area
                 {{4, 5, 3}}};
  std::vector<std::uint32_t> remap;
  const reconstruction::MeshCleanupStats s = reconstruction::clean_mesh(&m, &remap);
  EXPECT_EQ(s.duplicated, 2u);
  EXPECT_EQ(s.back_to_back, 1u);
  EXPECT_EQ(s.degenerate, 2u);
  EXPECT_EQ(s.unreferenced, 2u);  // 6 and 7
  ASSERT_EQ(m.triangles.size(), 3u);
  ASSERT_EQ(m.vertices.size(), 6u);
  EXPECT_EQ(s.non_manifold_edges, 0u);
  EXPECT_EQ(remap[6], memory::kInvalidHandle);
  EXPECT_EQ(remap[5], 5u);
  const MeshDefects d = find_defects(m);
  EXPECT_EQ(d.repeated_corner + d.zero_area + d.same_corners + d.unreferenced, 0u);
}

TEST(MeshCleanupTest, CountsNonManifoldEdges) {
  reconstruction::Mesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  m.triangles = {{{0, 1, 2}}, {{1, 0, 3}}, {{0, 1, 4}}};  // edge 0-1 shared by three triangles
  const reconstruction::MeshCleanupStats s = reconstruction::clean_mesh(&m);
  EXPECT_EQ(s.non_manifold_edges, 1u);
  EXPECT_EQ(m.triangles.size(), 3u);  // counted, not removed
}

// A short simulated run (4 rooms, 30 s): the outputs another program reads.
TEST(AppOutputsTest, MeshIsCleanAndTheGraphPointsIntoIt) {
  AppConfig c;
  c.output_dir = ::testing::TempDir() + "/qsg_outputs_test";
  c.building.num_rooms = 4;
  c.building.seed = 3;
  c.camera.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  c.snapshot_interval_s = 2.0;
  c.telemetry_interval_s = 1e6;
  std::filesystem::remove_all(c.output_dir);
  runtime::SteppedClock clock;
  Pipeline p;
  std::string error;
  ASSERT_TRUE(p.init(c, &clock, &error)) << error;
  for (int k = 0; k < 6000 && p.step(); ++k) {  // 30 s of 200 Hz ticks
  }
  p.request_stop();
  while (p.step()) {
  }
  ASSERT_TRUE(p.finish(&error)) << error;

  reconstruction::Mesh mesh;
  ASSERT_TRUE(reconstruction::read_ply(c.output_dir + "/mesh.ply", &mesh, &error)) << error;
  ASSERT_GT(mesh.triangles.size(), 1000u);
  const MeshDefects d = find_defects(mesh);
  EXPECT_EQ(d.repeated_corner, 0u);
  EXPECT_EQ(d.zero_area, 0u);
  EXPECT_EQ(d.same_corners, 0u) << "duplicated or back-to-back triangles";
  EXPECT_EQ(d.unreferenced, 0u);
  std::ifstream ply(c.output_dir + "/mesh.ply", std::ios::binary);
  std::string header, line;
  while (std::getline(ply, line) && line != "end_header") header += line + "\n";
  EXPECT_NE(header.find("property int label\n"), std::string::npos) << header;

  std::ifstream in(c.output_dir + "/scene_graph.json");
  const json doc = json::parse(in);
  const json& spaces = doc.at("metadata").at("labelspaces");
  std::map<std::uint32_t, std::string> object_names, room_names;
  for (const json& e : spaces.at("_l2p0")) object_names[e.at(0).get<std::uint32_t>()] = e.at(1).get<std::string>();
  for (const json& e : spaces.at("_l4p0")) room_names[e.at(0).get<std::uint32_t>()] = e.at(1).get<std::string>();
  std::size_t objects = 0, objects_with_vertices = 0, agents = 0, agent_stamped = 0;
  for (const json& n : doc.at("nodes")) {
    const json& a = n.at("attributes");
    const std::uint32_t label = a.value("semantic_label", 0u);
    if (a.at("type") == "ObjectNodeAttributes") {
      ++objects;
      EXPECT_EQ(object_names.count(label), 1u) << "object label " << label << " has no name";
      const json& connections = a.at("mesh_connections");
      objects_with_vertices += connections.empty() ? 0 : 1;
      // Indices into the written mesh, of vertices near the object's box.
      const Eigen::Vector3d c0(a["bounding_box"]["world_P_center"][0], a["bounding_box"]["world_P_center"][1],
                               a["bounding_box"]["world_P_center"][2]);
      const Eigen::Vector3d half(a["bounding_box"]["dimensions"][0], a["bounding_box"]["dimensions"][1],
                                 a["bounding_box"]["dimensions"][2]);
      for (const json& v : connections) {
        ASSERT_LT(v.get<std::size_t>(), mesh.vertices.size());
        const reconstruction::MeshVertex& mv = mesh.vertices[v.get<std::size_t>()];
        const Eigen::Vector3d off = (Eigen::Vector3d(mv.x, mv.y, mv.z) - c0).cwiseAbs() - 0.5 * half;
        EXPECT_LT(off.maxCoeff(), 0.25) << "vertex " << v << " is far from its object's box";
      }
    } else if (a.at("type") == "RoomNodeAttributes") {
      EXPECT_EQ(room_names.count(label), 1u);
      for (auto it = a.at("semantic_class_probabilities").begin(); it != a.at("semantic_class_probabilities").end(); ++it)
        EXPECT_TRUE(std::any_of(room_names.begin(), room_names.end(), [&](const auto& r) { return r.second == it.key(); }))
            << it.key();
    } else if (a.at("type") == "AgentNodeAttributes") {
      ++agents;
      agent_stamped += a.at("timestamp").get<std::uint64_t>() > 0 ? 1 : 0;
    }
  }
  EXPECT_GT(objects, 0u);
  EXPECT_GT(agents, 1u);
  EXPECT_GE(agent_stamped + 1, agents) << "every agent after the first at t = 0 has its timestamp";
  EXPECT_GE(objects_with_vertices * 10, objects * 9) << "most objects point at their vertices";

  // The browser view is written where three.js is installed (its drawing: viewer_test.cc).
  if (!find_three_js().empty()) {
    EXPECT_TRUE(std::filesystem::exists(c.output_dir + "/scene_graph.html"));
  }

  // A snapshot has no mesh beside it: no object mesh connections either.
  std::ifstream snap(c.output_dir + "/scene_graph_snapshot.json");
  ASSERT_TRUE(snap.good());
  const json snapshot = json::parse(snap);  // named: a temporary would die before the loop
  for (const json& n : snapshot.at("nodes"))
    EXPECT_FALSE(n.at("attributes").contains("mesh_connections"));
}

}  // namespace
}  // namespace qsg::app

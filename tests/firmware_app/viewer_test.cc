// The browser view (scene_graph.html) opened in headless Chromium: every layer and the mesh draw in their colours,
// the page's toggles hide them, and the page fetches nothing (three.js and the data are inlined). And the room
// names on the top-down picture.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "core/semantics/labels.h"
#include "firmware_app/graph_picture.h"
#include "firmware_app/graph_viewer.h"
#include "tests/scene_graph/test_graph.h"
#include "tests/support/emulation.h"

namespace qsg::app {
namespace {

using scene_graph::make_node_id;

void build(scene_graph::SceneGraph& g) {
  scene_graph::BuildingAttributes b;
  b.position_m = {5, 4, 1};
  ASSERT_EQ(g.add_building(make_node_id('B', 0), b), scene_graph::Status::kOk);
  for (int r = 0; r < 2; ++r) {
    scene_graph::RoomAttributes room;
    room.position_m = {2.5 + 5 * r, 4, 1};
    room.semantic_label = r == 0 ? semantics::kKitchen : semantics::kBedroom;
    const scene_graph::NodeId rid = make_node_id('R', r);
    ASSERT_EQ(g.add_room(rid, room), scene_graph::Status::kOk);
    ASSERT_EQ(g.add_edge(make_node_id('B', 0), rid), scene_graph::Status::kOk);
    for (int i = 0; i < 9; ++i) {
      const scene_graph::NodeId pid = make_node_id('p', 10 * r + i);
      ASSERT_EQ(g.add_place(pid, scene_graph::testing::place_at(1 + 5 * r + 1.5 * (i % 3), 2.5 + 1.5 * (i / 3), 0.5)),
                scene_graph::Status::kOk);
      ASSERT_EQ(g.add_edge(rid, pid), scene_graph::Status::kOk);
      if (i > 0) {
        ASSERT_EQ(g.add_edge(make_node_id('p', 10 * r + i - 1), pid), scene_graph::Status::kOk);
      }
      scene_graph::ObjectAttributes o;
      o.position_m = {1 + 5 * r + 1.5 * (i % 3), 2.5 + 1.5 * (i / 3), 0.4};
      ASSERT_EQ(g.add_object(make_node_id('O', 10 * r + i), o), scene_graph::Status::kOk);
      ASSERT_EQ(g.add_edge(pid, make_node_id('O', 10 * r + i)), scene_graph::Status::kOk);
    }
  }
  for (int k = 0; k < 20; ++k) {
    scene_graph::AgentAttributes a;
    a.position_m = {0.5 + 0.45 * k, 1.0, 0.5};
    a.timestamp_ns = 1000000000ull * k;
    ASSERT_EQ(g.add_agent(make_node_id('a', k), 'a', a), scene_graph::Status::kOk);
  }
}

// A 10 m x 8 m floor labelled "floor".
reconstruction::Mesh floor_mesh() {
  reconstruction::Mesh m;
  for (int y = 0; y <= 8; ++y)
    for (int x = 0; x <= 10; ++x) m.vertices.push_back({static_cast<float>(x), static_cast<float>(y), 0.0f, 0, 0, 0, semantics::kFloor});
  for (std::uint32_t y = 0; y < 8; ++y)
    for (std::uint32_t x = 0; x < 10; ++x) {
      const std::uint32_t v = y * 11 + x;
      m.triangles.push_back({{v, v + 1, v + 12}});
      m.triangles.push_back({{v, v + 12, v + 11}});
    }
  return m;
}

std::string chromium() {
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"})
    if (std::system(("command -v " + std::string(name) + " > /dev/null 2>&1").c_str()) == 0) return name;
  return "";
}

// Pixels of exactly this colour in the drawing, outside the layer panel at the top left (its swatches have the
// layers' colours too).
std::size_t pixels_of(const cv::Mat& bgr, const std::array<std::uint8_t, 3>& rgb) {
  std::size_t n = 0;
  for (int r = 0; r < bgr.rows; ++r)
    for (int c = r < 280 ? 340 : 0; c < bgr.cols; ++c) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(r, c);
      n += p[2] == rgb[0] && p[1] == rgb[1] && p[0] == rgb[2] ? 1 : 0;
    }
  return n;
}

TEST(GraphViewerTest, PageDrawsEveryLayerInHeadlessChromium) {
  if (testing::running_emulated()) GTEST_SKIP() << "under qemu-user: no browser to start";
  const std::string browser = chromium();
  if (browser.empty()) GTEST_SKIP() << "chromium not installed (toolchains/install_deps.sh installs it); skipping";
  if (find_three_js().empty()) GTEST_SKIP() << "three.js not found (libjs-three; toolchains/install_deps.sh); skipping";
  auto g = scene_graph::testing::make_graph();
  build(*g);
  const reconstruction::Mesh mesh = floor_mesh();
  scene_graph::LabelSpaces labels;
  labels.rooms = {{semantics::kKitchen, "kitchen"}, {semantics::kBedroom, "bedroom"}};
  std::string html, error;
  ASSERT_TRUE(graph_viewer_html(*g, labels, &mesh, ViewerConfig{}, &html, &error)) << error;
  // Nothing to fetch: three scripts inline, no element that loads from elsewhere.
  std::size_t scripts = 0;
  for (std::size_t at = html.find("<script"); at != std::string::npos; at = html.find("<script", at + 1)) {
    ++scripts;
    EXPECT_EQ(html.compare(at, 8, "<script>"), 0) << "a script with attributes (src?) at byte " << at;
  }
  EXPECT_EQ(scripts, 3u);
  for (const char* tag : {"<link", "<img", "<iframe", "@import"})
    EXPECT_EQ(html.find(tag), std::string::npos) << tag;
  const std::string dir = ::testing::TempDir() + "/qsg_viewer_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string page = dir + "/scene_graph.html";
  std::ofstream(page) << html;

  const auto screenshot = [&](const std::string& hash, const std::string& png) {
    const std::string cmd = "timeout 120 " + browser + " --headless --no-sandbox --disable-gpu --use-angle=swiftshader "
                            "--enable-unsafe-swiftshader --hide-scrollbars --user-data-dir=" + dir + "/profile " +
                            "--window-size=1000,700 --virtual-time-budget=5000 --screenshot=" + png + " 'file://" +
                            page + hash + "' > " + dir + "/chromium.log 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    return cv::imread(png, cv::IMREAD_COLOR);
  };
  const std::array<std::uint8_t, 3> floor = semantics::object_label(semantics::kFloor).color;
  const cv::Mat all = screenshot("", dir + "/all.png");
  ASSERT_FALSE(all.empty()) << "no screenshot; see " << dir << "/chromium.log";
  EXPECT_GT(pixels_of(all, floor), 20000u) << "the mesh";
  EXPECT_GT(pixels_of(all, kViewerObjectColor), 18 * 20u) << "objects";
  EXPECT_GT(pixels_of(all, kViewerAgentColor), 20 * 8u) << "agents";
  EXPECT_GT(pixels_of(all, kViewerPlaceColor), 18 * 15u) << "places";
  EXPECT_GT(pixels_of(all, kViewerRoomColor), 2 * 60u) << "rooms";
  EXPECT_GT(pixels_of(all, kViewerBuildingColor), 100u) << "building";
  // The toggles (set from the page's address here) hide what they name and nothing else.
  const cv::Mat some = screenshot("#hide=mesh,objects,rooms", dir + "/some.png");
  ASSERT_FALSE(some.empty());
  EXPECT_EQ(pixels_of(some, floor), 0u);
  EXPECT_EQ(pixels_of(some, kViewerObjectColor), 0u);
  EXPECT_EQ(pixels_of(some, kViewerRoomColor), 0u);
  EXPECT_GT(pixels_of(some, kViewerPlaceColor), 18 * 15u);
  EXPECT_GT(pixels_of(some, kViewerBuildingColor), 100u);
}

// The top-down picture names each room at its node: dark text where the picture without names has none.
TEST(GraphPictureTest, RoomsAreNamedOnTheTopDownPicture) {
  auto g = scene_graph::testing::make_graph();
  build(*g);
  const std::string dir = ::testing::TempDir() + "/qsg_picture_names";
  std::filesystem::create_directories(dir);
  std::string error;
  GraphPictureConfig named, plain;
  plain.draw_room_names = false;
  ASSERT_TRUE(write_graph_picture(*g, world::World(), {}, dir + "/named.png", &error, named)) << error;
  ASSERT_TRUE(write_graph_picture(*g, world::World(), {}, dir + "/plain.png", &error, plain)) << error;
  const cv::Mat a = cv::imread(dir + "/named.png", cv::IMREAD_COLOR), b = cv::imread(dir + "/plain.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size());
  const auto text_pixels = [](const cv::Mat& m) {
    std::size_t n = 0;
    for (int r = 0; r < m.rows; ++r)
      for (int c = 0; c < m.cols; ++c) n += m.at<cv::Vec3b>(r, c) == cv::Vec3b(40, 40, 40) ? 1 : 0;
    return n;
  };
  EXPECT_EQ(text_pixels(b), 0u);
  EXPECT_GT(text_pixels(a), 200u) << "two room names";
  // Both names sit at their rooms: dark pixels in each half of the picture (the rooms are 5 m apart along x).
  std::size_t left = 0, right = 0;
  for (int r = 0; r < a.rows; ++r)
    for (int c = 0; c < a.cols; ++c)
      if (a.at<cv::Vec3b>(r, c) == cv::Vec3b(40, 40, 40)) ++(c < a.cols / 2 ? left : right);
  EXPECT_GT(left, 50u);
  EXPECT_GT(right, 50u);
}

}  // namespace
}  // namespace qsg::app

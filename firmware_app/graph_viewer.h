// A self-contained 3D view of a scene graph in the browser (scene_graph.html): the mesh coloured by label at the
// bottom and the layers stacked above it as in the paper's figures (objects and agents where they are, places,
// rooms with their names and the building raised above), edges within and between layers, a toggle per layer and
// a click on a node to see its attributes. three.js (Debian's libjs-three) is inlined: nothing is fetched when the
// page is viewed. Off the real-time path (heap).
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"
#include "core/scene_graph/spark_dsg_json.h"

namespace qsg::app {

struct ViewerConfig {
  double place_lift_m = 3.0;     // places drawn this far above where they are
  double room_lift_m = 6.0;
  double building_lift_m = 9.0;
  std::string three_js_path;     // empty: find_three_js()
  void print(std::FILE* out) const;
};

// The layer colours the page draws nodes in (the CI's screenshot check looks for them).
inline constexpr std::array<std::uint8_t, 3> kViewerObjectColor{{255, 0, 0}};
inline constexpr std::array<std::uint8_t, 3> kViewerAgentColor{{255, 0, 255}};
inline constexpr std::array<std::uint8_t, 3> kViewerPlaceColor{{0, 0, 255}};
inline constexpr std::array<std::uint8_t, 3> kViewerRoomColor{{0, 192, 0}};
inline constexpr std::array<std::uint8_t, 3> kViewerBuildingColor{{0, 255, 255}};

// three.js to inline: $QSG_THREE_JS when set, else Debian's libjs-three (/usr/share/javascript/three/three.min.js);
// empty when neither exists.
std::string find_three_js();

// The page, into *html. mesh may be null (no mesh drawn). False with the reason in *error (three.js missing).
bool graph_viewer_html(const scene_graph::SceneGraph& graph, const scene_graph::LabelSpaces& labels,
                       const reconstruction::Mesh* mesh, const ViewerConfig& config, std::string* html, std::string* error);

}  // namespace qsg::app

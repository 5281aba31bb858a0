// The browser view of a scene graph (see graph_viewer.h): data as JSON and base64 arrays in one page with three.js.
#include "firmware_app/graph_viewer.h"

#include <algorithm>
#include <cinttypes>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "core/semantics/labels.h"
#include "firmware_app/viewer_page.h"

namespace qsg::app {
namespace {

using json = nlohmann::json;
using scene_graph::NodeKind;
using scene_graph::NodeRecord;

std::string base64(const void* data, std::size_t size) {
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const std::uint32_t v = (p[i] << 16) | (i + 1 < size ? p[i + 1] << 8 : 0) | (i + 2 < size ? p[i + 2] : 0);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < size ? kAlphabet[v & 63] : '=';
  }
  return out;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return in ? s.str() : std::string();
}

std::string format(const char* fmt, double a, double b, double c) {
  char text[128];
  std::snprintf(text, sizeof(text), fmt, a, b, c);
  return text;
}

struct LayerOut {
  const char* key;
  const char* title;
  std::array<std::uint8_t, 3> color;
  double lift_m;
  int size_px;
  json positions = json::array();
  json edges = json::array();
  json info = json::array();
};

std::string label_name(const std::map<std::uint32_t, std::string>& space, std::uint32_t label) {
  const auto it = space.find(label);
  return it == space.end() ? "label " + std::to_string(label) : it->second;
}

// What a click on the node shows.
std::string node_info(const scene_graph::SceneGraph& g, const scene_graph::LabelSpaces& labels, const NodeRecord& n) {
  std::string s = scene_graph::node_label(n.id) + "  " + scene_graph::to_string(n.kind) + "  (id " + std::to_string(n.id) + ")\n";
  const auto semantic = [&](const scene_graph::SemanticAttributes& a, const std::map<std::uint32_t, std::string>* space) {
    s += "name: " + std::string(a.name.c_str(), a.name.size()) + "\n";
    if (space != nullptr) s += "label: " + label_name(*space, a.semantic_label) + " (" + std::to_string(a.semantic_label) + ")\n";
    s += format("position: %.2f %.2f %.2f m\n", a.position_m.x(), a.position_m.y(), a.position_m.z());
    if (a.bounding_box.type != scene_graph::BoundingBox::Type::kInvalid) {
      const Eigen::Vector3d d = a.bounding_box.max_m - a.bounding_box.min_m;
      s += format("box: %.2f x %.2f x %.2f m\n", d.x(), d.y(), d.z());
    }
  };
  switch (n.kind) {
    case NodeKind::kObject:
      semantic(*g.object(n.id), &labels.objects);
      s += "mesh connections: " + std::to_string(g.num_mesh_connections(n.id)) + "\n";
      break;
    case NodeKind::kPlace:
      semantic(*g.place(n.id), nullptr);
      s += "clearance: " + format("%.2f m\n", g.place(n.id)->distance_m, 0, 0);
      break;
    case NodeKind::kRoom: {
      const scene_graph::RoomAttributes& r = *g.room(n.id);
      semantic(r, &labels.rooms);
      std::string classes;
      for (std::size_t i = 0; i < r.class_probabilities.size() && i < 4; ++i)
        classes += (i ? ", " : "") + label_name(labels.rooms, r.class_probabilities[i].label) +
                   format(" %.2f", r.class_probabilities[i].probability, 0, 0);
      if (!classes.empty()) s += "classes: " + classes + "\n";
      break;
    }
    case NodeKind::kBuilding: semantic(*g.building(n.id), nullptr); break;
    case NodeKind::kAgent: {
      const scene_graph::AgentAttributes& a = *g.agent(n.id);
      s += format("position: %.2f %.2f %.2f m\n", a.position_m.x(), a.position_m.y(), a.position_m.z());
      s += "timestamp: " + std::to_string(a.timestamp_ns) + " ns\n";
      break;
    }
  }
  s += "parent: " + (n.parent == scene_graph::kNoNode ? std::string("none") : scene_graph::node_label(n.parent)) +
       ", children: " + std::to_string(n.num_children) + ", edges: " + std::to_string(n.degree);
  return s;
}

}  // namespace

void ViewerConfig::print(std::FILE* out) const {
  std::fprintf(out, "viewer: place_lift_m=%.1f room_lift_m=%.1f building_lift_m=%.1f three_js=%s\n", place_lift_m,
               room_lift_m, building_lift_m, three_js_path.empty() ? "(libjs-three)" : three_js_path.c_str());
}

std::string find_three_js() {
  if (const char* env = std::getenv("QSG_THREE_JS"); env != nullptr && *env != '\0') return env;
  const char* debian = "/usr/share/javascript/three/three.min.js";
  std::ifstream probe(debian);
  return probe ? debian : "";
}

bool graph_viewer_html(const scene_graph::SceneGraph& graph, const scene_graph::LabelSpaces& labels,
                       const reconstruction::Mesh* mesh, const ViewerConfig& config, std::string* html, std::string* error) {
  const std::string three_path = config.three_js_path.empty() ? find_three_js() : config.three_js_path;
  const std::string three = three_path.empty() ? std::string() : read_file(three_path);
  if (three.empty() || three.find("</script") != std::string::npos) {
    *error = "three.js not found or unusable ('" + three_path + "'; install libjs-three or set QSG_THREE_JS)";
    return false;
  }
  std::vector<LayerOut> layers = {{"objects", "objects", kViewerObjectColor, 0.0, 9},
                                  {"agents", "agents", kViewerAgentColor, 0.0, 5},
                                  {"places", "places", kViewerPlaceColor, config.place_lift_m, 7},
                                  {"rooms", "rooms", kViewerRoomColor, config.room_lift_m, 14},
                                  {"buildings", "building", kViewerBuildingColor, config.building_lift_m, 16}};
  const auto layer_of = [](NodeKind k) {
    switch (k) {
      case NodeKind::kObject: return 0;
      case NodeKind::kAgent: return 1;
      case NodeKind::kPlace: return 2;
      case NodeKind::kRoom: return 3;
      case NodeKind::kBuilding: return 4;
    }
    return 0;
  };
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e30), hi = Eigen::Vector3d::Constant(-1e30);
  const auto drawn_at = [&](const NodeRecord& n) {
    Eigen::Vector3d p = n.kind == NodeKind::kAgent ? graph.agent(n.id)->position_m
                        : n.kind == NodeKind::kObject ? graph.object(n.id)->position_m
                        : n.kind == NodeKind::kPlace  ? graph.place(n.id)->position_m
                        : n.kind == NodeKind::kRoom   ? graph.room(n.id)->position_m
                                                      : graph.building(n.id)->position_m;
    p.z() += layers[layer_of(n.kind)].lift_m;
    return p;
  };
  json room_names = json::array();
  graph.for_each_node([&](const NodeRecord& n) {
    LayerOut& l = layers[layer_of(n.kind)];
    const Eigen::Vector3d p = drawn_at(n);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    for (int k = 0; k < 3; ++k) l.positions.push_back(p[k]);
    l.info.push_back(node_info(graph, labels, n));
    if (n.kind == NodeKind::kRoom) {
      const scene_graph::RoomAttributes& r = *graph.room(n.id);
      const auto it = labels.rooms.find(r.semantic_label);
      const std::string text = it != labels.rooms.end() && r.semantic_label != 0 ? it->second
                                                                                 : std::string(r.name.c_str(), r.name.size());
      room_names.push_back({{"text", text}, {"position", {p.x(), p.y(), p.z() + 0.9}}});
    }
  });
  json interlayer = json::array();
  graph.for_each_edge([&](const scene_graph::EdgeRecord& e) {
    const NodeRecord* a = graph.node(e.source);
    const NodeRecord* b = graph.node(e.target);
    if (a == nullptr || b == nullptr) return;
    json& out = a->kind == b->kind ? layers[layer_of(a->kind)].edges : interlayer;
    for (const Eigen::Vector3d& p : {drawn_at(*a), drawn_at(*b)})
      for (int k = 0; k < 3; ++k) out.push_back(p[k]);
  });
  json data;
  data["title"] = "scene graph: " + std::to_string(graph.num_nodes()) + " nodes, " + std::to_string(graph.num_edges()) + " edges";
  data["layers"] = json::array();
  for (const LayerOut& l : layers)
    data["layers"].push_back({{"key", l.key}, {"title", l.title}, {"color", l.color}, {"size_px", l.size_px},
                              {"positions", l.positions}, {"edges", l.edges}, {"info", l.info}});
  data["interlayer"] = std::move(interlayer);
  data["labels"] = std::move(room_names);
  data["label_height_m"] = 0.7;
  data["mesh"] = nullptr;
  if (mesh != nullptr && !mesh->triangles.empty()) {
    std::vector<float> xyz;
    std::vector<std::uint8_t> rgb;
    std::vector<std::uint32_t> indices;
    xyz.reserve(3 * mesh->vertices.size());
    rgb.reserve(3 * mesh->vertices.size());
    for (const reconstruction::MeshVertex& v : mesh->vertices) {
      xyz.insert(xyz.end(), {v.x, v.y, v.z});
      lo = lo.cwiseMin(Eigen::Vector3d(v.x, v.y, v.z));
      hi = hi.cwiseMax(Eigen::Vector3d(v.x, v.y, v.z));
      const std::array<std::uint8_t, 3> c = v.label < semantics::kNumObjectLabels ? semantics::object_label(v.label).color
                                                                                   : std::array<std::uint8_t, 3>{{128, 128, 128}};
      rgb.insert(rgb.end(), c.begin(), c.end());
    }
    for (const reconstruction::MeshTriangle& t : mesh->triangles) indices.insert(indices.end(), t.v, t.v + 3);
    data["mesh"] = {{"positions", base64(xyz.data(), xyz.size() * sizeof(float))},
                    {"colors", base64(rgb.data(), rgb.size())},
                    {"indices", base64(indices.data(), indices.size() * sizeof(std::uint32_t))}};
  }
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector3d::Zero();
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  data["center"] = {centre.x(), centre.y(), centre.z()};
  data["radius"] = std::max(1.0, 0.5 * (hi - lo).norm());
  std::string text = data.dump();
  for (std::size_t at = text.find("</"); at != std::string::npos; at = text.find("</", at + 3)) text.replace(at, 2, "<\\/");

  *html = std::string(viewer_page::kHead) + "<script>\n" + three + "\n</script>\n<script>const QSG_DATA = " + text +
          ";</script>\n<script>" + viewer_page::kViewer + "</script>\n</body></html>\n";
  return true;
}

}  // namespace qsg::app

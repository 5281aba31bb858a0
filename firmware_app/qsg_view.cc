// qsg_view: a self-contained 3D view of a Spark-DSG scene graph (and its mesh) in the browser.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "core/reconstruction/ply_writer.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "firmware_app/graph_viewer.h"

int main(int argc, char** argv) {
  using namespace qsg;
  std::string graph_path, mesh_path, out_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) out_path = argv[++i];
    else if (a == "-h" || a == "--help") graph_path.clear(), i = argc;
    else if (graph_path.empty()) graph_path = a;
    else if (mesh_path.empty()) mesh_path = a;
    else graph_path.clear(), i = argc;
  }
  if (graph_path.empty()) {
    std::fprintf(stderr,
                 "usage: qsg_view GRAPH.json [MESH.ply] [--out PAGE.html]\n"
                 "  Writes one self-contained page (default scene_graph.html beside GRAPH.json): the mesh coloured by\n"
                 "  label and the graph's layers stacked above it, with toggles and node attributes on click. three.js\n"
                 "  comes from Debian's libjs-three (or $QSG_THREE_JS) and is inlined.\n");
    return 2;
  }
  if (out_path.empty()) {
    const std::size_t slash = graph_path.rfind('/');
    out_path = (slash == std::string::npos ? std::string() : graph_path.substr(0, slash + 1)) + "scene_graph.html";
  }
  scene_graph::SceneGraph graph;
  std::string error;
  if (!graph.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "qsg_view: %s\n", error.c_str());
    return 1;
  }
  const scene_graph::JsonImportResult r = scene_graph::read_spark_dsg_json_file(graph_path, graph);
  if (!r.ok) {
    std::fprintf(stderr, "qsg_view: %s\n", r.error.c_str());
    return 1;
  }
  reconstruction::Mesh mesh;
  if (!mesh_path.empty() && !reconstruction::read_ply(mesh_path, &mesh, &error)) {
    std::fprintf(stderr, "qsg_view: %s\n", error.c_str());
    return 1;
  }
  std::string html;
  if (!app::graph_viewer_html(graph, r.labelspaces, mesh_path.empty() ? nullptr : &mesh, app::ViewerConfig{}, &html,
                              &error)) {
    std::fprintf(stderr, "qsg_view: %s\n", error.c_str());
    return 1;
  }
  std::ofstream out(out_path, std::ios::binary | std::ios::trunc);
  out << html;
  out.flush();
  if (!out) {
    std::fprintf(stderr, "qsg_view: cannot write '%s'\n", out_path.c_str());
    return 1;
  }
  std::printf("qsg_view: %s (%zu nodes%s) -> %s (%.1f MB)\n", graph_path.c_str(), graph.num_nodes(),
              mesh_path.empty() ? "" : (", " + std::to_string(mesh.triangles.size()) + " triangles").c_str(),
              out_path.c_str(), html.size() / 1048576.0);
  return 0;
}

// Label names and mesh-vertex indices for the written scene graphs (see graph_outputs.h).
#include "firmware_app/graph_outputs.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "core/semantics/labels.h"
#include "firmware_app/graph_viewer.h"
#include "firmware_app/pipeline.h"

namespace qsg::app {
namespace {

std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  const auto pack = [](std::int64_t v) { return static_cast<std::uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
  return (pack(x) << 42) | (pack(y) << 21) | pack(z);
}

}  // namespace

const scene_graph::LabelSpaces& app_label_spaces() {
  static const scene_graph::LabelSpaces spaces = [] {
    scene_graph::LabelSpaces s;
    for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) s.objects[l] = semantics::object_label(l).name;
    for (semantics::RoomLabel l = 0; l < semantics::kNumRoomLabels; ++l) s.rooms[l] = semantics::room_label_name(l);
    return s;
  }();
  return spaces;
}

scene_graph::ObjectMeshIndices object_mesh_indices(const objects::ObjectLayer& objects,
                                                   const reconstruction::SemanticTsdf& tsdf,
                                                   const reconstruction::Mesh& mesh, std::size_t* unmatched) {
  const double cell_m = tsdf.config().voxel_size_m;
  const double radius_m = 1.5 * cell_m;
  const auto cell_of = [&](double v) { return static_cast<std::int64_t>(std::floor(v / cell_m)); };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  grid.reserve(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const reconstruction::MeshVertex& v = mesh.vertices[i];
    grid[cell_key(cell_of(v.x), cell_of(v.y), cell_of(v.z))].push_back(static_cast<std::uint32_t>(i));
  }
  scene_graph::ObjectMeshIndices out;
  std::size_t missed = 0;
  objects.for_each_object([&](const objects::ObjectView& o) {
    std::vector<std::uint32_t>& indices = out[o.node];
    objects.for_each_vertex_key(o.node, [&](std::uint64_t key) {
      const Eigen::Vector3d p = tsdf.vertex_key_edge_middle_m(key);
      const std::int64_t cx = cell_of(p.x()), cy = cell_of(p.y()), cz = cell_of(p.z());
      double best_m = radius_m;
      std::uint32_t best = memory::kInvalidHandle;
      for (std::int64_t dx = -2; dx <= 2; ++dx)
        for (std::int64_t dy = -2; dy <= 2; ++dy)
          for (std::int64_t dz = -2; dz <= 2; ++dz) {
            const auto it = grid.find(cell_key(cx + dx, cy + dy, cz + dz));
            if (it == grid.end()) continue;
            for (std::uint32_t i : it->second) {
              const reconstruction::MeshVertex& v = mesh.vertices[i];
              const double d = (Eigen::Vector3d(v.x, v.y, v.z) - p).norm();
              if (d <= best_m) {
                best_m = d;
                best = i;
              }
            }
          }
      if (best == memory::kInvalidHandle) ++missed;
      else indices.push_back(best);
    });
    std::sort(indices.begin(), indices.end());
    indices.erase(std::unique(indices.begin(), indices.end()), indices.end());
  });
  if (unmatched != nullptr) *unmatched = missed;
  return out;
}

scene_graph::EmbeddedMesh embedded_mesh(const reconstruction::Mesh& mesh) {
  scene_graph::EmbeddedMesh out;
  for (const reconstruction::MeshVertex& v : mesh.vertices) {
    out.xyz.insert(out.xyz.end(), {v.x, v.y, v.z});
    out.rgb.insert(out.rgb.end(), {v.r, v.g, v.b});
    out.labels.push_back(v.label);
  }
  for (const reconstruction::MeshTriangle& t : mesh.triangles) out.faces.insert(out.faces.end(), t.v, t.v + 3);
  return out;
}

scene_graph::JsonExportOptions snapshot_graph_options() {
  scene_graph::JsonExportOptions options;
  options.labelspaces = &app_label_spaces();
  options.write_stored_mesh_connections = false;
  return options;
}

void write_final_graph(const scene_graph::SceneGraph& graph, const scene_graph::ObjectMeshIndices& indices,
                       const reconstruction::Mesh& mesh, const std::string& dir, std::string* failures,
                       bool* viewer_written) {
  const auto failed = [&](const std::string& why) { *failures += (failures->empty() ? "" : "; ") + why; };
  scene_graph::JsonExportOptions options;
  options.labelspaces = &app_label_spaces();
  options.object_mesh_indices = &indices;
  std::string why;
  if (!write_file_atomically(dir + "/scene_graph.json", scene_graph::write_spark_dsg_json(graph, options), &why)) failed(why);
  // The browser view needs three.js (Debian's libjs-three): where it is missing the page is left out.
  std::string html;
  why.clear();
  *viewer_written = false;
  if (!graph_viewer_html(graph, app_label_spaces(), &mesh, ViewerConfig{}, &html, &why))
    std::printf("viewer: scene_graph.html not written: %s\n", why.c_str());
  else if (!write_file_atomically(dir + "/scene_graph.html", html, &why)) failed(why);
  else *viewer_written = true;
}

}  // namespace qsg::app

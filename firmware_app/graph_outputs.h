// What the written scene graphs carry beyond the graph itself: the label names of this system (objects: mpcat40,
// rooms: the paper's room labels) and the objects' mesh connections as indices into the written mesh.
#pragma once

#include <cstddef>
#include <string>

#include "core/objects/object_layer.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/spark_dsg_json.h"

namespace qsg::app {

// Every object label and every room label with its name.
const scene_graph::LabelSpaces& app_label_spaces();

// Each object's kept mesh-vertex keys matched to the nearest vertex of `mesh` (the mesh as written: extracted and
// cleaned) within 1.5 voxels of the key's voxel edge; sorted, without repeats. Keys with no vertex that near (the
// surface was re-meshed or merged away) are counted in *unmatched. Off the real-time path (heap).
scene_graph::ObjectMeshIndices object_mesh_indices(const objects::ObjectLayer& objects,
                                                   const reconstruction::SemanticTsdf& tsdf,
                                                   const reconstruction::Mesh& mesh, std::size_t* unmatched);

// The mesh as Spark-DSG embeds it in a graph file (vertex colours and labels kept).
scene_graph::EmbeddedMesh embedded_mesh(const reconstruction::Mesh& mesh);

// A snapshot's export options: the label names, and no object mesh connections (no mesh goes with a snapshot).
scene_graph::JsonExportOptions snapshot_graph_options();

// The final scene_graph.json (label names; objects' mesh connections: `indices`, into `mesh`, the mesh as written,
// from object_mesh_indices() and any reconciliation after a loop-closure correction) and, where three.js is
// installed, scene_graph.html (graph_viewer.h), each replaced atomically in dir. A failure is appended to
// *failures ("; " between); *viewer_written says whether the page was written (its absence is no failure).
void write_final_graph(const scene_graph::SceneGraph& graph, const scene_graph::ObjectMeshIndices& indices,
                       const reconstruction::Mesh& mesh, const std::string& dir, std::string* failures,
                       bool* viewer_written);

}  // namespace qsg::app

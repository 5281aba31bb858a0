// Binary little-endian PLY export of a labelled mesh (x y z, red green blue, label; triangle faces), with the
// standard property names Open3D and MeshLab read, and a reader for files this writer produced.
#pragma once

#include <string>

#include "core/reconstruction/semantic_tsdf.h"

namespace qsg::reconstruction {

// Writes `mesh` to `path`. False with the file and the reason in *error on failure.
bool write_ply(const std::string& path, const Mesh& mesh, std::string* error);
// Reads a binary little-endian PLY with exactly the layout write_ply produces. False with the file, the header
// line or the element and the reason in *error on failure.
bool read_ply(const std::string& path, Mesh* mesh, std::string* error);

}  // namespace qsg::reconstruction

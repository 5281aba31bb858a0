// PLY export and re-import of labelled meshes (see ply_writer.h).
#include "core/reconstruction/ply_writer.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

namespace qsg::reconstruction {
namespace {

constexpr const char* kVertexProperties[] = {"property float x",        "property float y",
                                             "property float z",        "property uchar red",
                                             "property uchar green",     "property uchar blue",
                                             "property int label"};
constexpr const char* kFaceProperty = "property list uchar int vertex_indices";
// The label as a 32-bit "int": every common reader knows it (meshio, for one, refuses "ushort").
constexpr std::size_t kVertexBytes = 3 * 4 + 3 + 4;
constexpr std::size_t kFaceBytes = 1 + 3 * 4;

// Little-endian byte copies that do not depend on the host's byte order.
void put_u32(unsigned char* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
std::uint32_t get_u32(const unsigned char* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
void put_f32(unsigned char* p, float f) {
  std::uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(p, v);
}
float get_f32(const unsigned char* p) {
  const std::uint32_t v = get_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

}  // namespace

bool write_ply(const std::string& path, const Mesh& mesh, std::string* error) {
  std::ofstream out(path, std::ios::binary);
  if (!out) {
    if (error != nullptr) *error = path + ": cannot open for writing";
    return false;
  }
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment quadsg semantic mesh (label: core/semantics)\n"
         << "element vertex " << mesh.vertices.size() << "\n";
  for (const char* p : kVertexProperties) header << p << "\n";
  header << "element face " << mesh.triangles.size() << "\n" << kFaceProperty << "\nend_header\n";
  const std::string h = header.str();
  out.write(h.data(), static_cast<std::streamsize>(h.size()));
  std::vector<unsigned char> buf(mesh.vertices.size() * kVertexBytes);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const MeshVertex& v = mesh.vertices[i];
    unsigned char* p = &buf[i * kVertexBytes];
    put_f32(p, v.x);
    put_f32(p + 4, v.y);
    put_f32(p + 8, v.z);
    p[12] = v.r;
    p[13] = v.g;
    p[14] = v.b;
    put_u32(p + 15, v.label);
  }
  out.write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
  buf.assign(mesh.triangles.size() * kFaceBytes, 0);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    unsigned char* p = &buf[i * kFaceBytes];
    p[0] = 3;
    for (int k = 0; k < 3; ++k) put_u32(p + 1 + 4 * k, mesh.triangles[i].v[k]);
  }
  out.write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
  out.flush();
  if (!out) {
    if (error != nullptr) *error = path + ": write failed";
    return false;
  }
  return true;
}

bool read_ply(const std::string& path, Mesh* mesh, std::string* error) {
  const auto fail = [&](const std::string& why) {
    if (error != nullptr) *error = path + ": " + why;
    return false;
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot open");
  std::string line;
  int line_no = 0;
  const auto expect = [&](const std::string& want) {
    ++line_no;
    if (!std::getline(in, line) || line != want)
      return fail("header line " + std::to_string(line_no) + ": expected '" + want + "', got '" + line + "'");
    return true;
  };
  if (!expect("ply") || !expect("format binary_little_endian 1.0")) return false;
  std::size_t num_vertices = 0, num_faces = 0;
  // Comments may follow the format line.
  while (true) {
    ++line_no;
    if (!std::getline(in, line)) return fail("header ends early at line " + std::to_string(line_no));
    if (line.rfind("comment", 0) == 0) continue;
    if (std::sscanf(line.c_str(), "element vertex %zu", &num_vertices) != 1)
      return fail("header line " + std::to_string(line_no) + ": expected 'element vertex N'");
    break;
  }
  for (const char* p : kVertexProperties)
    if (!expect(p)) return false;
  ++line_no;
  if (!std::getline(in, line) || std::sscanf(line.c_str(), "element face %zu", &num_faces) != 1)
    return fail("header line " + std::to_string(line_no) + ": expected 'element face N'");
  if (!expect(kFaceProperty) || !expect("end_header")) return false;
  std::vector<unsigned char> buf(num_vertices * kVertexBytes);
  if (!in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size())))
    return fail("vertex data truncated (" + std::to_string(num_vertices) + " vertices declared)");
  mesh->vertices.resize(num_vertices);
  mesh->vertex_time_ns.clear();  // not in the file
  for (std::size_t i = 0; i < num_vertices; ++i) {
    const unsigned char* p = &buf[i * kVertexBytes];
    MeshVertex& v = mesh->vertices[i];
    v.x = get_f32(p);
    v.y = get_f32(p + 4);
    v.z = get_f32(p + 8);
    v.r = p[12];
    v.g = p[13];
    v.b = p[14];
    const std::uint32_t label = get_u32(p + 15);
    if (label > 0xFFFF) return fail("vertex " + std::to_string(i) + ": label " + std::to_string(label) + " out of range");
    v.label = static_cast<semantics::Label>(label);
  }
  buf.assign(num_faces * kFaceBytes, 0);
  if (!in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size())))
    return fail("face data truncated (" + std::to_string(num_faces) + " faces declared)");
  mesh->triangles.resize(num_faces);
  for (std::size_t i = 0; i < num_faces; ++i) {
    const unsigned char* p = &buf[i * kFaceBytes];
    if (p[0] != 3) return fail("face " + std::to_string(i) + ": not a triangle");
    for (int k = 0; k < 3; ++k) {
      mesh->triangles[i].v[k] = get_u32(p + 1 + 4 * k);
      if (mesh->triangles[i].v[k] >= num_vertices)
        return fail("face " + std::to_string(i) + ": vertex index out of range");
    }
  }
  return true;
}

}  // namespace qsg::reconstruction

// Ground truth: voxel occupancy from the world's exact geometry, an exact Euclidean feature transform
// (separable lower envelopes, Felzenszwalb and Huttenlocher), the theta-SMA skeleton, and the files it is written to.
#include "drivers/sim/ground_truth.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

namespace qsg::sim {
namespace {

constexpr double kInf = 1e30;

// One 1D pass of the squared-distance transform with features: f and feature along a line of n samples with
// stride; writes the lower envelope of parabolas q -> f(q) + (p - q)^2.
void envelope_pass(double* f, std::int32_t* feature, std::size_t n, std::size_t stride, std::vector<double>& fq,
                   std::vector<std::int32_t>& featq, std::vector<int>& v, std::vector<double>& z) {
  fq.resize(n);
  featq.resize(n);
  for (std::size_t q = 0; q < n; ++q) {
    fq[q] = f[q * stride];
    featq[q] = feature[q * stride];
  }
  v.resize(n);
  z.resize(n + 1);
  int k = -1;
  for (int q = 0; q < static_cast<int>(n); ++q) {
    if (fq[static_cast<std::size_t>(q)] >= kInf) continue;
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    double s;
    while (true) {
      const int r = v[static_cast<std::size_t>(k)];
      s = ((fq[static_cast<std::size_t>(q)] + double(q) * q) - (fq[static_cast<std::size_t>(r)] + double(r) * r)) /
          (2.0 * (q - r));
      if (s <= z[static_cast<std::size_t>(k)] && k > 0) {
        --k;
        continue;
      }
      break;
    }
    if (s <= z[static_cast<std::size_t>(k)]) {  // k == 0 and the new parabola dominates everywhere
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    ++k;
    v[static_cast<std::size_t>(k)] = q;
    z[static_cast<std::size_t>(k)] = s;
    z[static_cast<std::size_t>(k) + 1] = kInf;
  }
  if (k < 0) return;  // nothing on this line: leave it infinite
  int j = 0;
  for (int p = 0; p < static_cast<int>(n); ++p) {
    while (z[static_cast<std::size_t>(j) + 1] < p) ++j;
    const int r = v[static_cast<std::size_t>(j)];
    f[static_cast<std::size_t>(p) * stride] = fq[static_cast<std::size_t>(r)] + double(p - r) * (p - r);
    feature[static_cast<std::size_t>(p) * stride] = featq[static_cast<std::size_t>(r)];
  }
}

}  // namespace

void GroundTruthConfig::print(std::FILE* out) const {
  std::fprintf(out, "ground truth: voxel %.3f m, max clearance %.2f m, GVD min clearance %.2f m, theta %.1f deg\n",
               voxel_size_m, max_clearance_m, gvd_min_clearance_m, gvd_min_angle_rad * 180.0 / 3.14159265358979);
}

double GroundTruth::distance_to_gvd(const Eigen::Vector3d& p_m) const {
  double best = std::numeric_limits<double>::infinity();
  const Eigen::Vector3f p = p_m.cast<float>();
  for (const GvdVoxel& g : gvd) best = std::min(best, static_cast<double>((g.position_m - p).squaredNorm()));
  return std::sqrt(best);
}

bool compute_ground_truth(const world::World& world, const world::FreeSpaceIndex& free_space,
                          const GroundTruthConfig& config, GroundTruth* truth, std::string* error,
                          std::size_t max_voxels) {
  if (!(config.voxel_size_m > 0.005)) {
    if (error != nullptr) *error = "ground truth: voxel_size_m must be above 0.005";
    return false;
  }
  const world::Aabb bounds = world::world_bounds(world);
  if (bounds.empty()) {
    if (error != nullptr) *error = "ground truth: the world is empty";
    return false;
  }
  GroundTruth& t = *truth;
  t = GroundTruth{};
  t.config = config;
  const double s = config.voxel_size_m;
  t.origin_m = bounds.min_m - Eigen::Vector3d::Constant(s);
  const Eigen::Vector3d extent = bounds.size_m() + Eigen::Vector3d::Constant(2 * s);
  t.dims = (extent / s).array().ceil().cast<int>();
  const std::size_t n = static_cast<std::size_t>(t.dims.x()) * t.dims.y() * t.dims.z();
  if (n > max_voxels) {
    if (error != nullptr)
      *error = "ground truth: " + std::to_string(n) + " voxels at " + std::to_string(s) + " m exceed the limit of " +
               std::to_string(max_voxels) + "; use a coarser voxel size";
    return false;
  }

  // Occupancy: a voxel whose centre lies within half a voxel of a surface (or inside a solid).
  t.voxel_room.assign(n, kVoxelFreeNoRoom);
  std::vector<double> f(n, kInf);
  std::vector<std::int32_t> feature(n, -1);
  for (int z = 0; z < t.dims.z(); ++z)
    for (int y = 0; y < t.dims.y(); ++y)
      for (int x = 0; x < t.dims.x(); ++x) {
        const std::size_t i = t.index(x, y, z);
        // Strictly within half a voxel: a surface on a voxel boundary does not claim the free voxel beside it.
        if (!free_space.is_free(t.center(x, y, z), 0.5 * s * (1.0 - 1e-6))) {
          t.voxel_room[i] = kVoxelOccupied;
          f[i] = 0.0;
          feature[i] = static_cast<std::int32_t>(i);
        }
      }

  // Rooms: each room's footprint columns between its floor and ceiling.
  t.room_free_voxels.assign(world.rooms.size(), 0);
  for (std::size_t r = 0; r < world.rooms.size(); ++r) {
    const world::Room& room = world.rooms[r];
    const int z0 = std::max(0, static_cast<int>(std::floor((room.floor_z_m - t.origin_m.z()) / s)));
    const int z1 = std::min(t.dims.z(), static_cast<int>(std::ceil((room.floor_z_m + room.height_m - t.origin_m.z()) / s)));
    for (int y = 0; y < t.dims.y(); ++y)
      for (int x = 0; x < t.dims.x(); ++x) {
        const Eigen::Vector3d c = t.center(x, y, 0);
        bool inside = false;
        for (const world::Polygon2& poly : room.footprint_m)
          if (world::point_in_polygon(poly, c.head<2>())) inside = true;
        if (!inside) continue;
        for (int z = z0; z < z1; ++z) {
          const double cz = t.center(x, y, z).z();
          if (cz < room.floor_z_m || cz >= room.floor_z_m + room.height_m) continue;
          std::int16_t& v = t.voxel_room[t.index(x, y, z)];
          if (v == kVoxelFreeNoRoom) {
            v = static_cast<std::int16_t>(r);
            ++t.room_free_voxels[r];
          }
        }
      }
  }

  // Exact squared distance (in voxels) and nearest occupied voxel, three separable passes.
  std::vector<double> fq;
  std::vector<std::int32_t> featq;
  std::vector<int> v;
  std::vector<double> zz;
  const std::size_t X = static_cast<std::size_t>(t.dims.x()), Y = static_cast<std::size_t>(t.dims.y()),
                    Z = static_cast<std::size_t>(t.dims.z());
  for (std::size_t z = 0; z < Z; ++z)
    for (std::size_t y = 0; y < Y; ++y) envelope_pass(&f[(z * Y + y) * X], &feature[(z * Y + y) * X], X, 1, fq, featq, v, zz);
  for (std::size_t z = 0; z < Z; ++z)
    for (std::size_t x = 0; x < X; ++x) envelope_pass(&f[z * Y * X + x], &feature[z * Y * X + x], Y, X, fq, featq, v, zz);
  for (std::size_t y = 0; y < Y; ++y)
    for (std::size_t x = 0; x < X; ++x) envelope_pass(&f[y * X + x], &feature[y * X + x], Z, X * Y, fq, featq, v, zz);

  t.clearance_m.assign(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    if (t.voxel_room[i] == kVoxelOccupied) continue;
    // Distance to the nearest occupied voxel centre, less half a voxel: about the distance to the surface.
    const double d = f[i] >= kInf ? config.max_clearance_m : (std::sqrt(f[i]) - 0.5) * s;
    t.clearance_m[i] = static_cast<float>(std::min(config.max_clearance_m, std::max(0.0, d)));
  }

  // theta-SMA: a free voxel whose neighbourhood's nearest obstacles span an angle of at least theta, as seen
  // from the voxel, lies on the medial axis; the number of such mutually separated obstacles is its basis count.
  const double cos_theta = std::cos(config.gvd_min_angle_rad);
  const auto feature_center = [&](std::int32_t idx) {
    const std::size_t u = static_cast<std::size_t>(idx);
    const int x = static_cast<int>(u % X), y = static_cast<int>((u / X) % Y), z = static_cast<int>(u / (X * Y));
    return t.center(x, y, z);
  };
  for (int z = 1; z + 1 < t.dims.z(); ++z)
    for (int y = 1; y + 1 < t.dims.y(); ++y)
      for (int x = 1; x + 1 < t.dims.x(); ++x) {
        const std::size_t i = t.index(x, y, z);
        if (t.voxel_room[i] == kVoxelOccupied || feature[i] < 0 || t.clearance_m[i] < config.gvd_min_clearance_m) continue;
        const Eigen::Vector3d c = t.center(x, y, z);
        const double own_distance = (feature_center(feature[i]) - c).norm();
        Eigen::Vector3d basis[8];
        int count = 0;
        // A neighbour's obstacle counts when this voxel is (within a voxel) as close to it as to its own:
        // equidistance is what puts a voxel on the GVD, and it keeps the skeleton one to two voxels thin.
        const auto consider = [&](std::int32_t feat) {
          if (feat < 0 || count == 8) return;
          const Eigen::Vector3d offset = feature_center(feat) - c;
          if (offset.norm() - own_distance > s + 1e-9) return;
          const Eigen::Vector3d dir = offset.normalized();
          for (int k = 0; k < count; ++k)
            if (dir.dot(basis[k]) > cos_theta) return;
          basis[count++] = dir;
        };
        consider(feature[i]);
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              if (dx == 0 && dy == 0 && dz == 0) continue;
              const std::size_t j = t.index(x + dx, y + dy, z + dz);
              if (t.voxel_room[j] != kVoxelOccupied) consider(feature[j]);
            }
        if (count < 2) continue;
        GvdVoxel g;
        g.position_m = c.cast<float>();
        g.clearance_m = static_cast<float>(free_space.clearance(c, config.max_clearance_m));
        g.num_basis_points = static_cast<std::uint8_t>(count);
        t.gvd.push_back(g);
      }
  return true;
}

bool write_ground_truth(const std::string& dir, const world::World& world, const GroundTruth& truth,
                        const replay::Trajectory& trajectory, std::string* error) {
  using json = nlohmann::json;
  const auto fail = [&](const std::string& what) {
    if (error != nullptr) *error = what;
    return false;
  };
  const auto write_text = [&](const std::string& name, const std::string& text) {
    std::ofstream out(dir + "/" + name, std::ios::binary | std::ios::trunc);
    out << text;
    return static_cast<bool>(out);
  };

  json objects = json::array();
  for (const world::Object& o : world.objects) {
    const Eigen::Matrix3d R = o.box.world_R_box.toRotationMatrix();
    Eigen::Vector3d half_aabb = R.cwiseAbs() * o.box.half_extents_m;
    objects.push_back({{"id", o.id},
                       {"label", o.label},
                       {"label_name", semantics::object_label(o.label).name},
                       {"room_id", o.room_id},
                       {"centroid", {o.box.center_m.x(), o.box.center_m.y(), o.box.center_m.z()}},
                       {"size", {2 * o.box.half_extents_m.x(), 2 * o.box.half_extents_m.y(), 2 * o.box.half_extents_m.z()}},
                       {"orientation_wxyz", {o.box.world_R_box.w(), o.box.world_R_box.x(), o.box.world_R_box.y(), o.box.world_R_box.z()}},
                       {"aabb_min", {o.box.center_m.x() - half_aabb.x(), o.box.center_m.y() - half_aabb.y(), o.box.center_m.z() - half_aabb.z()}},
                       {"aabb_max", {o.box.center_m.x() + half_aabb.x(), o.box.center_m.y() + half_aabb.y(), o.box.center_m.z() + half_aabb.z()}}});
  }
  if (!write_text("objects.json", json{{"world", world.name}, {"objects", objects}}.dump(1))) return fail("cannot write " + dir + "/objects.json");

  json rooms = json::array();
  for (std::size_t r = 0; r < world.rooms.size(); ++r) {
    const world::Room& room = world.rooms[r];
    json footprint = json::array();
    for (const world::Polygon2& poly : room.footprint_m) {
      json p = json::array();
      for (const Eigen::Vector2d& q : poly) p.push_back({q.x(), q.y()});
      footprint.push_back(p);
    }
    rooms.push_back({{"index", r},
                     {"id", room.id},
                     {"label", room.label},
                     {"label_name", semantics::room_label_name(room.label)},
                     {"floor_index", room.floor_index},
                     {"floor_z", room.floor_z_m},
                     {"height", room.height_m},
                     {"footprint", footprint},
                     {"free_voxels", truth.room_free_voxels.empty() ? 0 : truth.room_free_voxels[r]}});
  }
  const json free_space{{"file", "free_space.bin"},
                        {"voxel_size", truth.config.voxel_size_m},
                        {"origin", {truth.origin_m.x(), truth.origin_m.y(), truth.origin_m.z()}},
                        {"dims", {truth.dims.x(), truth.dims.y(), truth.dims.z()}},
                        {"encoding", "int16 little endian per voxel, x fastest then y then z; value = index into "
                                     "rooms, -1 free outside every room, -2 occupied"}};
  if (!write_text("rooms.json", json{{"world", world.name}, {"rooms", rooms}, {"free_space", free_space}}.dump(1)))
    return fail("cannot write " + dir + "/rooms.json");

  {
    std::ofstream out(dir + "/free_space.bin", std::ios::binary | std::ios::trunc);
    for (std::int16_t value : truth.voxel_room) {
      const unsigned char bytes[2] = {static_cast<unsigned char>(value & 0xFF), static_cast<unsigned char>((value >> 8) & 0xFF)};
      out.write(reinterpret_cast<const char*>(bytes), 2);
    }
    if (!out) return fail("cannot write " + dir + "/free_space.bin");
  }
  {
    std::ofstream out(dir + "/gvd.ply", std::ios::binary | std::ios::trunc);
    out << "ply\nformat binary_little_endian 1.0\ncomment theta-SMA skeleton of the world's free space\n"
        << "element vertex " << truth.gvd.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nproperty float clearance\n"
           "property uchar num_basis_points\nend_header\n";
    for (const GvdVoxel& g : truth.gvd) {
      const float values[4] = {g.position_m.x(), g.position_m.y(), g.position_m.z(), g.clearance_m};
      for (float value : values) {
        std::uint32_t bits;
        std::memcpy(&bits, &value, 4);
        const unsigned char b[4] = {static_cast<unsigned char>(bits), static_cast<unsigned char>(bits >> 8),
                                    static_cast<unsigned char>(bits >> 16), static_cast<unsigned char>(bits >> 24)};
        out.write(reinterpret_cast<const char*>(b), 4);
      }
      out.put(static_cast<char>(g.num_basis_points));
    }
    if (!out) return fail("cannot write " + dir + "/gvd.ply");
  }
  if (!trajectory.empty()) {
    std::string e;
    if (!replay::write_tum_trajectory(dir + "/trajectory.txt", trajectory, &e)) return fail(e);
  }
  return true;
}

}  // namespace qsg::sim

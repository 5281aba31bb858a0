// rooms_eval's cache files, dumps, pictures, door oracle and door judgement (rooms_eval_io.h).
#include "bench/rooms/rooms_eval_io.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace qsg::bench {

namespace sg = scene_graph;

// One line per place, "P id x y z clearance room truth plan_clearance" (room: the parent's node id, 0 without one;
// truth: the ground-truth room of its cell as the oracle takes it, 0: none; plan_clearance: the horizontal distance
// from its cell to the plan's nearest occupied cell, the 2D clearance a map-based method sees), and per place-place
// edge "E id id weight" (weight -1 when unweighted), and per door the room finder read "D ax ay bx by z" (jamb to
// jamb in plan, the slice's height).
bool dump_places(const sg::SceneGraph& g, const Raster& ras, const std::string& path,
                 const std::vector<rooms::Door>& doors, double z_min_m, double z_max_m) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    std::fprintf(stderr, "--dump-places: cannot write %s\n", path.c_str());
    return false;
  }
  // Distance of every free cell to the plan's nearest occupied cell.
  cv::Mat free_mask(ras.rows, ras.cols, CV_8U), distance_px;
  for (int r = 0; r < ras.rows; ++r)
    for (int c = 0; c < ras.cols; ++c) free_mask.at<std::uint8_t>(r, c) = ras.free[ras.idx(c, r)] ? 255 : 0;
  cv::distanceTransform(free_mask, distance_px, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kPlace) return;
    const sg::PlaceAttributes* a = g.place(n.id);
    if (a->position_m.z() < z_min_m || a->position_m.z() >= z_max_m) return;
    int c, r;
    const bool inside = ras.cell_of(a->position_m, &c, &r);
    const std::int32_t truth = inside ? truth_near(ras, c, r) : 0;
    const double plan_clearance = inside ? distance_px.at<float>(r, c) * ras.res_m : 0.0;
    std::fprintf(f, "P %llu %.6f %.6f %.6f %.6f %llu %d %.6f\n", static_cast<unsigned long long>(n.id),
                 a->position_m.x(), a->position_m.y(), a->position_m.z(), a->distance_m,
                 static_cast<unsigned long long>(n.parent == sg::kNoNode ? 0 : n.parent), truth, plan_clearance);
    g.for_each_neighbor(n.id, [&](sg::NodeId other, const sg::EdgeRecord& e) {
      const sg::PlaceAttributes* b = g.place(other);
      if (other > n.id && b != nullptr && b->position_m.z() >= z_min_m && b->position_m.z() < z_max_m)
        std::fprintf(f, "E %llu %llu %.6f\n", static_cast<unsigned long long>(n.id),
                     static_cast<unsigned long long>(other), e.info.weighted ? e.info.weight : -1.0);
    });
  });
  for (const rooms::Door& d : doors)
    if (d.z_m >= z_min_m && d.z_m < z_max_m)
      std::fprintf(f, "D %.6f %.6f %.6f %.6f %.6f\n", d.a.x(), d.a.y(), d.b.x(), d.b.y(), d.z_m);
  return std::fclose(f) == 0;
}

// --door-oracle-m: every place-place edge whose ends lie in two different ground-truth rooms gets clearance
// clearance_m, and the rooms (and building) of the earlier run leave the graph so the finder can run again.
// Returns the number of edges changed.
std::size_t apply_door_oracle(const Raster& ras, double clearance_m, sg::SceneGraph* g) {
  std::map<sg::NodeId, std::int32_t> truth;
  std::vector<sg::NodeId> remove;
  g->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind == sg::NodeKind::kRoom || n.kind == sg::NodeKind::kBuilding) remove.push_back(n.id);
    if (n.kind != sg::NodeKind::kPlace) return;
    int c, r;
    truth[n.id] = ras.cell_of(g->place(n.id)->position_m, &c, &r) ? truth_near(ras, c, r) : 0;
  });
  for (sg::NodeId id : remove) g->remove_node(id);
  std::vector<std::pair<sg::NodeId, sg::NodeId>> doors;
  for (const auto& entry : truth) {
    const sg::NodeId id = entry.first;
    const std::int32_t t = entry.second;  // a plain variable: C++17 lambdas cannot capture structured bindings
    if (t <= 0) continue;
    g->for_each_neighbor(id, [&](sg::NodeId other, const sg::EdgeRecord&) {
      const auto o = truth.find(other);
      if (other > id && o != truth.end() && o->second > 0 && o->second != t) doors.emplace_back(id, other);
    });
  }
  for (const auto& [a, b] : doors) {
    sg::EdgeAttributes* e = g->edge_info(a, b);
    e->weighted = true;
    e->weight = clearance_m;
  }
  return doors.size();
}

// Left: the estimated rooms, right: the ground truth, each room a colour from its id (black: occupied, grey: free but
// unlabelled).
void write_image(const Raster& ras, const std::string& path, const std::vector<rooms::Door>& doors) {
  cv::Mat out(ras.rows, 2 * ras.cols + 10, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto colour = [](std::int32_t id) {
    const std::uint32_t h = static_cast<std::uint32_t>(id) * 2654435761u;
    return cv::Vec3b(static_cast<std::uint8_t>(60 + (h & 0x7f)), static_cast<std::uint8_t>(60 + ((h >> 8) & 0x7f)),
                     static_cast<std::uint8_t>(60 + ((h >> 16) & 0x7f)));
  };
  for (int r = 0; r < ras.rows; ++r)
    for (int c = 0; c < ras.cols; ++c) {
      const std::size_t k = ras.idx(c, r);
      const cv::Vec3b free_grey(200, 200, 200);
      out.at<cv::Vec3b>(r, c) = !ras.free[k] ? cv::Vec3b(0, 0, 0) : ras.estimate[k] > 0 ? colour(ras.estimate[k]) : free_grey;
      out.at<cv::Vec3b>(r, ras.cols + 10 + c) =
          !ras.free[k] ? cv::Vec3b(0, 0, 0) : ras.truth[k] > 0 ? colour(ras.truth[k] + 1000) : free_grey;
    }
  // Doors found on the robot's surface (--doors), in red on both halves.
  for (const rooms::Door& d : doors) {
    const auto px = [&](const Eigen::Vector2d& p, int offset) {
      return cv::Point(static_cast<int>(std::floor((p.x() - ras.origin_m.x()) / ras.res_m)) + offset,
                       ras.rows - 1 - static_cast<int>(std::floor((p.y() - ras.origin_m.y()) / ras.res_m)));
    };
    for (const int offset : {0, ras.cols + 10}) cv::line(out, px(d.a, offset), px(d.b, offset), cv::Scalar(0, 0, 255), 2);
  }
  if (!cv::imwrite(path, out)) std::fprintf(stderr, "cannot write %s\n", path.c_str());
}

// --doors online: the last window pass's sight lines (raster and structure mask), cached beside the doors as lo.x
// lo.y cell_m z (doubles), cols rows (int32), then cols x rows bytes.
bool write_window(const rooms::DoorRaster& r, const std::uint8_t* structure, double z, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  const double head[4] = {r.lo.x(), r.lo.y(), r.cell_m, z};
  const std::int32_t size[2] = {r.cols, r.rows};
  const bool ok = std::fwrite(head, sizeof(head), 1, f) == 1 && std::fwrite(size, sizeof(size), 1, f) == 1 &&
                  std::fwrite(structure, 1, r.cells(), f) == r.cells();
  return std::fclose(f) == 0 && ok;
}

bool read_window(const std::string& path, rooms::DoorRaster* r, std::vector<std::uint8_t>* structure, double* z) {
  std::ifstream in(path, std::ios::binary);
  double head[4];
  std::int32_t size[2];
  if (!in.read(reinterpret_cast<char*>(head), sizeof(head)) || !in.read(reinterpret_cast<char*>(size), sizeof(size)))
    return false;
  if (size[0] <= 0 || size[1] <= 0 || size[0] > 100000 || size[1] > 100000 || !(head[2] > 0.0)) return false;
  r->lo = Eigen::Vector2d(head[0], head[1]);
  r->cell_m = head[2];
  r->cols = size[0];
  r->rows = size[1];
  *z = head[3];
  structure->resize(r->cells());
  return static_cast<bool>(
      in.read(reinterpret_cast<char*>(structure->data()), static_cast<std::streamsize>(r->cells())));
}

// --doors online: a run's online doors, cached beside its graph as 5 doubles a door (a.x a.y b.x b.y z).
bool write_doors(const std::vector<rooms::Door>& doors, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  bool ok = true;
  for (const rooms::Door& d : doors) {
    const double v[5] = {d.a.x(), d.a.y(), d.b.x(), d.b.y(), d.z_m};
    ok = ok && std::fwrite(v, sizeof(double), 5, f) == 5;
  }
  return std::fclose(f) == 0 && ok;
}

bool read_doors(const std::string& path, std::vector<rooms::Door>* doors) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  doors->clear();
  double v[5];
  while (in.read(reinterpret_cast<char*>(v), sizeof(v))) {
    rooms::Door d;
    d.a = Eigen::Vector2d(v[0], v[1]);
    d.b = Eigen::Vector2d(v[2], v[3]);
    d.z_m = v[4];
    doors->push_back(d);
  }
  return in.eof() && in.gcount() == 0;
}

// The robot's surface: the vertices of its reconstructed mesh (archive and active window), as float x y z triples in
// a raw file beside the cached graph.
bool write_surface(const std::vector<Eigen::Vector3f>& surface, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  const bool ok = surface.empty() || std::fwrite(surface.data(), sizeof(Eigen::Vector3f), surface.size(), f) == surface.size();
  return std::fclose(f) == 0 && ok;
}

bool read_surface(const std::string& path, std::vector<Eigen::Vector3f>* surface) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return false;
  const std::streamsize bytes = in.tellg();
  if (bytes < 0 || bytes % static_cast<std::streamsize>(sizeof(Eigen::Vector3f)) != 0) return false;
  surface->resize(static_cast<std::size_t>(bytes) / sizeof(Eigen::Vector3f));
  in.seekg(0);
  return static_cast<bool>(in.read(reinterpret_cast<char*>(surface->data()), bytes));
}

// Each door against the ground truth (between two rooms, inside one, unknown): the first free cell
// with a ground-truth room on each side of the line's midpoint, along its normal from 0.15 m to 1 m out.
DoorJudgement check_doors(const Raster& ras, const std::vector<rooms::Door>& doors) {
  DoorJudgement st;
  for (const rooms::Door& d : doors) {
    const Eigen::Vector2d mid = 0.5 * (d.a + d.b);
    const Eigen::Vector2d u = (d.b - d.a).normalized();
    const Eigen::Vector2d n(-u.y(), u.x());
    std::int32_t side[2] = {0, 0};
    for (int k = 0; k < 2; ++k)
      for (double t = 0.15; t <= 1.0 + 1e-9 && side[k] == 0; t += ras.res_m) {
        const Eigen::Vector2d p = mid + (k == 0 ? t : -t) * n;
        int c, r;
        if (!ras.cell_of(Eigen::Vector3d(p.x(), p.y(), 0.0), &c, &r)) break;
        if (ras.free[ras.idx(c, r)] && ras.truth[ras.idx(c, r)] > 0) side[k] = ras.truth[ras.idx(c, r)];
      }
    if (side[0] == 0 || side[1] == 0) ++st.unknown;
    else if (side[0] == side[1]) ++st.inside;
    else ++st.between;
  }
  return st;
}

}  // namespace qsg::bench

// rooms_eval's files and pictures: the cache of an explored run (the robot's surface, an online run's doors and its
// last window's sight lines), the --dump-places text, the --images picture, the --door-oracle-m cut, and each door
// judged against the ground truth.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "bench/rooms/room_score.h"
#include "core/doors/door_detector.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::bench {

bool dump_places(const scene_graph::SceneGraph& g, const Raster& ras, const std::string& path,
                 const std::vector<rooms::Door>& doors, double z_min_m = -1e9, double z_max_m = 1e9);
std::size_t apply_door_oracle(const Raster& ras, double clearance_m, scene_graph::SceneGraph* g);
void write_image(const Raster& ras, const std::string& path, const std::vector<rooms::Door>& doors = {});
bool write_window(const rooms::DoorRaster& r, const std::uint8_t* structure, double z, const std::string& path);
bool read_window(const std::string& path, rooms::DoorRaster* r, std::vector<std::uint8_t>* structure, double* z);
bool write_doors(const std::vector<rooms::Door>& doors, const std::string& path);
bool read_doors(const std::string& path, std::vector<rooms::Door>* doors);
bool write_surface(const std::vector<Eigen::Vector3f>& surface, const std::string& path);
bool read_surface(const std::string& path, std::vector<Eigen::Vector3f>* surface);

// The doors the room finder read, against the ground truth.
struct DoorJudgement {
  std::size_t between = 0, inside = 0, unknown = 0;
};
DoorJudgement check_doors(const Raster& ras, const std::vector<rooms::Door>& doors);

}  // namespace qsg::bench

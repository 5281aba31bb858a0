// What a door stage hands the room finder, and all the finder knows of it: which place edges are closed
// (ClosedPassages: a door between their ends) and which places see each other past the building's structural walls
// (SightLines). core/doors implements both (DoorSet, WallSight); the finder never sees a door, a raster or a wall.
#pragma once

#include <Eigen/Core>
#include <cstddef>

namespace qsg::rooms {

class ClosedPassages {
 public:
  virtual ~ClosedPassages() = default;
  // Whether the place edge a-b passes through a closed passage (a door), and is no way between rooms.
  virtual bool closes(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const = 0;
};

class SightLines {
 public:
  virtual ~SightLines() = default;
  // Slices (storeys) the lines are known on; none: no sight lines at all.
  virtual std::size_t slices() const = 0;
  // Whether the lines cover a window around the robot only, not the whole map of every storey.
  virtual bool window() const = 0;
  // Whether the segment a-b, in plan, crosses no structure (false when unknown: ends on different slices, off the
  // map, not finite).
  virtual bool sees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const = 0;
  // Whether the segment a-b, in plan, crosses structure (false when unknown).
  virtual bool crosses_structure(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const = 0;
};

}  // namespace qsg::rooms

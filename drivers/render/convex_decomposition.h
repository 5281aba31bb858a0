// Splits a simple polygon into convex pieces (ear clipping, then merging neighbours while the union stays convex),
// so a concave prism becomes a few convex prisms that the ray caster clips exactly.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace qsg::render {

using Polygon2d = std::vector<Eigen::Vector2d>;

// Accepts either winding and drops repeated and collinear vertices. Each piece is convex and counter-clockwise;
// the pieces tile the polygon. Returns false with a reason for fewer than 3 distinct vertices, non-finite
// coordinates, zero area or a self-intersecting outline.
bool decompose_convex(const Polygon2d& polygon, std::vector<Polygon2d>* pieces, std::string* error);

// Signed area (positive when counter-clockwise).
double signed_area(const Polygon2d& polygon);
bool is_convex_ccw(const Polygon2d& polygon);

}  // namespace qsg::render

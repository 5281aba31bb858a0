// Ear clipping plus greedy convex merging (see convex_decomposition.h).
#include "drivers/render/convex_decomposition.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

namespace qsg::render {
namespace {

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }
double orient(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return cross(b - a, c - a);
}

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  char buffer[200];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof(buffer), fmt, args);
  va_end(args);
  return buffer;
}

bool on_segment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  return std::min(a.x(), b.x()) <= p.x() && p.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= p.y() &&
         p.y() <= std::max(a.y(), b.y());
}

// Closed segments touch or cross (eps: collinearity tolerance on orientations).
bool segments_meet(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2, const Eigen::Vector2d& p3,
                   const Eigen::Vector2d& p4, double eps) {
  const double d1 = orient(p3, p4, p1);
  const double d2 = orient(p3, p4, p2);
  const double d3 = orient(p1, p2, p3);
  const double d4 = orient(p1, p2, p4);
  if (((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps)) && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps)))
    return true;
  if (std::fabs(d1) <= eps && on_segment(p3, p4, p1)) return true;
  if (std::fabs(d2) <= eps && on_segment(p3, p4, p2)) return true;
  if (std::fabs(d3) <= eps && on_segment(p1, p2, p3)) return true;
  if (std::fabs(d4) <= eps && on_segment(p1, p2, p4)) return true;
  return false;
}

// Convex and counter-clockwise with every corner turning left by more than eps.
bool convex_indices(const Polygon2d& v, const std::vector<int>& idx, double eps) {
  const std::size_t n = idx.size();
  if (n < 3) return false;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = v[idx[(i + n - 1) % n]];
    const Eigen::Vector2d& b = v[idx[i]];
    const Eigen::Vector2d& c = v[idx[(i + 1) % n]];
    if (orient(a, b, c) <= eps) return false;
  }
  return true;
}

// Merges two counter-clockwise pieces sharing a directed edge a->b (in p) / b->a (in q) when the union is convex.
bool try_merge(const Polygon2d& v, const std::vector<int>& p, const std::vector<int>& q, double eps,
               std::vector<int>* merged) {
  const std::size_t np = p.size(), nq = q.size();
  for (std::size_t i = 0; i < np; ++i) {
    const int a = p[i], b = p[(i + 1) % np];
    for (std::size_t j = 0; j < nq; ++j) {
      if (q[j] != b || q[(j + 1) % nq] != a) continue;
      merged->clear();
      for (std::size_t k = 0; k < np; ++k) merged->push_back(p[(i + 1 + k) % np]);  // b ... a
      for (std::size_t k = 2; k < nq; ++k) merged->push_back(q[(j + k) % nq]);      // after a, before b
      // Drop corners that became straight so the merged piece keeps strictly convex corners.
      std::vector<int> cleaned;
      const std::size_t n = merged->size();
      for (std::size_t k = 0; k < n; ++k) {
        const Eigen::Vector2d& pa = v[(*merged)[(k + n - 1) % n]];
        const Eigen::Vector2d& pb = v[(*merged)[k]];
        const Eigen::Vector2d& pc = v[(*merged)[(k + 1) % n]];
        if (std::fabs(orient(pa, pb, pc)) > eps) cleaned.push_back((*merged)[k]);
      }
      if (!convex_indices(v, cleaned, eps)) return false;
      *merged = cleaned;
      return true;
    }
  }
  return false;
}

}  // namespace

double signed_area(const Polygon2d& polygon) {
  double area = 0.0;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) area += cross(polygon[i], polygon[(i + 1) % n]);
  return 0.5 * area;
}

bool is_convex_ccw(const Polygon2d& polygon) {
  std::vector<int> idx(polygon.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
  return convex_indices(polygon, idx, 0.0);
}

bool decompose_convex(const Polygon2d& polygon, std::vector<Polygon2d>* pieces, std::string* error) {
  pieces->clear();
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    if (!polygon[i].allFinite()) {
      if (error) *error = format("vertex %zu is not finite", i);
      return false;
    }
  }
  // Scale-aware tolerances.
  double extent = 0.0;
  for (const auto& p : polygon) extent = std::max(extent, p.cwiseAbs().maxCoeff());
  const double length_eps = 1e-9 * std::max(1.0, extent);
  const double area_eps = 1e-12 * std::max(1.0, extent * extent);

  Polygon2d v;
  v.reserve(polygon.size());
  for (const auto& p : polygon)
    if (v.empty() || (p - v.back()).norm() > length_eps) v.push_back(p);
  while (v.size() > 1 && (v.front() - v.back()).norm() <= length_eps) v.pop_back();
  if (v.size() < 3) {
    if (error) *error = format("polygon has %zu distinct vertices, needs at least 3", v.size());
    return false;
  }
  const double area = signed_area(v);
  if (std::fabs(area) <= area_eps) {
    if (error) *error = "polygon has zero area";
    return false;
  }
  if (area < 0.0) std::reverse(v.begin(), v.end());
  // Drop collinear vertices (repeat: removing one can make its neighbour collinear).
  for (bool changed = true; changed && v.size() >= 3;) {
    changed = false;
    for (std::size_t i = 0; i < v.size() && v.size() >= 3; ++i) {
      const std::size_t n = v.size();
      if (std::fabs(orient(v[(i + n - 1) % n], v[i], v[(i + 1) % n])) <= area_eps &&
          (v[(i + 1) % n] - v[i]).dot(v[i] - v[(i + n - 1) % n]) >= 0.0) {
        v.erase(v.begin() + static_cast<long>(i));
        changed = true;
      }
    }
  }
  const std::size_t n = v.size();
  if (n < 3) {
    if (error) *error = "polygon has zero area";
    return false;
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (j == i + 1 || (i == 0 && j == n - 1)) {
        // Adjacent edges share a vertex; they overlap only when the outline folds back on itself.
        const std::size_t shared = (j == i + 1) ? j : i;
        const Eigen::Vector2d& s = v[shared];
        const Eigen::Vector2d& a = v[(shared + n - 1) % n];
        const Eigen::Vector2d& b = v[(shared + 1) % n];
        if (std::fabs(orient(a, s, b)) <= area_eps && (b - s).dot(a - s) > 0.0) {
          if (error) *error = format("polygon folds back on itself at edges %zu and %zu", i, j);
          return false;
        }
        continue;
      }
      if (segments_meet(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n], area_eps)) {
        if (error) *error = format("polygon is not simple: edges %zu and %zu intersect", i, j);
        return false;
      }
    }
  }

  std::vector<int> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = static_cast<int>(i);
  if (convex_indices(v, all, area_eps)) {
    pieces->push_back(v);
    return true;
  }

  // Ear clipping on the index ring.
  std::vector<std::vector<int>> parts;
  std::vector<int> ring = all;
  std::size_t guard = 0;
  while (ring.size() > 3) {
    bool clipped = false;
    const std::size_t m = ring.size();
    for (std::size_t i = 0; i < m; ++i) {
      const int ia = ring[(i + m - 1) % m], ib = ring[i], ic = ring[(i + 1) % m];
      const double turn = orient(v[ia], v[ib], v[ic]);
      if (std::fabs(turn) <= area_eps) {  // straight corner left by earlier clips: drop it, it adds no area
        ring.erase(ring.begin() + static_cast<long>(i));
        clipped = true;
        break;
      }
      if (turn < 0.0) continue;  // reflex
      bool blocked = false;
      for (std::size_t k = 0; k < m && !blocked; ++k) {
        const int ip = ring[k];
        if (ip == ia || ip == ib || ip == ic) continue;
        const Eigen::Vector2d& p = v[ip];
        blocked = orient(v[ia], v[ib], p) >= -area_eps && orient(v[ib], v[ic], p) >= -area_eps &&
                  orient(v[ic], v[ia], p) >= -area_eps;
      }
      if (blocked) continue;
      parts.push_back({ia, ib, ic});
      ring.erase(ring.begin() + static_cast<long>(i));
      clipped = true;
      break;
    }
    if (!clipped || ++guard > 4 * n + 16) {
      if (error) *error = "ear clipping failed (polygon nearly degenerate)";
      return false;
    }
  }
  if (std::fabs(orient(v[ring[0]], v[ring[1]], v[ring[2]])) > area_eps) parts.push_back(ring);

  // Greedy merging of neighbours while the union stays convex (cheap for the small outlines of walls and
  // furniture; large outlines keep their triangles, which the BVH handles well).
  if (parts.size() <= 256) {
    std::vector<int> merged;
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t i = 0; i < parts.size() && !changed; ++i) {
        for (std::size_t j = i + 1; j < parts.size() && !changed; ++j) {
          if (try_merge(v, parts[i], parts[j], area_eps, &merged)) {
            parts[i] = merged;
            parts.erase(parts.begin() + static_cast<long>(j));
            changed = true;
          }
        }
      }
    }
  }
  for (const auto& part : parts) {
    Polygon2d piece;
    for (int i : part) piece.push_back(v[i]);
    pieces->push_back(piece);
  }
  return true;
}

}  // namespace qsg::render

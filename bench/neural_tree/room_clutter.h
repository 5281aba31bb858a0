// The clutter generator of labels_eval (issue 38): real homes' rooms hold a median of 13 objects, most of them
// labels the Stanford3DSG training rooms never have (lamps, cushions, towels, curtains, pictures, "misc",
// "objects"); Stanford's rooms hold 3-7. This tops every room up to a total drawn uniformly from
// [min_total, max_total] (10-15) with mpcat40 clutter, the same mix in every room type (the mix per type is not
// known here; a mix that followed the room type would hand a model that reads clutter evidence it cannot have in
// the field). Labels, weights and box sizes are in kClutter below; positions are uniform in the room's box, each
// item at its kind's height above the floor. Deterministic for a seed.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "core/semantics/labels.h"

namespace qsg::bench {

struct ClutterItem {
  semantics::Label label;
  Eigen::Vector3d centroid_m, size_m;
};

struct ClutterConfig {
  int min_total = 10, max_total = 15;  // objects per room after clutter (a room already fuller gets none)
};

struct ClutterKind {
  semantics::Label label;
  double weight;  // relative frequency
  double w0, w1, d0, d1, h0, h1;  // box: width, depth, height ranges (m)
  double z0, z1;  // height of the box's bottom above the floor (m)
};

// Lamps, pictures, small objects and cushions are the commonest; then curtains, "misc", towels, mirrors, clothes,
// blinds.
inline constexpr ClutterKind kClutter[] = {
    {semantics::kLighting, 3.0, 0.25, 0.5, 0.25, 0.5, 0.3, 1.6, 0.0, 0.8},
    {semantics::kPicture, 3.0, 0.3, 1.0, 0.02, 0.06, 0.3, 0.9, 1.0, 1.6},
    {semantics::kObjects, 4.0, 0.08, 0.4, 0.08, 0.4, 0.05, 0.4, 0.0, 1.2},
    {semantics::kCushion, 2.0, 0.3, 0.55, 0.3, 0.55, 0.1, 0.2, 0.4, 0.7},
    {semantics::kCurtain, 1.5, 0.8, 2.0, 0.05, 0.15, 1.5, 2.3, 0.0, 0.2},
    {semantics::kMisc, 2.0, 0.2, 0.8, 0.2, 0.8, 0.2, 0.9, 0.0, 0.8},
    {semantics::kTowel, 1.0, 0.3, 0.7, 0.03, 0.1, 0.3, 0.8, 0.5, 1.2},
    {semantics::kMirror, 1.0, 0.4, 0.9, 0.02, 0.05, 0.5, 1.1, 0.9, 1.3},
    {semantics::kClothes, 1.0, 0.3, 0.6, 0.2, 0.5, 0.1, 0.6, 0.0, 1.0},
    {semantics::kBlinds, 0.5, 0.6, 1.6, 0.02, 0.06, 0.8, 1.6, 0.8, 1.2},
};

// Clutter for one room whose box is centred at `centroid_m` with sides `size_m` (z up) holding `existing` objects.
inline std::vector<ClutterItem> make_clutter(const Eigen::Vector3d& centroid_m, const Eigen::Vector3d& size_m,
                                             int existing, std::uint64_t seed, const ClutterConfig& config = {}) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int total = config.min_total + static_cast<int>(u(rng) * (config.max_total - config.min_total + 1));
  const int add = std::max(0, std::min(total, config.max_total) - existing);
  double weight_sum = 0.0;
  for (const ClutterKind& k : kClutter) weight_sum += k.weight;
  const double floor_z = centroid_m.z() - 0.5 * size_m.z();
  std::vector<ClutterItem> out;
  for (int i = 0; i < add; ++i) {
    double pick = u(rng) * weight_sum;
    const ClutterKind* kind = &kClutter[0];
    for (const ClutterKind& k : kClutter) {
      kind = &k;
      if ((pick -= k.weight) < 0.0) break;
    }
    const auto in = [&](double a, double b) { return a + (b - a) * u(rng); };
    Eigen::Vector3d size(in(kind->w0, kind->w1), in(kind->d0, kind->d1), in(kind->h0, kind->h1));
    if (u(rng) < 0.5) std::swap(size.x(), size.y());  // either orientation in the room's frame
    const double bottom = in(kind->z0, kind->z1);
    const Eigen::Vector3d c(centroid_m.x() + (u(rng) - 0.5) * std::max(size_m.x() - size.x(), 0.0),
                            centroid_m.y() + (u(rng) - 0.5) * std::max(size_m.y() - size.y(), 0.0),
                            floor_z + bottom + 0.5 * size.z());
    out.push_back({kind->label, c, size});
  }
  return out;
}

}  // namespace qsg::bench

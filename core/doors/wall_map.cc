#include "core/doors/wall_map.h"

#include <algorithm>
#include <cmath>

namespace qsg::rooms {

namespace {

std::int32_t floor_div(std::int64_t a, std::int32_t b) {
  return static_cast<std::int32_t>(a >= 0 ? a / b : -((-a + b - 1) / b));
}

std::int32_t mod(std::int64_t a, std::int32_t b) { return static_cast<std::int32_t>(a - std::int64_t{floor_div(a, b)} * b); }

}  // namespace

memory::ArenaPlan WallMap::plan(std::size_t tiles) {
  memory::ArenaPlan p;
  using Map = memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash>;
  Map::plan(p, Map::slots_for(tiles));
  p.add_array<Tile>(tiles);
  return p;
}

bool WallMap::carve(memory::Arena& arena, std::size_t tiles, double cell_m) {
  using Map = memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash>;
  cell_m_ = cell_m;
  const bool ok = index_.carve(arena, Map::slots_for(tiles), tiles) &&
                  (tiles_ = static_cast<Tile*>(arena.carve_bytes(sizeof(Tile) * tiles, alignof(Tile)))) != nullptr;
  counter_.set_capacity(ok ? tiles : 0);
  clear();
  return ok && cell_m > 0.0;
}

void WallMap::clear() {
  index_.clear();
  used_ = 0;
  counter_.set_in_use(0);
}

const WallMap::Tile* WallMap::find(std::int32_t tx, std::int32_t ty, std::int32_t tz) const {
  const std::uint32_t* h = index_.find(memory::Index3{tx, ty, tz});
  return h == nullptr ? nullptr : &tiles_[*h];
}

bool WallMap::add(float x, float y, float z) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return false;
  const double fx = std::floor(x / cell_m_), fy = std::floor(y / cell_m_), fz = std::floor(z / cell_m_);
  if (std::abs(fx) > 1e9 || std::abs(fy) > 1e9 || std::abs(fz) > 1e9) return false;
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy), iz = static_cast<std::int64_t>(fz);
  const memory::Index3 key{floor_div(ix, kTileSide), floor_div(iy, kTileSide), floor_div(iz, kTileBins)};
  std::uint32_t* handle = index_.find(key);
  if (handle == nullptr) {
    if (used_ >= counter_.capacity()) {
      ++dropped_;
      return counter_.refuse(1);
    }
    handle = index_.insert(key, static_cast<std::uint32_t>(used_));
    if (handle == nullptr) {
      ++dropped_;
      return false;
    }
    std::fill(tiles_[used_].bits, tiles_[used_].bits + kTileSide * kTileSide, 0u);
    counter_.set_in_use(++used_);
  }
  tiles_[*handle].bits[mod(iy, kTileSide) * kTileSide + mod(ix, kTileSide)] |= 1u << mod(iz, kTileBins);
  return true;
}

void WallMap::clear_box(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m) {
  if (!min_m.allFinite() || !max_m.allFinite()) return;
  // Cells and bins whose centres lie inside the box.
  const auto first = [this](double v) { return static_cast<std::int64_t>(std::ceil(v / cell_m_ - 0.5)); };
  const std::int64_t x0 = first(min_m.x()), x1 = first(max_m.x()) - 1;
  const std::int64_t y0 = first(min_m.y()), y1 = first(max_m.y()) - 1;
  const std::int64_t z0 = first(min_m.z()), z1 = first(max_m.z()) - 1;
  if (x1 < x0 || y1 < y0 || z1 < z0 || (x1 - x0) > 4096 || (y1 - y0) > 4096) return;
  for (std::int32_t tz = floor_div(z0, kTileBins); tz <= floor_div(z1, kTileBins); ++tz) {
    const std::int64_t b0 = std::max<std::int64_t>(z0, std::int64_t{tz} * kTileBins) - std::int64_t{tz} * kTileBins;
    const std::int64_t b1 = std::min<std::int64_t>(z1, std::int64_t{tz} * kTileBins + kTileBins - 1) - std::int64_t{tz} * kTileBins;
    const std::uint64_t span = (std::uint64_t{1} << (b1 - b0 + 1)) - 1;
    const std::uint32_t keep = ~static_cast<std::uint32_t>(span << b0);
    for (std::int32_t ty = floor_div(y0, kTileSide); ty <= floor_div(y1, kTileSide); ++ty)
      for (std::int32_t tx = floor_div(x0, kTileSide); tx <= floor_div(x1, kTileSide); ++tx) {
        std::uint32_t* h = index_.find(memory::Index3{tx, ty, tz});
        if (h == nullptr) continue;
        Tile& t = tiles_[*h];
        const std::int64_t cx0 = std::max<std::int64_t>(x0, std::int64_t{tx} * kTileSide);
        const std::int64_t cx1 = std::min<std::int64_t>(x1, std::int64_t{tx} * kTileSide + kTileSide - 1);
        const std::int64_t cy0 = std::max<std::int64_t>(y0, std::int64_t{ty} * kTileSide);
        const std::int64_t cy1 = std::min<std::int64_t>(y1, std::int64_t{ty} * kTileSide + kTileSide - 1);
        for (std::int64_t y = cy0; y <= cy1; ++y)
          for (std::int64_t x = cx0; x <= cx1; ++x) t.bits[mod(y, kTileSide) * kTileSide + mod(x, kTileSide)] &= keep;
      }
  }
}

void WallMap::slice(const DoorRaster& raster, double z_m, double half_band_m, double min_wall_height_m,
                    std::uint8_t* wall) const {
  std::fill(wall, wall + raster.cells(), std::uint8_t{0});
  if (!std::isfinite(z_m) || used_ == 0) return;
  const std::int64_t k0 = static_cast<std::int64_t>(std::floor((z_m - half_band_m) / cell_m_));
  const std::int64_t k1 = static_cast<std::int64_t>(std::floor((z_m + half_band_m) / cell_m_));
  if (k1 < k0 || k1 - k0 >= 32) return;
  const std::int32_t tz0 = floor_div(k0, kTileBins);
  const std::int32_t tz1 = floor_div(k1, kTileBins);  // tz0 or tz0 + 1
  const std::int64_t base = std::int64_t{tz0} * kTileBins;
  const std::uint64_t band = ((std::uint64_t{1} << (k1 - k0 + 1)) - 1) << (k0 - base);
  const std::int64_t min_bins = static_cast<std::int64_t>(std::ceil(min_wall_height_m / cell_m_ - 1e-9));
  const std::int64_t gx0 = static_cast<std::int64_t>(std::llround(raster.lo.x() / cell_m_));
  const std::int64_t gy0 = static_cast<std::int64_t>(std::llround(raster.lo.y() / cell_m_));
  const std::int64_t gx1 = gx0 + raster.cols - 1, gy1 = gy0 + raster.rows - 1;
  for (std::int32_t ty = floor_div(gy0, kTileSide); ty <= floor_div(gy1, kTileSide); ++ty)
    for (std::int32_t tx = floor_div(gx0, kTileSide); tx <= floor_div(gx1, kTileSide); ++tx) {
      const Tile* lower = find(tx, ty, tz0);
      const Tile* upper = tz1 != tz0 ? find(tx, ty, tz1) : nullptr;
      if (lower == nullptr && upper == nullptr) continue;
      const std::int64_t cx0 = std::max<std::int64_t>(gx0, std::int64_t{tx} * kTileSide);
      const std::int64_t cx1 = std::min<std::int64_t>(gx1, std::int64_t{tx} * kTileSide + kTileSide - 1);
      const std::int64_t cy0 = std::max<std::int64_t>(gy0, std::int64_t{ty} * kTileSide);
      const std::int64_t cy1 = std::min<std::int64_t>(gy1, std::int64_t{ty} * kTileSide + kTileSide - 1);
      for (std::int64_t y = cy0; y <= cy1; ++y)
        for (std::int64_t x = cx0; x <= cx1; ++x) {
          const int i = mod(y, kTileSide) * kTileSide + mod(x, kTileSide);
          std::uint64_t bits = lower != nullptr ? lower->bits[i] : 0u;
          if (upper != nullptr) bits |= std::uint64_t{upper->bits[i]} << kTileBins;
          bits &= band;
          if (bits == 0) continue;
          const int lo = __builtin_ctzll(bits), hi = 63 - __builtin_clzll(bits);
          if (hi - lo >= min_bins)
            wall[static_cast<std::size_t>(y - gy0) * raster.cols + static_cast<std::size_t>(x - gx0)] = 1;
        }
    }
}

}  // namespace qsg::rooms

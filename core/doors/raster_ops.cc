#include "core/doors/raster_ops.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace qsg::rooms::raster {

void distance_1d(const double* f, int n, double* d, std::int32_t* v, double* z) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto meet = [f](int q, int p) {  // where the parabolas from q and p intersect
    return ((f[q] + static_cast<double>(q) * q) - (f[p] + static_cast<double>(p) * p)) / (2.0 * (q - p));
  };
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    double s = meet(q, v[k]);
    while (s <= z[k]) s = meet(q, v[--k]);  // z[0] is -inf: ends at k = 0
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = q - v[k];
    d[q] = dq * dq + f[v[k]];
  }
}

bool zhang_suen_removes(std::uint8_t neighbours, int pass) {
  int p[8];
  for (int j = 0; j < 8; ++j) p[j] = (neighbours >> j) & 1;
  int count = 0, transitions = 0;
  for (int j = 0; j < 8; ++j) {
    count += p[j];
    transitions += (p[j] == 0 && p[(j + 1) % 8] == 1) ? 1 : 0;
  }
  if (count < 2 || count > 6 || transitions != 1) return false;
  return pass == 0 ? (p[0] * p[2] * p[4] == 0 && p[2] * p[4] * p[6] == 0)
                   : (p[0] * p[2] * p[6] == 0 && p[0] * p[4] * p[6] == 0);
}

namespace {

// The removal test of both sub-iterations for every neighbourhood (bit 0: pass 0, bit 1: pass 1).
std::array<std::uint8_t, 256> removal_table() {
  std::array<std::uint8_t, 256> t{};
  for (int code = 0; code < 256; ++code)
    t[code] = static_cast<std::uint8_t>((zhang_suen_removes(static_cast<std::uint8_t>(code), 0) ? 1 : 0) |
                                        (zhang_suen_removes(static_cast<std::uint8_t>(code), 1) ? 2 : 0));
  return t;
}

}  // namespace

// Only a foreground cell with a background neighbour can be removed (one with eight foreground neighbours fails the
// count test), so each sub-iteration tests a list of border cells only, which gives the same skeleton as testing
// every cell; the test itself is a table lookup on the neighbourhood's eight bits. A cell that both sub-iterations
// kept since its neighbourhood last changed leaves the list (the test would keep it again); a removal puts its
// foreground neighbours back. Removals are applied after each sub-iteration, so the order of the list is immaterial.
void thin(std::uint8_t* m, int cols, int rows, std::uint32_t* list, std::uint32_t* marks, std::uint8_t* state) {
  static const std::array<std::uint8_t, 256> kRemoves = removal_table();
  constexpr std::uint8_t kInList = 1, kKeptBy0 = 2, kKeptBy1 = 4;
  const std::size_t n = static_cast<std::size_t>(cols) * rows;
  std::fill(state, state + n, std::uint8_t{0});
  const std::ptrdiff_t w = cols;
  const std::ptrdiff_t around[8] = {-w, -w + 1, 1, w + 1, w, w - 1, -1, -w - 1};  // p2 .. p9, clockwise from north
  std::size_t size = 0;
  for (int r = 1; r + 1 < rows; ++r)
    for (int c = 1; c + 1 < cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * cols + c;
      if (m[i] == 0) continue;
      bool border = false;
      for (const std::ptrdiff_t d : around) border = border || m[static_cast<std::ptrdiff_t>(i) + d] == 0;
      if (border) {
        state[i] = kInList;
        list[size++] = static_cast<std::uint32_t>(i);
      }
    }
  for (bool changed = true; changed;) {
    changed = false;
    for (int pass = 0; pass < 2; ++pass) {
      const std::uint8_t bit = static_cast<std::uint8_t>(1 << pass);
      const std::uint8_t kept_by = pass == 0 ? kKeptBy0 : kKeptBy1;
      std::size_t marked = 0;
      for (std::size_t k = 0; k < size; ++k) {
        const std::ptrdiff_t i = list[k];
        unsigned code = 0;
        for (int j = 0; j < 8; ++j) code |= static_cast<unsigned>(m[i + around[j]] != 0) << j;
        if ((kRemoves[code] & bit) != 0) marks[marked++] = static_cast<std::uint32_t>(i);
        else state[i] |= kept_by;
      }
      for (std::size_t k = 0; k < marked; ++k) m[marks[k]] = 0;
      changed = changed || marked > 0;
      // Neighbours of a removed cell: their neighbourhood changed, so both tests are due again.
      for (std::size_t k = 0; k < marked; ++k) {
        state[marks[k]] = 0;
        for (const std::ptrdiff_t d : around) {
          const std::size_t q = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(marks[k]) + d);
          if (m[q] != 0) state[q] &= kInList;
        }
      }
      // The next list: the survivors still due a test, then the removed cells' neighbours not in it.
      std::size_t kept = 0;
      for (std::size_t k = 0; k < size; ++k) {
        const std::uint32_t i = list[k];
        if (m[i] != 0 && (state[i] & (kKeptBy0 | kKeptBy1)) != (kKeptBy0 | kKeptBy1)) list[kept++] = i;
        else if (m[i] != 0) state[i] &= static_cast<std::uint8_t>(~kInList);
      }
      size = kept;
      for (std::size_t k = 0; k < marked; ++k)
        for (const std::ptrdiff_t d : around) {
          const std::size_t q = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(marks[k]) + d);
          if (m[q] != 0 && (state[q] & kInList) == 0) {
            state[q] |= kInList;
            list[size++] = static_cast<std::uint32_t>(q);
          }
        }
    }
  }
}

// Separable: each row's 3-wide maximum into `out`, then each column's 3-tall maximum of those.
void dilate3x3(const std::uint8_t* in, int cols, int rows, std::uint8_t* row, std::uint8_t* out) {
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* src = in + static_cast<std::size_t>(r) * cols;
    std::uint8_t* dst = out + static_cast<std::size_t>(r) * cols;
    for (int c = 0; c < cols; ++c) {
      std::uint8_t any = src[c] != 0;
      if (c > 0) any |= src[c - 1] != 0;
      if (c + 1 < cols) any |= src[c + 1] != 0;
      dst[c] = any;
    }
  }
  // Columns, one row at a time: `row` keeps the previous row's horizontal maxima before it is overwritten.
  if (rows < 2) return;
  std::copy(out, out + cols, row);
  for (int r = 0; r < rows; ++r) {
    std::uint8_t* cur = out + static_cast<std::size_t>(r) * cols;
    const std::uint8_t* below = r + 1 < rows ? cur + cols : nullptr;
    for (int c = 0; c < cols; ++c) {
      const std::uint8_t above = row[c];  // row r - 1's horizontal maximum (row r's own when r == 0)
      row[c] = cur[c];
      cur[c] = static_cast<std::uint8_t>(above | cur[c] | (below != nullptr ? below[c] : 0));
    }
  }
}

}  // namespace qsg::rooms::raster

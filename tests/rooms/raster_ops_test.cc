// The door detector's raster operations against plain references: Zhang-Suen thinning that tests every cell in
// every sub-iteration, and a 3 x 3 dilation that reads every neighbourhood.
#include "core/doors/raster_ops.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

namespace qsg::rooms::raster {
namespace {

// Zhang & Suen (1984) as published: every foreground cell tested against the image as it was at the start of the
// sub-iteration, counts and transitions computed from the cells.
void thin_reference(std::vector<std::uint8_t>* image, int cols, int rows) {
  std::vector<std::uint8_t>& m = *image;
  for (bool changed = true; changed;) {
    changed = false;
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<int> remove;
      for (int r = 1; r + 1 < rows; ++r)
        for (int c = 1; c + 1 < cols; ++c) {
          if (m[r * cols + c] == 0) continue;
          const int p2 = m[(r - 1) * cols + c], p3 = m[(r - 1) * cols + c + 1], p4 = m[r * cols + c + 1];
          const int p5 = m[(r + 1) * cols + c + 1], p6 = m[(r + 1) * cols + c], p7 = m[(r + 1) * cols + c - 1];
          const int p8 = m[r * cols + c - 1], p9 = m[(r - 1) * cols + c - 1];
          const int p[9] = {p2, p3, p4, p5, p6, p7, p8, p9, p2};
          int b = 0, a = 0;
          for (int j = 0; j < 8; ++j) {
            b += p[j];
            a += p[j] == 0 && p[j + 1] == 1;
          }
          if (b < 2 || b > 6 || a != 1) continue;
          const bool ok = pass == 0 ? (p2 * p4 * p6 == 0 && p4 * p6 * p8 == 0) : (p2 * p4 * p8 == 0 && p2 * p6 * p8 == 0);
          if (ok) remove.push_back(r * cols + c);
        }
      for (const int i : remove) m[i] = 0;
      changed = changed || !remove.empty();
    }
  }
}

// Random blobs: discs and bars, inside a zero frame.
std::vector<std::uint8_t> random_shapes(int cols, int rows, std::mt19937* rng) {
  std::vector<std::uint8_t> m(static_cast<std::size_t>(cols) * rows, 0);
  std::uniform_int_distribution<int> cx(2, cols - 3), cy(2, rows - 3), rad(1, 9), kind(0, 2);
  for (int s = 0; s < 12; ++s) {
    const int x = cx(*rng), y = cy(*rng), rr = rad(*rng), k = kind(*rng);
    for (int r = 1; r + 1 < rows; ++r)
      for (int c = 1; c + 1 < cols; ++c) {
        const int dx = c - x, dy = r - y;
        const bool in = k == 0 ? dx * dx + dy * dy <= rr * rr : k == 1 ? (std::abs(dx) <= 3 * rr && std::abs(dy) <= 1)
                                                                       : (std::abs(dy) <= 2 * rr && std::abs(dx) <= 2);
        if (in) m[r * cols + c] = 1;
      }
  }
  return m;
}

TEST(RasterOpsTest, ThinningEqualsTheReferenceOnRandomShapes) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    const int cols = 20 + trial * 3, rows = 64 - trial;
    std::vector<std::uint8_t> image = random_shapes(cols, rows, &rng);
    std::vector<std::uint8_t> expected = image;
    thin_reference(&expected, cols, rows);
    const std::size_t n = image.size();
    std::vector<std::uint32_t> list(n), marks(n);
    std::vector<std::uint8_t> in_list(n);
    thin(image.data(), cols, rows, list.data(), marks.data(), in_list.data());
    ASSERT_EQ(image, expected) << "trial " << trial;
  }
}

TEST(RasterOpsTest, RemovalTestFollowsZhangSuen) {
  // An end point (one neighbour) and an interior cell (eight) stay; a corner of a square goes in both passes.
  EXPECT_FALSE(zhang_suen_removes(0b00000001, 0));
  EXPECT_FALSE(zhang_suen_removes(0xff, 1));
  // South-east corner cell of a filled block: neighbours north (p2), north-west (p9) and west (p8) set.
  const std::uint8_t south_east = (1 << 0) | (1 << 7) | (1 << 6);
  EXPECT_TRUE(zhang_suen_removes(south_east, 0));
  // A cell on the west edge of a thick bar (north, north-east, east, south-east and south set): pass 0 keeps it
  // (p2 * p4 * p6 != 0), pass 1 removes it.
  const std::uint8_t west_edge = 0b00011111;
  EXPECT_FALSE(zhang_suen_removes(west_edge, 0));
  EXPECT_TRUE(zhang_suen_removes(west_edge, 1));
}

TEST(RasterOpsTest, DilationEqualsTheNeighbourhoodMaximum) {
  std::mt19937 rng(3);
  std::bernoulli_distribution on(0.08);
  for (const auto& [cols, rows] : {std::pair{1, 1}, std::pair{1, 7}, std::pair{9, 1}, std::pair{2, 2},
                                   std::pair{37, 23}, std::pair{64, 64}}) {
    std::vector<std::uint8_t> in(static_cast<std::size_t>(cols) * rows);
    for (auto& v : in) v = on(rng) ? 5 : 0;  // any non-zero is a wall
    std::vector<std::uint8_t> out(in.size(), 9), row(cols);
    dilate3x3(in.data(), cols, rows, row.data(), out.data());
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        std::uint8_t any = 0;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const int rr = r + dr, cc = c + dc;
            if (rr >= 0 && rr < rows && cc >= 0 && cc < cols && in[rr * cols + cc] != 0) any = 1;
          }
        ASSERT_EQ(out[r * cols + c], any) << cols << "x" << rows << " at " << c << "," << r;
      }
  }
}

}  // namespace
}  // namespace qsg::rooms::raster

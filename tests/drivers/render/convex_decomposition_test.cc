// Convex decomposition: pieces are convex, counter-clockwise and tile the polygon (areas add up, sample points
// are covered exactly once); bad outlines are rejected with a reason.
#include "drivers/render/convex_decomposition.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace qsg::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool inside_polygon(const Polygon2d& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    if ((poly[i].y() > p.y()) != (poly[j].y() > p.y())) {
      const double x = poly[i].x() + (p.y() - poly[i].y()) * (poly[j].x() - poly[i].x()) / (poly[j].y() - poly[i].y());
      if (p.x() < x) inside = !inside;
    }
  }
  return inside;
}

void expect_tiles(const Polygon2d& polygon, std::size_t max_pieces) {
  std::vector<Polygon2d> pieces;
  std::string error;
  ASSERT_TRUE(decompose_convex(polygon, &pieces, &error)) << error;
  ASSERT_GE(pieces.size(), 1u);
  EXPECT_LE(pieces.size(), max_pieces);
  double area = 0.0;
  for (const Polygon2d& piece : pieces) {
    EXPECT_TRUE(is_convex_ccw(piece));
    area += signed_area(piece);
  }
  EXPECT_NEAR(area, std::fabs(signed_area(polygon)), 1e-9);
  // Points strictly inside the polygon lie in exactly one piece; points outside in none.
  std::mt19937 rng(5);
  Eigen::Vector2d lo = polygon[0], hi = polygon[0];
  for (const auto& p : polygon) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y());
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector2d p(ux(rng), uy(rng));
    int covering = 0;
    for (const Polygon2d& piece : pieces) covering += inside_polygon(piece, p);
    ASSERT_EQ(covering, inside_polygon(polygon, p) ? 1 : 0) << p.transpose();
  }
}

TEST(ConvexDecomposition, ConvexPolygonStaysWhole) {
  expect_tiles({{0.0, 0.0}, {2.0, 0.0}, {2.0, 1.0}, {0.0, 1.0}}, 1);
  expect_tiles({{0.0, 0.0}, {0.0, 1.0}, {2.0, 1.0}, {2.0, 0.0}}, 1);  // clockwise
  Polygon2d circle;
  for (int i = 0; i < 40; ++i) circle.emplace_back(std::cos(i * 2 * kPi / 40), std::sin(i * 2 * kPi / 40));
  expect_tiles(circle, 1);
}

TEST(ConvexDecomposition, ConcaveShapesSplitIntoFewConvexPieces) {
  expect_tiles({{0.0, 0.0}, {2.0, 0.0}, {2.0, 0.6}, {0.6, 0.6}, {0.6, 2.0}, {0.0, 2.0}}, 2);  // L
  expect_tiles({{0.0, 0.0}, {3.0, 0.0}, {3.0, 2.0}, {2.0, 2.0}, {2.0, 1.0}, {1.0, 1.0}, {1.0, 2.0}, {0.0, 2.0}},
               3);  // U
  Polygon2d star;
  for (int k = 0; k < 14; ++k) {
    const double r = k % 2 == 0 ? 1.0 : 0.35;
    star.emplace_back(r * std::cos(k * kPi / 7), r * std::sin(k * kPi / 7));
  }
  expect_tiles(star, 12);
  // A comb with many teeth, clockwise.
  Polygon2d comb = {{0.0, 0.0}};
  for (int t = 0; t < 10; ++t) {
    comb.emplace_back(t + 0.0, 3.0);
    comb.emplace_back(t + 0.5, 3.0);
    comb.emplace_back(t + 0.5, 1.0);
    comb.emplace_back(t + 1.0, 1.0);
  }
  comb.emplace_back(10.0, 0.0);
  expect_tiles(comb, 30);
}

TEST(ConvexDecomposition, DropsRepeatedAndCollinearVertices) {
  std::vector<Polygon2d> pieces;
  std::string error;
  ASSERT_TRUE(decompose_convex({{0.0, 0.0}, {1.0, 0.0}, {1.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}, {0.0, 2.0}, {0.0, 0.0}},
                               &pieces, &error))
      << error;
  ASSERT_EQ(pieces.size(), 1u);
  EXPECT_EQ(pieces[0].size(), 4u);
}

TEST(ConvexDecomposition, RejectsBadOutlines) {
  std::vector<Polygon2d> pieces;
  std::string error;
  EXPECT_FALSE(decompose_convex({{0.0, 0.0}, {1.0, 0.0}}, &pieces, &error));
  EXPECT_NE(error.find("at least 3"), std::string::npos) << error;
  EXPECT_FALSE(decompose_convex({{0.0, 0.0}, {1.0, 1.0}, {3.0, 3.0}}, &pieces, &error));
  EXPECT_NE(error.find("zero area"), std::string::npos) << error;
  EXPECT_FALSE(decompose_convex({{0.0, 0.0}, {2.0, 2.0}, {2.0, 0.0}, {0.0, 3.0}}, &pieces, &error));
  EXPECT_NE(error.find("not simple"), std::string::npos) << error;
  EXPECT_FALSE(decompose_convex({{0.0, 0.0}, {NAN, 0.0}, {1.0, 1.0}}, &pieces, &error));
  EXPECT_NE(error.find("not finite"), std::string::npos) << error;
  // A spike folding back along itself.
  EXPECT_FALSE(decompose_convex({{0.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}, {1.0, 2.0}, {1.0, 4.0}, {1.0, 2.0}, {0.0, 2.0}},
                                &pieces, &error));
  EXPECT_TRUE(pieces.empty());
}

}  // namespace
}  // namespace qsg::render

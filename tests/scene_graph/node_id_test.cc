// Spark-DSG-compatible node ids.
#include "core/scene_graph/node_id.h"

#include <gtest/gtest.h>

namespace qsg::scene_graph {
namespace {

TEST(NodeIdTest, MatchesSparkDsgSymbols) {
  // Ids taken from a graph written by Spark-DSG (shared/data/scene_graphs/apartment_dsg.json).
  EXPECT_EQ(make_node_id('p', 6), 8070450532247928838ULL);
  EXPECT_EQ(make_node_id('R', 0), 5908722711110090752ULL);
  EXPECT_EQ(make_node_id('B', 0), 4755801206503243776ULL);
  EXPECT_EQ(make_node_id('a', 0), 6989586621679009792ULL);
  EXPECT_EQ(node_prefix(5692549928996306944ULL), 'O');
  EXPECT_EQ(node_index(make_node_id('O', 12345)), 12345u);
  EXPECT_EQ(node_label(make_node_id('p', 12)), "p(12)");
}

}  // namespace
}  // namespace qsg::scene_graph

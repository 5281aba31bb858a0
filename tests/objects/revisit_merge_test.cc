// objects::merge_revisits: the finish's merge of the visits the object layer kept apart, on a hand-built graph.
#include "core/objects/revisit_merge.h"

#include <gtest/gtest.h>

#include "core/scene_graph/scene_graph.h"
#include "tests/scene_graph/test_graph.h"

namespace qsg::objects {
namespace {

namespace sg = scene_graph;

sg::NodeId object(sg::SceneGraph* g, std::uint64_t index, semantics::Label label, const Eigen::Vector3d& lo,
                  const Eigen::Vector3d& hi, std::uint64_t time_ns) {
  sg::ObjectAttributes a;
  a.semantic_label = label;
  a.bounding_box = sg::BoundingBox::aabb(lo, hi);
  a.position_m = 0.5 * (lo + hi);
  a.last_update_time_ns = time_ns;
  const sg::NodeId id = sg::make_node_id(sg::kObjectPrefix, index);
  EXPECT_EQ(g->add_object(id, a), sg::Status::kOk);
  return id;
}

TEST(RevisitMergeTest, VisitsThatTheRulesPairMergeIntoTheLargerWithTheUnionOfBoth) {
  auto g = sg::testing::make_graph();
  // A chair seen twice, 0.1 m apart; a table over it (another label); a chair far away.
  const sg::NodeId first = object(g.get(), 0, semantics::kChair, {0, 0, 0}, {0.5, 0.5, 0.8}, 10);
  const sg::NodeId table = object(g.get(), 1, semantics::kTable, {0, 0, 0}, {1.0, 1.0, 0.7}, 10);
  const sg::NodeId far = object(g.get(), 2, semantics::kChair, {3, 0, 0}, {3.5, 0.5, 0.8}, 10);
  const sg::NodeId second = object(g.get(), 3, semantics::kChair, {0.1, 0, 0}, {0.6, 0.5, 0.8}, 50);
  // Both visits hang off places (the layer below); the survivor keeps its own and takes the other's edges.
  sg::PlaceAttributes pa;
  pa.distance_m = 1.0;
  const sg::NodeId place = sg::make_node_id(sg::kPlacePrefix, 0), other_place = sg::make_node_id(sg::kPlacePrefix, 1);
  ASSERT_EQ(g->add_place(place, pa), sg::Status::kOk);
  ASSERT_EQ(g->add_place(other_place, pa), sg::Status::kOk);
  ASSERT_EQ(g->add_edge(place, first), sg::Status::kOk);
  ASSERT_EQ(g->add_edge(other_place, second), sg::Status::kOk);
  sg::ObjectMeshIndices indices;
  indices[first] = {1, 2, 3};
  indices[second] = {3, 4, 5, 6};  // more vertices: the second visit's node survives
  indices[far] = {9};
  const RevisitMerge m = merge_revisits(Config{}, g.get(), &indices);
  EXPECT_EQ(m.objects, 4u);
  EXPECT_EQ(m.merged, 1u);
  EXPECT_FALSE(g->has_node(first));
  ASSERT_NE(g->object(second), nullptr);
  EXPECT_NE(g->object(table), nullptr) << "another label never merges";
  EXPECT_NE(g->object(far), nullptr);
  const sg::ObjectAttributes* kept = g->object(second);
  EXPECT_NEAR(kept->bounding_box.min_m.x(), 0.0, 1e-6);
  EXPECT_NEAR(kept->bounding_box.max_m.x(), 0.6, 1e-6);
  EXPECT_NEAR(kept->position_m.x(), 0.3, 1e-6) << "the box centre, as the layer reports";
  EXPECT_EQ(kept->last_update_time_ns, 50u);
  EXPECT_EQ(indices.count(first), 0u);
  EXPECT_EQ(indices[second], (std::vector<std::uint32_t>{1, 2, 3, 4, 5, 6}));
  EXPECT_TRUE(g->has_edge(other_place, second));
  EXPECT_FALSE(g->has_edge(place, second)) << "an object keeps its own parent place";
}

// A merged box is larger and may pair with an object neither part paired with: merged until nothing pairs. Of two
// with as many mesh vertices, the larger box survives. Only the paper's rule: boxes that merely intersect stay apart.
TEST(RevisitMergeTest, AGrownBoxPairsAgainAndOnlyThePapersRuleMerges) {
  for (const bool overlapping : {true, false}) {
    auto g = sg::testing::make_graph();
    // c first (it is looked at first): its centre lies in the union of a and b only.
    const sg::NodeId c = object(g.get(), 0, semantics::kSofa, {0.1, 0.5, 0}, {0.3, 1.3, 0.5}, 1);
    const sg::NodeId a = object(g.get(), 1, semantics::kSofa, {0, 0, 0}, {2.0, 0.4, 0.5}, 1);
    const sg::NodeId b = object(g.get(), 2, semantics::kSofa, {0.4, 0, 0}, {1.0, 1.0, 0.5}, 2);  // a's centre in it
    // d's box intersects a's, neither centre in the other's box; e (a bed) would fit one bed with a: no size prior.
    const sg::NodeId d = object(g.get(), 3, semantics::kSofa, {-0.8, -0.4, 0}, {0.1, 0.1, 0.5}, 3);
    const sg::NodeId e = object(g.get(), 4, semantics::kBed, {0, 2, 0}, {1.0, 2.5, 0.5}, 3);
    const sg::NodeId f = object(g.get(), 5, semantics::kBed, {1.1, 2, 0}, {2.0, 2.5, 0.5}, 3);
    Config config;
    config.merge_overlapping = overlapping;
    const RevisitMerge m = merge_revisits(config, g.get(), nullptr);
    EXPECT_TRUE(g->has_node(d)) << "intersecting boxes are a fragment rule";
    EXPECT_TRUE(g->has_node(e) && g->has_node(f)) << "so is the size prior";
    if (!overlapping) {
      EXPECT_EQ(m.merged, 0u) << "the rule switched off";
      continue;
    }
    EXPECT_EQ(m.merged, 2u) << "a and b, then c into their union";
    EXPECT_FALSE(g->has_node(c));
    EXPECT_FALSE(g->has_node(b));
    ASSERT_TRUE(g->has_node(a)) << "a's box is the larger of a and b";
    EXPECT_NEAR(g->object(a)->bounding_box.max_m.y(), 1.3, 1e-6);
    EXPECT_EQ(g->object(a)->last_update_time_ns, 2u);
  }
}

// Two chairs 0.83 m apart held at once in the first visit; the second visit saw one box over both. Merged with the
// first visit's chair, that box would take the neighbour too: lifetimes keep the two chairs of the first visit apart.
TEST(RevisitMergeTest, ObjectsTheLayerHeldAtOnceAreNotJoinedThroughAThird) {
  struct Case {
    bool with_lifetimes, keep_apart;
    std::size_t nodes_left, merged, refused;
  };
  for (const Case c : {Case{true, true, 2, 1, 1}, Case{false, true, 1, 2, 0}, Case{true, false, 1, 2, 0}}) {
    auto g = sg::testing::make_graph();
    const sg::NodeId a1 = object(g.get(), 0, semantics::kChair, {0, 0, 0}, {0.5, 0.5, 0.8}, 20);
    const sg::NodeId b1 = object(g.get(), 1, semantics::kChair, {0.83, 0, 0}, {1.33, 0.5, 0.8}, 22);
    const sg::NodeId both = object(g.get(), 2, semantics::kChair, {0.1, 0, 0}, {1.2, 0.5, 0.8}, 310);
    Lifetimes lives;
    lives[a1] = {10, 20};
    lives[b1] = {12, 22};  // overlaps a1's
    lives[both] = {300, 310};
    Config config;
    config.finish_keeps_concurrent_apart = c.keep_apart;
    const RevisitMerge m = merge_revisits(config, g.get(), nullptr, c.with_lifetimes ? &lives : nullptr);
    std::size_t left = 0;
    for (const sg::NodeId id : {a1, b1, both}) left += g->has_node(id) ? 1 : 0;
    EXPECT_EQ(left, c.nodes_left) << c.with_lifetimes << c.keep_apart;
    EXPECT_EQ(m.merged, c.merged);
    EXPECT_EQ(m.concurrent_refused, c.refused) << "counted once, in the pass that merged nothing";
    if (c.nodes_left == 2) {
      EXPECT_TRUE(g->has_node(both)) << "the larger box survives and takes the first chair";
      EXPECT_TRUE(g->has_node(b1)) << "the neighbour stays an object of its own";
      EXPECT_NEAR(g->object(both)->bounding_box.min_m.x(), 0.0, 1e-6);
    }
  }
}

// A node the layer no longer holds (no lifetime) merges by the rule alone.
TEST(RevisitMergeTest, ANodeWithoutALifetimeMergesByTheRuleAlone) {
  auto g = sg::testing::make_graph();
  const sg::NodeId a = object(g.get(), 0, semantics::kChair, {0, 0, 0}, {0.5, 0.5, 0.8}, 20);
  const sg::NodeId b = object(g.get(), 1, semantics::kChair, {0.1, 0, 0}, {0.6, 0.5, 0.8}, 30);
  Lifetimes lives;
  lives[a] = {10, 20};
  const RevisitMerge m = merge_revisits(Config{}, g.get(), nullptr, &lives);
  EXPECT_EQ(m.merged, 1u);
  EXPECT_NE(g->has_node(a), g->has_node(b));
}

}  // namespace
}  // namespace qsg::objects

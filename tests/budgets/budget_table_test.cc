// Consistency of every board's budget table: capacities fit their arenas, every task has a budget, queues are sane.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <set>
#include <string>

#include "budgets/budget_table.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/places/places.h"
#include "core/doors/online_doors.h"
#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::budgets {
namespace {

template <typename Ns>
scene_graph::Capacities scene_graph_capacities() {
  scene_graph::Capacities c;
  c.object_nodes = Ns::kObjectNodes;
  c.agent_nodes = Ns::kAgentNodes;
  c.place_nodes = Ns::kPlaceNodes;
  c.room_nodes = Ns::kRoomNodes;
  c.building_nodes = Ns::kBuildingNodes;
  c.edges = Ns::kEdges;
  c.adjacency_chunks = Ns::kAdjacencyChunks;
  c.mesh_connections = Ns::kMeshConnections;
  return c;
}
// Namespaces cannot be template arguments; wrap each board's constants in a struct.
struct HostSimSceneGraph {
#define QSG_BUDGET_FIELDS(board)                                                     \
  static constexpr std::size_t kObjectNodes = board::scene_graph::kObjectNodes;         \
  static constexpr std::size_t kAgentNodes = board::scene_graph::kAgentNodes;           \
  static constexpr std::size_t kPlaceNodes = board::scene_graph::kPlaceNodes;           \
  static constexpr std::size_t kRoomNodes = board::scene_graph::kRoomNodes;             \
  static constexpr std::size_t kBuildingNodes = board::scene_graph::kBuildingNodes;     \
  static constexpr std::size_t kEdges = board::scene_graph::kEdges;                     \
  static constexpr std::size_t kAdjacencyChunks = board::scene_graph::kAdjacencyChunks; \
  static constexpr std::size_t kMeshConnections = board::scene_graph::kMeshConnections; \
  static constexpr std::size_t kArenaBytes = board::scene_graph::kArenaBytes;
  QSG_BUDGET_FIELDS(host_sim)
};
struct XavierNxSceneGraph {
  QSG_BUDGET_FIELDS(xavier_nx)
};
#undef QSG_BUDGET_FIELDS

template <typename T>
void expect_scene_graph_fits(const char* board) {
  const scene_graph::Capacities c = scene_graph_capacities<T>();
  const std::size_t planned = scene_graph::SceneGraph::plan(c).total_bytes();
  EXPECT_LE(planned, T::kArenaBytes) << board << ": scene_graph capacities need " << planned
                                     << " bytes, its arena allows " << T::kArenaBytes;
  // Every node can have its parent edge and a few more: adjacency chunks cover at least one per edge end / 15.
  EXPECT_GE(c.adjacency_chunks * scene_graph::kAdjacencyChunkEdges, c.edges) << board;
  EXPECT_GT(c.building_nodes, 0u) << board;
}

TEST(BudgetTableTest, EveryArenaHoldsItsCapacities) {
  expect_scene_graph_fits<HostSimSceneGraph>("host_sim");
  expect_scene_graph_fits<XavierNxSceneGraph>("xavier_nx");
}

// The places layer of each board: its capacities must fit its arena.
#define QSG_PLACES_FITS(board)                                                                               \
  do {                                                                                                       \
    places::Capacities c;                                                                                    \
    c.max_blocks = budgets::board::places::kMaxBlocks;                                                       \
    c.place_nodes = budgets::board::places::kPlaceNodes;                                                     \
    c.inactive_cells = budgets::board::places::kInactiveCells;                                               \
    c.observed_blocks = budgets::board::places::kObservedBlocks;                                             \
    c.pending_relinks = budgets::board::places::kPendingRelinks;                                             \
    const std::size_t planned = places::Places::plan(c).total_bytes();                                       \
    EXPECT_LE(planned, budgets::board::places::kArenaBytes) << #board ": places capacities need " << planned; \
    std::printf(#board " places arena: planned %zu of %zu bytes\n", planned, budgets::board::places::kArenaBytes); \
  } while (0)

TEST(BudgetTableTest, PlacesArenaHoldsThePlacesLayer) {
  QSG_PLACES_FITS(host_sim);
  QSG_PLACES_FITS(xavier_nx);
}

// The room finder is sized from the graph's place, edge and room capacities; its arena is the board's "rooms".
template <typename T>
void expect_rooms_fit(const char* board, std::size_t arena_bytes) {
  const rooms::Capacities c = rooms::Capacities::from_scene_graph(scene_graph_capacities<T>());
  const std::size_t planned = rooms::RoomFinder::plan(rooms::Config{}, c).total_bytes();
  EXPECT_LE(planned, arena_bytes) << board << ": rooms capacities need " << planned << " bytes, its arena allows "
                                  << arena_bytes;
  std::printf("%s rooms arena: planned %zu of %zu bytes\n", board, planned, arena_bytes);
}

TEST(BudgetTableTest, RoomsArenaHoldsTheRoomFinder) {
  expect_rooms_fit<HostSimSceneGraph>("host_sim", budgets::host_sim::rooms::kArenaBytes);
  expect_rooms_fit<XavierNxSceneGraph>("xavier_nx", budgets::xavier_nx::rooms::kArenaBytes);
}

// The online door stage's arena holds its wall map, door set, window workspace and window places graph.
#define QSG_DOORS_FIT(board)                                                                                  \
  do {                                                                                                        \
    rooms::OnlineDoorCapacities c;                                                                            \
    c.wall_tiles = budgets::board::doors::kWallTiles;                                                         \
    c.window_side = budgets::board::doors::kWindowSide;                                                       \
    c.places = budgets::board::doors::kPlaces;                                                                \
    c.doors = budgets::board::doors::kDoors;                                                                  \
    c.candidates = budgets::board::doors::kCandidates;                                                        \
    c.place_edges = budgets::board::doors::kPlaceEdges;                                                       \
    EXPECT_EQ(c.check(), "") << #board;                                                                       \
    const std::size_t planned = rooms::OnlineDoors::plan(c).total_bytes();                                    \
    EXPECT_LE(planned, budgets::board::doors::kArenaBytes) << #board ": door capacities need " << planned;    \
    std::printf(#board " doors arena: planned %zu of %zu bytes\n", planned, budgets::board::doors::kArenaBytes); \
  } while (0)

TEST(BudgetTableTest, DoorsArenaHoldsTheOnlineDoorStage) {
  QSG_DOORS_FIT(host_sim);
  QSG_DOORS_FIT(xavier_nx);
}

template <typename Ns>
void expect_reconstruction_fits(const char* board) {
  reconstruction::Capacities c;
  c.max_blocks = Ns::kMaxBlocks;
  c.mesh_vertices = Ns::kMeshVertices;
  c.mesh_triangles = Ns::kMeshTriangles;
  c.archive_vertices = Ns::kArchiveVertices;
  c.archive_triangles = Ns::kArchiveTriangles;
  const std::size_t planned = reconstruction::SemanticTsdf::plan(c).total_bytes();
  EXPECT_LE(planned, Ns::kArenaBytes) << board << ": reconstruction capacities need " << planned
                                      << " bytes, its arena allows " << Ns::kArenaBytes;
  std::printf("%s reconstruction arena: planned %zu of %zu bytes\n", board, planned, Ns::kArenaBytes);
  // The paper's budget: the active window's TSDF + semantics within 12 MB.
  EXPECT_LE(c.max_blocks * reconstruction::kBlockVoxels * sizeof(reconstruction::Voxel), 12u << 20) << board;
}

#define QSG_RECONSTRUCTION_FIELDS(board)                                                     \
  static constexpr std::size_t kMaxBlocks = board::reconstruction::kMaxBlocks;               \
  static constexpr std::size_t kMeshVertices = board::reconstruction::kMeshVertices;         \
  static constexpr std::size_t kMeshTriangles = board::reconstruction::kMeshTriangles;       \
  static constexpr std::size_t kArchiveVertices = board::reconstruction::kArchiveVertices;   \
  static constexpr std::size_t kArchiveTriangles = board::reconstruction::kArchiveTriangles; \
  static constexpr std::size_t kArenaBytes = board::reconstruction::kArenaBytes;
struct HostSimReconstruction {
  QSG_RECONSTRUCTION_FIELDS(host_sim)
};
struct XavierNxReconstruction {
  QSG_RECONSTRUCTION_FIELDS(xavier_nx)
};
#undef QSG_RECONSTRUCTION_FIELDS

TEST(BudgetTableTest, ReconstructionArenaHoldsItsCapacities) {
  expect_reconstruction_fits<HostSimReconstruction>("host_sim");
  expect_reconstruction_fits<XavierNxReconstruction>("xavier_nx");
}

TEST(BudgetTableTest, EveryBoardIsInTheGeneratedList) {
  std::set<std::string> boards;
  for (const BoardTable* t : kAllBoards) boards.insert(t->board);
  EXPECT_EQ(boards.count("host_sim"), 1u);
  EXPECT_EQ(boards.count("xavier_nx"), 1u);
}

TEST(BudgetTableTest, EveryTaskHasABudgetAndOneCadence) {
  for (const BoardTable* t : kAllBoards) {
    ASSERT_GT(t->num_tasks, 0u) << t->board;
    for (std::size_t i = 0; i < t->num_tasks; ++i) {
      const TaskBudget& task = t->tasks[i];
      SCOPED_TRACE(std::string(t->board) + "." + task.name);
      EXPECT_GT(task.budget_us, 0u) << "every task needs a time budget";
      const bool rate = task.rate_hz > 0.0;
      const bool keyframe = task.every_n_keyframes > 0;
      EXPECT_NE(rate, keyframe) << "exactly one of rate_hz and every_n_keyframes";
      if (keyframe) {
        EXPECT_LT(task.offset, task.every_n_keyframes);
      }
      if (rate) {
        EXPECT_LE(task.budget_us, 1e6 / task.rate_hz) << "budget longer than the task's period";
      }
    }
    EXPECT_NE(t->find_task("frontend"), nullptr) << t->board << " must schedule the frontend";
    EXPECT_NE(t->find_task("reconstruction"), nullptr) << t->board;
  }
}

TEST(BudgetTableTest, BoardsDeclareTheSameTasksArenasAndQueues) {
  const BoardTable& ref = *kAllBoards[0];
  for (const BoardTable* t : kAllBoards) {
    ASSERT_EQ(t->num_tasks, ref.num_tasks) << t->board;
    ASSERT_EQ(t->num_arenas, ref.num_arenas) << t->board;
    ASSERT_EQ(t->num_capacities, ref.num_capacities) << t->board;
    ASSERT_EQ(t->num_queues, ref.num_queues) << t->board;
    for (std::size_t i = 0; i < t->num_tasks; ++i) EXPECT_STREQ(t->tasks[i].name, ref.tasks[i].name) << t->board;
    for (std::size_t i = 0; i < t->num_queues; ++i) {
      EXPECT_STREQ(t->queues[i].name, ref.queues[i].name) << t->board;
      EXPECT_GT(t->queues[i].depth, 0u) << t->board << "." << t->queues[i].name;
    }
    for (std::size_t i = 0; i < t->num_capacities; ++i) {
      EXPECT_STREQ(t->capacities[i].name, ref.capacities[i].name) << t->board;
      EXPECT_NE(t->find_arena(t->capacities[i].arena), nullptr) << t->board << ": capacity in an undeclared arena";
    }
  }
}

// The worker threads outside the tick loop have budgets too, on every board, and the segmentation worker has the
// slots it needs (one frame in work, one labelled waiting for the loop).
TEST(BudgetTableTest, EveryBoardBudgetsTheWorkerThreads) {
  for (const BoardTable* t : kAllBoards) {
    for (const char* name : {"segmentation", "backend"}) {
      const ThreadBudget* b = t->find_thread(name);
      ASSERT_NE(b, nullptr) << t->board << ": no thread budget '" << name << "'";
      EXPECT_GT(b->budget_us, 0u) << t->board << "." << name;
    }
    // The backend's door pass is a budgeted part of its update, and its final stage has a budget of its own.
    const ThreadBudget* backend = t->find_thread("backend");
    EXPECT_GT(backend->part_budget_us, 0u) << t->board << ": the online door pass";
    EXPECT_LT(backend->part_budget_us, backend->budget_us) << t->board << ": the door pass is part of an update";
    EXPECT_GT(backend->finish_budget_us, 0u) << t->board << ": the final stage";
    // A deformation-graph solve is a run of its own, longer than an update, and must end well before the next one
    // can be due (loop_closure.solve_interval_s, 10 s by default): at most half of it.
    EXPECT_GT(backend->solve_budget_us, backend->budget_us) << t->board << ": the loop-closure solve";
    EXPECT_LE(backend->solve_budget_us, 5000000u) << t->board << ": half the default solve interval";
    EXPECT_GE(t->find_thread("segmentation")->every_n_keyframes, 1u) << t->board;
    EXPECT_LE(t->find_thread("segmentation")->every_n_keyframes, 5u) << t->board << ": the paper's 1 Hz at 5 Hz keyframes";
    const QueueBudget* slots = nullptr;
    for (std::size_t i = 0; i < t->num_queues; ++i)
      if (std::string(t->queues[i].name) == "segmentation") slots = &t->queues[i];
    ASSERT_NE(slots, nullptr) << t->board;
    EXPECT_GE(slots->depth, 2u) << t->board;
    EXPECT_EQ(t->find_thread("no_such_thread"), nullptr);
  }
}

TEST(BudgetTableTest, ActiveBoardIsTheConfiguredOne) {
  EXPECT_GT(active::scene_graph::kArenaBytes, 0u);
  EXPECT_GE(active::tasks::frontend::kEveryNKeyframes, 1u);
}

TEST(BudgetTableTest, XavierRunsTheFrontendEveryFifthKeyframeAsThePaper) {
  EXPECT_EQ(xavier_nx::tasks::frontend::kEveryNKeyframes, 5u);
  EXPECT_EQ(host_sim::tasks::frontend::kEveryNKeyframes, 1u);
}

}  // namespace
}  // namespace qsg::budgets

// The frontend's orchestration of places, objects and agents.
#include "core/frontend/frontend.h"

#include <algorithm>

#include "budgets/budget_table.h"
#include "core/frontend/frontend_params.h"

namespace qsg::frontend {

std::string Config::check() const {
  if (std::string why = params::check(params_table(), *this); !why.empty()) return why;  // frontend_params.cc
  if (const std::string p = places.check(); !p.empty()) return "places: " + p;
  if (const std::string o = objects.check(); !o.empty()) return "objects: " + o;
  if (const std::string a = agents.check(); !a.empty()) return "agents: " + a;
  return {};
}

void Config::print(std::FILE* out) const {
  places.print(out);
  objects.print(out);
  agents.print(out);
  std::fprintf(out, "frontend: connect_interlayer=%d reparent_untracked_every=%u\n", connect_interlayer ? 1 : 0,
               reparent_untracked_every);
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "frontend: updates=%llu places_cycles=%llu deadline_stops=%llu interlayer connected=%llu failed=%llu "
               "reconnected=%llu reparent_refreshes=%llu objects_reparented=%llu graph_refused=%llu\n",
               (unsigned long long)updates, (unsigned long long)places_cycles, (unsigned long long)deadline_stops,
               (unsigned long long)interlayer_connected, (unsigned long long)interlayer_failed,
               (unsigned long long)interlayer_reconnected, (unsigned long long)reparent_refreshes,
               (unsigned long long)objects_reparented, (unsigned long long)graph_refused);
}

bool Frontend::init(const Config& config, std::string* error) {
  if (ready_) return *error = "frontend: init() called twice", false;
  if (const std::string bad = config.check(); !bad.empty()) return *error = "frontend: config: " + bad, false;
  config_ = config;
  if (!places_.init(config.places, places::capacities_from_budget(), places::arena_bytes_from_budget(), error) ||
      !objects_.init(config.objects, objects::capacities_from_budget(), budgets::active::objects::kArenaBytes, error) ||
      !agents_.init(config.agents, agents::capacities_from_budget(), error))
    return false;
  const NearestPlaceCapacities index_caps = nearest_place_capacities_from_budget();
  index_.set_name("frontend.active_places_index");
  all_places_index_.set_name("frontend.all_places_index");
  if (!index_.init(index_caps, NearestPlaceIndex::plan(index_caps).total_bytes(), error) ||
      !all_places_index_.init(index_caps, IncrementalPlaceIndex::plan(index_caps).total_bytes(), error))
    return false;
  ready_ = true;
  return true;
}

agents::AddResult Frontend::add_keyframe(scene_graph::SceneGraph* graph, std::uint64_t timestamp_ns,
                                         const Eigen::Isometry3d& world_T_body,
                                         const Eigen::Matrix<double, 6, 1>& variance) {
  return agents_.add_keyframe(graph, timestamp_ns, world_T_body, 0, variance);
}

UpdateSummary Frontend::update(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m,
                               std::uint64_t time_ns, scene_graph::SceneGraph* graph, const Deadline& deadline) {
  UpdateSummary summary;
  if (!ready_) return summary;
  ++counters_.updates;
  // Objects first: one pass over the re-meshed blocks, far below any budget (their own bound is the number of
  // new vertices), so they never starve behind the places' wavefronts.
  summary.objects = objects_.update(tsdf, time_ns);
  if (!objects_.sync(graph)) ++counters_.graph_refused;

  places::Deadline pd;
  pd.max_work_units = deadline.max_work_units;
  if (deadline.now != nullptr) {
    pd.expired = [](const void* d) { return static_cast<const Deadline*>(d)->expired(); };
    pd.context = &deadline;
  }
  const places::UpdateResult pr = places_.update(tsdf, robot_m, pd);
  summary.places_complete = pr.complete;
  summary.places_work_units = pr.work_units;
  if (!pr.complete) {
    ++counters_.deadline_stops;  // the cycle resumes where it stopped on the next call
    return summary;
  }
  ++counters_.places_cycles;
  summary.places_sync = places_.sync(graph);
  if (summary.places_sync.status != scene_graph::Status::kOk) ++counters_.graph_refused;
  if (config_.connect_interlayer) connect_interlayer(graph, robot_m, &summary);
  return summary;
}

bool Frontend::near_active_places(const objects::ObjectView& o, const Eigen::Vector3d& robot_m) const {
  if (o.num_tracked == 0) return false;
  if (config_.reparent_untracked_every == 0) return true;
  const double reach = std::max(0.0, config_.places.window_radius_m - 1.0);
  return (o.position_m - robot_m).squaredNorm() <= reach * reach;
}

void Frontend::connect_interlayer(scene_graph::SceneGraph* graph, const Eigen::Vector3d& robot_m,
                                  UpdateSummary* summary) {
  // Places were removed: their keyframes may have lost their place (the sweep below; connected ones only).
  if (summary->places_sync.nodes_removed > 0) orphan_checks_left_ = agents_connected_;
  refresh_place_indices(*graph);
  // Objects out of the window among all places (also when no place is active, e.g. far from everything mapped).
  if (config_.reparent_untracked_every > 0 && ++cycles_since_reparent_ >= config_.reparent_untracked_every) {
    cycles_since_reparent_ = 0;
    reparent_untracked(graph, robot_m, summary);
  }
  if (index_.size() == 0) return;
  // Every object in the window (an object's nearest place changes as places appear around it), and the
  // keyframes added since the last refresh.
  connect_nodes_.clear();
  objects_.for_each_object([&](const objects::ObjectView& o) {
    if (o.node != scene_graph::kNoNode && near_active_places(o, robot_m) && graph->has_node(o.node))
      connect_nodes_.push_back(o.node);
  });
  const std::size_t keyframes = agents_.num_keyframes();
  std::size_t k = agents_connected_;
  for (; k < keyframes && !connect_nodes_.full(); ++k)
    if (graph->has_node(agents_.node_of(k))) connect_nodes_.push_back(agents_.node_of(k));  // not folded away
  // Keyframes connected before whose place has since been removed.
  constexpr std::size_t kOrphanChecksPerUpdate = 4096;
  for (std::size_t checked = 0;
       checked < kOrphanChecksPerUpdate && orphan_checks_left_ > 0 && !connect_nodes_.full(); ++checked) {
    --orphan_checks_left_;
    if (orphan_cursor_ >= agents_connected_) orphan_cursor_ = 0;
    const scene_graph::NodeId id = agents_.node_of(orphan_cursor_++);
    const scene_graph::NodeRecord* n = graph->node(id);
    if (n != nullptr && n->parent == scene_graph::kNoNode) {
      connect_nodes_.push_back(id);
      ++counters_.interlayer_reconnected;
    }
  }
  agents_connected_ = k;
  summary->connect = connect_to_nearest_places(graph, index_, connect_nodes_.data(), connect_nodes_.size());
  counters_.interlayer_connected += summary->connect.connected;
  counters_.interlayer_failed += summary->connect.failed;
}

// Both indices from the window's published places (the places cycle bounds them, not the building): each goes
// into the all-places index at its graph position (inserted or moved), and the active ones into the k-d tree. Places
// that left the window stay in the all-places index where they were; those removed from the graph are skipped by
// its queries and dropped by a bounded sweep, which also moves a place the graph moved (a loop-closure correction).
void Frontend::refresh_place_indices(const scene_graph::SceneGraph& graph) {
  struct Context {
    const scene_graph::SceneGraph* graph;
    NearestPlaceIndex* active;
    IncrementalPlaceIndex* all;
  } context{&graph, &index_, &all_places_index_};
  index_.clear_points();
  const std::uint64_t failed_before = all_places_index_.failed();
  places_.for_each_published(
      [](void* c, scene_graph::NodeId node, const Eigen::Vector3d&) {
        Context& ctx = *static_cast<Context*>(c);
        const scene_graph::PlaceAttributes* a = ctx.graph->place(node);
        if (a == nullptr || !a->position_m.allFinite()) return;
        ctx.all->upsert(node, a->position_m);
        if (a->is_active) ctx.active->add_point(node, a->position_m);
      },
      &context);
  index_.build_tree();
  const auto check = [&](scene_graph::NodeId id, const Eigen::Vector3d& p, Eigen::Vector3d* to) {
    const scene_graph::PlaceAttributes* a = graph.place(id);
    if (a == nullptr || !a->position_m.allFinite()) return 1;
    if (a->position_m == p) return 0;
    *to = a->position_m;
    return 2;
  };
  constexpr std::size_t kSweepPerCycle = 512;
  all_places_index_.sweep(kSweepPerCycle, check);
  // Full (removed places not swept yet hold slots): one whole sweep; the refused places come in next cycle.
  if (all_places_index_.failed() != failed_before) all_places_index_.sweep(all_places_index_.capacity(), check);
}

void Frontend::reparent_untracked(scene_graph::SceneGraph* graph, const Eigen::Vector3d& robot_m,
                                  UpdateSummary* summary) {
  connect_nodes_.clear();
  objects_.for_each_object([&](const objects::ObjectView& o) {
    if (o.node != scene_graph::kNoNode && !near_active_places(o, robot_m) && !connect_nodes_.full() &&
        graph->has_node(o.node))
      connect_nodes_.push_back(o.node);
  });
  ++counters_.reparent_refreshes;
  if (connect_nodes_.empty() || all_places_index_.size() == 0) return;
  summary->reparent = connect_to_nearest_places(graph, all_places_index_, connect_nodes_.data(), connect_nodes_.size());
  counters_.objects_reparented += summary->reparent.connected;
  counters_.interlayer_failed += summary->reparent.failed;
}

}  // namespace qsg::frontend

// Layer 3, places: construction and the stores (one arena), the anytime update() that runs the paper's steps in
// order (ESDF waves, GVD, sparsification, then the repair passes), memory use and the read-only queries. The
// steps live in esdf.cc, gvd.cc, sparsify.cc, the pass_*.cc files and graph_mirror.cc (README.md).
#include "core/places/places_internal.h"

namespace qsg::places {

Places::Places()
    : blocks_("places.blocks", memory::OverflowPolicy::kRefuse),
      block_index_("places.block_index", memory::OverflowPolicy::kRefuse),
      clusters_("places.clusters", memory::OverflowPolicy::kRefuse),
      inactive_("places.inactive_cells", memory::OverflowPolicy::kRefuse),
      cells_("places.cell_index", memory::OverflowPolicy::kRefuse),
      observed_{memory::SpatialHash<std::uint32_t>("places.observed_blocks_a", memory::OverflowPolicy::kRefuse),
                memory::SpatialHash<std::uint32_t>("places.observed_blocks_b", memory::OverflowPolicy::kRefuse)} {}

Places::~Places() {
  if (ready_) {
    blocks_.clear();
    clusters_.clear();
  }
}

namespace {
std::size_t list_capacity(const Capacities& c, int which) {
  return which == kDirtyList ? c.max_blocks * kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor
                             : c.max_blocks * kBlockVoxels;
}
}  // namespace

memory::ArenaPlan Places::plan(const Capacities& c) {
  memory::ArenaPlan plan;
  memory::Pool<Block>::plan(plan, c.max_blocks);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.max_blocks));
  memory::Pool<Cluster>::plan(plan, c.place_nodes);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.inactive_cells));
  plan.add_array<InactiveEntry>(c.inactive_cells);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.place_nodes));
  for (int i = 0; i < 2; ++i)
    memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.observed_blocks));
  plan.add_array<Relink>(c.pending_relinks);
  plan.add_array<List>(kNumLists);
  for (int i = 0; i < kNumLists; ++i) plan.add_array<std::uint32_t>(list_capacity(c, i));
  plan.add_array<std::uint32_t>(c.max_blocks * kBlockVoxels);  // lower-wave ring
  return plan;
}

bool Places::init(const Config& config, const Capacities& c, std::size_t budget_bytes, std::string* error) {
  const auto fail = [error](const std::string& why) {
    if (error != nullptr) *error = "places: " + why;
    return false;
  };
  if (ready_) return fail("init() called twice");
  const std::string bad = config.check();
  if (!bad.empty()) return fail("config: " + bad);
  if (c.max_blocks == 0 || c.place_nodes == 0 || c.inactive_cells == 0 || c.observed_blocks == 0 ||
      c.pending_relinks == 0)
    return fail("capacities: max_blocks, place_nodes, inactive_cells, observed_blocks and pending_relinks must be "
                "positive");
  if (c.max_blocks > (kNoRef / kBlockVoxels) - 1) return fail("capacities: max_blocks too large for 32-bit voxel refs");
  config_ = config;
  capacities_ = c;
  if (!arena_.create("places", plan(c), budget_bytes, error)) return false;
  bool ok = blocks_.carve(arena_, c.max_blocks) &&
            block_index_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.max_blocks), c.max_blocks) &&
            clusters_.carve(arena_, c.place_nodes) &&
            inactive_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.inactive_cells),
                            c.inactive_cells) &&
            cells_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.place_nodes), c.place_nodes) &&
            observed_[0].carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.observed_blocks),
                               c.observed_blocks) &&
            observed_[1].carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.observed_blocks),
                               c.observed_blocks);
  inactive_entries_ = ok ? arena_.carve_array<InactiveEntry>(c.inactive_cells) : nullptr;
  ok = ok && inactive_entries_ != nullptr;
  for (std::size_t i = 0; ok && i < c.inactive_cells; ++i)
    inactive_entries_[i].next = i + 1 < c.inactive_cells ? static_cast<std::uint32_t>(i + 1) : kNoRef;
  inactive_free_ = 0;
  relinks_ = ok ? arena_.carve_array<Relink>(c.pending_relinks) : nullptr;
  ok = ok && relinks_ != nullptr;
  lists_ = ok ? arena_.carve_array<List>(kNumLists) : nullptr;
  ok = ok && lists_ != nullptr;
  static const char* const kNames[kNumLists] = {"places.dirty_tsdf_blocks", "places.raise_list",
                                                "places.affected_list", "places.gvd_eval_list",
                                                "places.gvd_changed_list"};
  for (int i = 0; ok && i < kNumLists; ++i) {
    lists_[i].capacity = list_capacity(c, i);
    lists_[i].name = kNames[i];
    lists_[i].data = arena_.carve_array<std::uint32_t>(lists_[i].capacity);
    ok = lists_[i].data != nullptr;
  }
  lower_capacity_ = c.max_blocks * kBlockVoxels;
  lower_ring_ = ok ? arena_.carve_array<std::uint32_t>(lower_capacity_) : nullptr;
  if (!ok || lower_ring_ == nullptr || !arena_.seal()) return fail("the arena carve did not match its plan");
  cos_theta_ = static_cast<float>(std::cos(config_.min_basis_angle_rad));
  ready_ = true;
  return true;
}

memory::ResourceStats Places::lower_queue_stats() const {
  memory::ResourceStats s;
  s.name = "places.lower_queue";
  s.unit = "voxels";
  s.capacity = lower_capacity_;
  s.in_use = lower_size_;
  s.high_water = lower_high_water_;
  return s;
}

memory::ResourceStats Places::relink_stats() const {
  memory::ResourceStats s;
  s.name = "places.pending_relinks";
  s.unit = "edges";
  s.capacity = capacities_.pending_relinks;
  s.in_use = num_relinks_;
  s.high_water = relinks_high_water_;
  s.failed = counters_.relinks_refused;
  return s;
}

memory::ResourceStats Places::inactive_entry_stats() const {
  return {"places.inactive_places", "places", capacities_.inactive_cells, inactive_used_, inactive_high_water_,
          counters_.inactive_forgotten};
}

memory::ResourceStats Places::list_stats(int which) const {
  memory::ResourceStats s;
  if (lists_ == nullptr) return s;
  const List& l = lists_[which];
  s.name = l.name;
  s.unit = which == kDirtyList ? "blocks" : "voxels";
  s.capacity = l.capacity;
  s.in_use = l.size;
  s.high_water = l.high_water;
  s.failed = l.failed;
  return s;
}

// ---------------------------------------------------------------------------------------------------------
// The anytime cycle: the paper's steps in order

UpdateResult Places::update(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m,
                            const Deadline& deadline) {
  UpdateResult result;
  if (!ready_) return result;
  ++counters_.updates;
  units_ = 0;
  // The path search reads the deadline too; the pointer lives exactly as long as this call.
  struct DeadlineScope {
    const Deadline** slot;
    ~DeadlineScope() { *slot = nullptr; }
  } scope{&deadline_};
  deadline_ = &deadline;
  const std::uint32_t every = deadline.check_every == 0 ? 1 : deadline.check_every;
  // At least one unit of work per call, so repeated calls always finish a cycle.
  const auto expired = [&]() {
    if (units_ == 0) return false;
    if (units_ >= deadline.max_work_units) return true;
    return deadline.expired != nullptr && units_ % every == 0 && deadline.expired(deadline.context);
  };
  const auto run_list = [&](int which, auto&& step) {
    List& l = lists_[which];
    while (cursor_ < l.size) {
      if (expired()) return false;
      step(l.data[cursor_++]);
      ++units_;
    }
    l.clear();
    cursor_ = 0;
    return true;
  };
  for (;;) {
    switch (phase_) {
      case kIdle:  // the TSDF blocks integrated since their last read, the window around the robot (esdf.cc)
        begin_cycle(tsdf, robot_m);
        ++units_;
        cursor_ = 0;
        phase_ = kSeedPhase;
        break;
      case kSeedPhase:  // ESDF seeds from the TSDF's zero crossings, free space carved by rays (esdf.cc)
        if (!run_list(kDirtyList, [&](std::uint32_t e) {
              constexpr std::uint32_t kSubs = kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor;
              seed_sub_block(tsdf, e / kSubs, static_cast<int>(e % kSubs), true);
            }))
          return {false, units_};
        phase_ = kRaisePhase;
        break;
      case kRaisePhase:  // the brushfire's raise wave: distances whose source is gone (esdf.cc)
        if (!run_list(kRaiseList, [&](std::uint32_t r) { raise_step(r); })) return {false, units_};
        phase_ = kLowerPhase;
        break;
      case kLowerPhase:  // ... and its lower wave: new and shorter distances (esdf.cc)
        while (lower_size_ > 0) {
          if (expired()) return {false, units_};
          const std::uint32_t r = lower_ring_[lower_head_];
          lower_head_ = (lower_head_ + 1) % lower_capacity_;
          --lower_size_;
          lower_step(tsdf, r);
          ++units_;
        }
        lower_head_ = 0;
        phase_ = kGvdExpand;
        break;
      case kGvdExpand:  // GVD: the voxels around every changed distance are re-tested (gvd.cc)
        if (!run_list(kAffectedList, [&](std::uint32_t r) { expand_affected(r); })) return {false, units_};
        phase_ = kGvdEval;
        break;
      case kGvdEval:  // ... where wavefronts meet, theta-SMA and clearance filters (gvd.cc)
        if (!run_list(kEvalList, [&](std::uint32_t r) { gvd_step(r); })) return {false, units_};
        phase_ = kSparsify;
        break;
      case kSparsify:  // Algorithm 1: changed GVD voxels clustered per hash cell (sparsify.cc)
        if (!run_list(kChangedList, [&](std::uint32_t r) { sparsify_step(r); })) return {false, units_};
        phase_ = kFinalize;
        break;
      case kFinalize:  // node attributes and edges of every changed place; free-space edges (sparsify.cc, pass_*)
        while (cursor_ < clusters_.capacity()) {
          if (expired()) return {false, units_};
          const std::uint32_t h = static_cast<std::uint32_t>(cursor_++);
          if (clusters_.live(h) && clusters_[h].state == kLive && clusters_[h].dirty) {
            finalize_cluster(tsdf, h, true);
            ++units_;
          } else if ((h & 63) == 0) {
            ++units_;  // scanning slots costs too, a little
          }
        }
        cursor_ = 0;
        counters_.bridges_missing = 0;
        phase_ = kBridge;
        break;
      case kBridge:  // repair pass: small fragments bridged, pockets and islands held back (pass_bridges.cc)
        while (config_.bridge_fragments && cursor_ < clusters_.capacity()) {
          if (expired()) return {false, units_};
          const std::uint32_t h = static_cast<std::uint32_t>(cursor_++);
          if (clusters_.live(h) && clusters_[h].state == kLive && clusters_[h].bridge_check &&
              clusters_[h].rep != kNoRef) {
            bridge_fragment(h);
            ++units_;
          } else if ((h & 63) == 0) {
            ++units_;
          }
        }
        cursor_ = 0;
        phase_ = kIdle;
        finish_cycle();
        result.complete = true;
        result.work_units = units_;
        return result;
      default:
        phase_ = kIdle;
        break;
    }
  }
}

// The end of a cycle: its counters, and the current free-space edges, bridges and held places.
void Places::finish_cycle() {
  ++counters_.cycles;
  counters_.free_space_edges = 0;
  counters_.bridges = 0;
  counters_.enclosed_held = 0;
  clusters_.for_each([&](std::uint32_t, const Cluster& c) {
    if (c.state != kLive) return;
    counters_.enclosed_held += c.held;
    for (int k = 0; k < c.num_edges; ++k) {
      counters_.free_space_edges += c.edge_free[k] == kEdgeFree ? 1 : 0;
      counters_.bridges += c.edge_free[k] == kEdgeBridge ? 1 : 0;
    }
  });
  counters_.free_space_edges /= 2;
  counters_.bridges /= 2;
}

// ---------------------------------------------------------------------------------------------------------
// Memory use and queries

MemoryUse Places::memory_use() const {
  MemoryUse m;
  m.block_bytes = sizeof(Block);
  const memory::ResourceStats bs = blocks_.stats();
  m.blocks_high_water = bs.high_water;
  m.blocks_capacity = capacities_.max_blocks;
  m.esdf_used_bytes = bs.high_water * sizeof(Block);
  {
    memory::ArenaPlan p;
    memory::Pool<Block>::plan(p, capacities_.max_blocks);
    memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.max_blocks));
    m.esdf_planned_bytes = p.total_bytes();
  }
  for (int i = 0; lists_ != nullptr && i < kNumLists; ++i) {
    m.work_lists_used_bytes += lists_[i].high_water * sizeof(std::uint32_t);
    m.work_lists_planned_bytes += lists_[i].capacity * sizeof(std::uint32_t);
  }
  m.work_lists_used_bytes += lower_high_water_ * sizeof(std::uint32_t);
  m.work_lists_planned_bytes += lower_capacity_ * sizeof(std::uint32_t);
  {
    const memory::ResourceStats cs = clusters_.stats(), cells = cells_.stats(), in = inactive_.stats();
    memory::ArenaPlan p;
    memory::Pool<Cluster>::plan(p, capacities_.place_nodes);
    memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.inactive_cells));
    p.add_array<InactiveEntry>(capacities_.inactive_cells);
    memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.place_nodes));
    p.add_array<Relink>(capacities_.pending_relinks);
    m.places_planned_bytes = p.total_bytes();
    // Used: slots at their high water, each at its planned share of the store.
    const auto share = [](std::size_t planned, std::size_t used, std::size_t capacity) {
      return capacity == 0 ? 0 : planned * used / capacity;
    };
    memory::ArenaPlan pc, pi, ph;
    memory::Pool<Cluster>::plan(pc, capacities_.place_nodes);
    memory::SpatialHash<std::uint32_t>::plan(pi, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.inactive_cells));
    memory::SpatialHash<std::uint32_t>::plan(ph, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.place_nodes));
    m.places_used_bytes = share(pc.total_bytes(), cs.high_water, cs.capacity) +
                          share(pi.total_bytes(), in.high_water, in.capacity) +
                          inactive_high_water_ * sizeof(InactiveEntry) +
                          share(ph.total_bytes(), cells.high_water, cells.capacity) +
                          relinks_high_water_ * sizeof(Relink);
  }
  m.arena_planned_bytes = plan(capacities_).total_bytes();
  return m;
}

std::uint32_t Places::voxel_at(const Eigen::Vector3d& p_m) const {
  if (!ready_) return kNoRef;
  return find_voxel({static_cast<std::int32_t>(std::floor(p_m.x() / voxel_m_)),
                     static_cast<std::int32_t>(std::floor(p_m.y() / voxel_m_)),
                     static_cast<std::int32_t>(std::floor(p_m.z() / voxel_m_))});
}

bool Places::distance_at(const Eigen::Vector3d& p_m, float* distance_m) const {
  const std::uint32_t ref = voxel_at(p_m);
  if (ref == kNoRef) return false;
  const Voxel& v = vox(ref);
  if ((v.state != kFree && v.state != kSeed) || v.parent == kNoRef) return false;
  *distance_m = v.distance_m;
  return true;
}

bool Places::probe(const Eigen::Vector3d& p_m, VoxelProbe* out) const {
  const std::uint32_t ref = voxel_at(p_m);
  if (ref == kNoRef) return false;
  static constexpr const char* kStates[] = {"free", "seed", "occupied", "unobserved"};
  const Voxel& v = vox(ref);
  *out = VoxelProbe{};
  out->position_m = center_m(coords(ref));
  out->state = kStates[v.state & 3];
  out->carved = (v.flags & kCarved) != 0;
  out->gvd = (v.flags & kGvd) != 0;
  out->distance_m = v.distance_m;
  out->num_basis_points = v.num_basis;
  if (v.parent != kNoRef) {
    const Voxel& pv = vox(v.parent);
    out->has_parent = true;
    out->parent_m = center_m(coords(v.parent));
    out->parent_state = kStates[pv.state & 3];
    out->parent_distance_m = pv.distance_m;
  }
  return true;
}

void Places::gvd_voxels(std::vector<GvdVoxelInfo>* out) const {
  out->clear();
  if (!ready_) return;
  blocks_.for_each([&](std::uint32_t h, const Block&) {
    for (int local = 0; local < kBlockVoxels; ++local) {
      const std::uint32_t ref = make_ref(h, local);
      const Voxel& v = vox(ref);
      if ((v.flags & kGvd) == 0) continue;
      GvdVoxelInfo info;
      info.position_m = center_m(coords(ref));
      info.clearance_m = v.distance_m;
      info.num_basis_points = v.num_basis;
      std::uint32_t parents[kMaxBasis];
      const int n = std::min(std::max(0, evaluate_gvd(ref, parents, kMaxBasis)), kMaxBasis);
      for (int k = 0; k < n; ++k) info.basis_m.push_back(center_m(coords(parents[k])));
      out->push_back(info);
    }
  });
}

void Places::places(std::vector<PlaceInfo>* out) const {
  out->clear();
  if (!ready_) return;
  clusters_.for_each([&](std::uint32_t, const Cluster& c) {
    if (c.state != kLive) return;
    PlaceInfo p;
    p.id = c.node;
    p.position_m = c.position_m;
    p.clearance_m = c.clearance_m;
    p.num_basis_points = c.num_basis;
    p.num_voxels = c.count;
    for (int k = 0; k < c.num_edges; ++k)
      (c.edge_free[k] == kEdgeBridge ? p.bridge_edges : c.edge_free[k] == kEdgeFree ? p.free_space_edges : p.edges)
          .emplace_back(clusters_[c.edge_to[k]].node, c.edge_weight[k]);
    for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next) {
      p.voxel_positions_m.push_back(center_m(coords(r)));
      p.voxel_clearances_m.push_back(vox(r).distance_m);
      p.voxel_basis_points.push_back(vox(r).num_basis);
    }
    out->push_back(std::move(p));
  });
}

std::size_t Places::num_place_edges() const {
  std::size_t n = 0;
  clusters_.for_each([&](std::uint32_t, const Cluster& c) {
    if (c.state == kLive) n += c.num_edges;
  });
  return n / 2;
}

}  // namespace qsg::places

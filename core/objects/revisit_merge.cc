// merge_revisits(): the finish's merge of objects the frontend kept apart by visit.
#include "core/objects/revisit_merge.h"

#include <algorithm>
#include <array>
#include <vector>

#include "core/scene_graph/scene_graph.h"

namespace qsg::objects {

namespace {

struct Box {
  float lo[3], hi[3];
};

Box box_of(const scene_graph::ObjectAttributes& o) {
  Box b;
  const bool valid = o.bounding_box.type != scene_graph::BoundingBox::Type::kInvalid;
  for (int i = 0; i < 3; ++i) {  // no box: the position alone
    b.lo[i] = static_cast<float>(valid ? o.bounding_box.min_m[i] : o.position_m[i]);
    b.hi[i] = static_cast<float>(valid ? o.bounding_box.max_m[i] : o.position_m[i]);
  }
  return b;
}

float volume(const Box& b) { return (b.hi[0] - b.lo[0]) * (b.hi[1] - b.lo[1]) * (b.hi[2] - b.lo[2]); }

}  // namespace

void RevisitMerge::print(std::FILE* out) const {
  std::fprintf(out,
               "objects: %zu revisits merged at the finish of %zu objects (one's centre in the other's box), %zu pairs "
               "held at once kept apart, %zu edges refused\n",
               merged, objects, concurrent_refused, edges_refused);
}

Lifetimes lifetimes(const ObjectLayer& layer) {
  Lifetimes out;
  layer.for_each_object([&](const ObjectView& v) { out[v.node] = {v.first_update_ns, v.last_update_ns}; });
  return out;
}

RevisitMerge merge_revisits(const Config& config, scene_graph::SceneGraph* graph,
                            scene_graph::ObjectMeshIndices* indices, const Lifetimes* lifetimes) {
  RevisitMerge out;
  if (!config.finish_keeps_concurrent_apart) lifetimes = nullptr;
  // The paper's rule alone (as Config::merge_overlapping switches it). The frontend's fragment rules (intersecting
  // boxes; the size prior, which merge_rule leaves out for a new cluster) join the pieces of one visit; between
  // whole visits they also joined a visit with a neighbour of its label.
  Config paper_rule = config;
  paper_rule.merge_intersecting = false;
  std::array<std::vector<scene_graph::NodeId>, semantics::kNumObjectLabels> by_label;
  graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kObject) return;
    const scene_graph::ObjectAttributes* o = graph->object(n.id);
    if (o == nullptr || o->semantic_label >= semantics::kNumObjectLabels) return;
    by_label[o->semantic_label].push_back(n.id);
    ++out.objects;
  });
  const auto size_of = [&](scene_graph::NodeId id) {
    if (indices == nullptr) return std::size_t{0};
    const auto it = indices->find(id);
    return it == indices->end() ? std::size_t{0} : it->second.size();
  };
  for (semantics::Label label = 0; label < semantics::kNumObjectLabels; ++label) {
    std::vector<scene_graph::NodeId>& ids = by_label[label];
    std::sort(ids.begin(), ids.end());  // deterministic whatever the graph's storage order
    std::vector<bool> gone(ids.size(), false);
    // The lifetimes of the nodes merged into each (its own first).
    std::vector<std::vector<Lifetime>> lives(ids.size());
    if (lifetimes != nullptr)
      for (std::size_t i = 0; i < ids.size(); ++i)
        if (const auto it = lifetimes->find(ids[i]); it != lifetimes->end()) lives[i].push_back(it->second);
    const auto held_at_once = [&](std::size_t a, std::size_t b) {
      for (const Lifetime& x : lives[a])
        for (const Lifetime& y : lives[b])
          if (x.first_ns <= y.last_ns && y.first_ns <= x.last_ns) return true;
      return false;
    };
    std::size_t refused = 0;  // in the last pass (the one that merged nothing): pairs left apart among the survivors
    for (bool again = true; again;) {
      again = false;
      refused = 0;
      for (std::size_t a = 0; a < ids.size(); ++a) {
        for (std::size_t b = a + 1; b < ids.size() && !gone[a]; ++b) {
          if (gone[b]) continue;
          scene_graph::ObjectAttributes* oa = graph->object(ids[a]);
          scene_graph::ObjectAttributes* ob = graph->object(ids[b]);
          const Box ba = box_of(*oa), bb = box_of(*ob);
          const MergeRule rule = merge_rule(paper_rule, label, ba.lo, ba.hi, bb.lo, bb.hi, true);
          if (rule == MergeRule::kNone) continue;
          if (held_at_once(a, b)) {
            ++refused;
            continue;
          }
          const std::size_t na = size_of(ids[a]), nb = size_of(ids[b]);
          const bool keep_a = na != nb ? na > nb : volume(ba) >= volume(bb);
          const scene_graph::NodeId into = keep_a ? ids[a] : ids[b], from = keep_a ? ids[b] : ids[a];
          scene_graph::ObjectAttributes* keep = keep_a ? oa : ob;
          const scene_graph::ObjectAttributes* drop = keep_a ? ob : oa;
          Eigen::Vector3d lo, hi;
          for (int i = 0; i < 3; ++i) {
            lo[i] = std::min(ba.lo[i], bb.lo[i]);
            hi[i] = std::max(ba.hi[i], bb.hi[i]);
          }
          const std::uint64_t time_ns = std::max(keep->last_update_time_ns, drop->last_update_time_ns);
          const bool active = keep->is_active || drop->is_active;
          const scene_graph::SceneGraph::MergeResult m = graph->merge_into(into, from);
          if (m.status != scene_graph::Status::kOk) continue;
          keep = graph->object(into);
          keep->bounding_box = scene_graph::BoundingBox::aabb(lo, hi);
          keep->position_m = 0.5 * (lo + hi);
          keep->last_update_time_ns = time_ns;
          keep->is_active = active;
          if (indices != nullptr) {
            if (const auto it = indices->find(from); it != indices->end()) {
              // Taken out first: adding `into` to the map may rehash it and invalidate `it`.
              const std::vector<std::uint32_t> taken = std::move(it->second);
              indices->erase(it);
              std::vector<std::uint32_t>& joined = (*indices)[into];
              joined.insert(joined.end(), taken.begin(), taken.end());
              std::sort(joined.begin(), joined.end());
              joined.erase(std::unique(joined.begin(), joined.end()), joined.end());
            }
          }
          out.edges_refused += m.refused;
          ++out.merged;
          const std::size_t kept = keep_a ? a : b, absorbed = keep_a ? b : a;
          lives[kept].insert(lives[kept].end(), lives[absorbed].begin(), lives[absorbed].end());
          lives[absorbed].clear();
          gone[absorbed] = true;
          again = true;
        }
      }
    }
    out.concurrent_refused += refused;
  }
  return out;
}

}  // namespace qsg::objects

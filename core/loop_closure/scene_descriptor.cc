#include "core/loop_closure/scene_descriptor.h"

#include "core/loop_closure/detector_params.h"
#include "core/memory/prefault.h"

#include <algorithm>
#include <cmath>

namespace qsg::loop_closure {

std::string DescriptorConfig::check() const {
  // Each field the app exposes within its declared range (detector_params.cc).
  if (std::string why = params::check(descriptor_params_table(), *this); !why.empty()) return why;
  if (!(max_clearance_m > 0.0 && max_clearance_m <= 20.0)) return "max_clearance_m must be in (0, 20] m";
  if (max_places < 1 || max_places > 65536) return "max_places must be in [1, 65536]";
  return "";
}

void DescriptorConfig::print(std::FILE* out) const {
  std::fprintf(out, "descriptors: places within %.1f m (at most %u), clearance histogram of %d bins to %.1f m, "
               "%d object labels\n", radius_m, max_places, kPlaceBins, max_clearance_m, kObjectBins);
}

float histogram_similarity(const float* a, const float* b, int n) {
  float sa = 0.0f, sb = 0.0f, l1 = 0.0f;
  for (int i = 0; i < n; ++i) {
    sa += a[i];
    sb += b[i];
    l1 += std::abs(a[i] - b[i]);
  }
  if (sa <= 0.0f || sb <= 0.0f) return 0.0f;
  return std::max(0.0f, 1.0f - 0.5f * l1);
}

bool DescriptorBuilder::init(const DescriptorConfig& config, std::string* error) {
  if (const std::string why = config.check(); !why.empty()) return *error = "loop_closure.descriptor: " + why, false;
  config_ = config;
  queue_.reserve(config.max_places);
  seen_.reserve(config.max_places);
  memory::prefault_capacity(&queue_);
  memory::prefault_capacity(&seen_);
  return true;
}

bool DescriptorBuilder::describe(const scene_graph::SceneGraph& graph, scene_graph::NodeId start_place,
                                 const Eigen::Vector3d& center_m, AgentDescriptor* out) {
  *out = AgentDescriptor{};
  if (graph.place(start_place) == nullptr) return false;
  queue_.clear();
  seen_.clear();
  queue_.push_back(start_place);
  seen_.push_back(start_place);
  const double r2 = config_.radius_m * config_.radius_m;
  double point_d2[kMaxDescriptorObjects];
  const auto seen = [&](scene_graph::NodeId id) { return std::find(seen_.begin(), seen_.end(), id) != seen_.end(); };
  for (std::size_t head = 0; head < queue_.size(); ++head) {
    const scene_graph::NodeId id = queue_[head];
    const scene_graph::PlaceAttributes* p = graph.place(id);
    const int bin = std::min(kPlaceBins - 1,
                             static_cast<int>(std::max(0.0, p->distance_m) / config_.max_clearance_m * kPlaceBins));
    out->places[static_cast<std::size_t>(bin)] += 1.0f;
    ++out->num_places;
    graph.for_each_neighbor(id, [&](scene_graph::NodeId other, const scene_graph::EdgeRecord&) {
      const scene_graph::NodeRecord* n = graph.node(other);
      if (n == nullptr) return;
      if (n->kind == scene_graph::NodeKind::kObject && n->parent == id) {
        const scene_graph::ObjectAttributes* o = graph.object(other);
        if (o->semantic_label >= static_cast<std::uint32_t>(kObjectBins)) return;
        out->objects[o->semantic_label] += 1.0f;
        ++out->num_objects;
        // Keep the nearest kMaxDescriptorObjects centroids (replace the farthest kept one).
        const double d2 = (o->position_m - center_m).squaredNorm();
        std::size_t slot = out->num_points;
        if (slot == kMaxDescriptorObjects) {
          slot = static_cast<std::size_t>(std::max_element(point_d2, point_d2 + kMaxDescriptorObjects) - point_d2);
          if (point_d2[slot] <= d2) return;
        } else {
          ++out->num_points;
        }
        out->points[slot] = LabelledPoint{o->position_m, o->semantic_label};
        point_d2[slot] = d2;
        return;
      }
      if (n->kind != scene_graph::NodeKind::kPlace || seen(other)) return;
      if ((graph.place(other)->position_m - center_m).squaredNorm() > r2) return;
      if (queue_.size() == config_.max_places) {
        ++truncated_;
        return;
      }
      queue_.push_back(other);
      seen_.push_back(other);
    });
  }
  for (float& v : out->places) v /= static_cast<float>(out->num_places);
  if (out->num_objects > 0)
    for (float& v : out->objects) v /= static_cast<float>(out->num_objects);
  return true;
}

}  // namespace qsg::loop_closure

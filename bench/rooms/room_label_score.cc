// rooms_eval's room labels against the ground truth (room_label_score.h).
#include "bench/rooms/room_label_score.h"

#include <Eigen/Core>
#include <algorithm>
#include <cstdio>

#include "core/neural_tree/room_classifier.h"
#include "core/semantics/labels.h"
#include "drivers/world/world_query.h"

namespace qsg::bench {

namespace sg = scene_graph;

namespace {

neural_tree::RoomClassifier& shared_classifier() {
  static neural_tree::RoomClassifier classifier;
  static bool tried = false;
  if (!tried) {
    tried = true;
    std::string error;
    if (!classifier.init(&error)) std::fprintf(stderr, "room labels: %s\n", error.c_str());
  }
  return classifier;
}

}  // namespace

// The same classifier on the generator's ground truth (room footprints, object boxes, doors as room-room edges):
// what the labels can reach when rooms and objects are perfect.
void label_truth_rooms(const world::World& w, LabelScore* out) {
  neural_tree::RoomClassifier& classifier = shared_classifier();
  if (!classifier.ready()) return;
  neural_tree::ObjectRoomGraph input;
  std::map<std::int32_t, int> node_of_room;
  for (const world::Room& room : w.rooms) {
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e9), hi = -lo;
    for (const world::Polygon2& poly : room.footprint_m)
      for (const Eigen::Vector2d& v : poly) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
    const Eigen::Vector2d c = 0.5 * (lo + hi);
    node_of_room[room.id] = input.add_room(Eigen::Vector3d(c.x(), c.y(), room.floor_z_m + 0.5 * room.height_m),
                                           Eigen::Vector3d(hi.x() - lo.x(), hi.y() - lo.y(), room.height_m));
  }
  for (const world::Object& o : w.objects) {
    const auto room = node_of_room.find(o.room_id);
    if (room == node_of_room.end()) continue;
    const Eigen::Vector3d extent = o.box.world_R_box.toRotationMatrix().cwiseAbs() * (2.0 * o.box.half_extents_m);
    input.add_object(room->second, classifier.word_index(o.label, extent), o.box.center_m, extent);
  }
  for (const world::Door& d : w.doors) {
    const auto a = node_of_room.find(d.room_a), b = node_of_room.find(d.room_b);
    if (a != node_of_room.end() && b != node_of_room.end()) input.add_edge(a->second, b->second);
  }
  std::string error;
  if (!classifier.classify(input, &error)) return;
  for (const neural_tree::RoomPrediction& p : classifier.predictions())
    for (const world::Room& room : w.rooms)
      if (node_of_room[room.id] == p.node) {
        const std::string want = semantics::room_label_name(room.label);
        ++out->truth_rooms;
        out->truth_correct += p.label == room.label ? 1 : 0;
        out->truth_unknown += p.label == semantics::kRoomUnknown ? 1 : 0;
        auto& per_type = out->truth_per_type[want];
        ++per_type.second;
        per_type.first += p.label == room.label ? 1 : 0;
        if (p.label != room.label) ++out->truth_confusions[want + " -> " + semantics::room_label_name(p.label)];
      }
}

bool label_rooms(const world::World& w, const sg::SceneGraph& g, LabelScore* out) {
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kObject || n.parent == sg::kNoNode || g.place(n.parent) == nullptr) return;
    const Eigen::Vector3d& o = g.object(n.id)->position_m;
    const Eigen::Vector3d& p = g.place(n.parent)->position_m;
    const std::int32_t t = world::room_at(w, o.x(), o.y(), o.z());
    if (t < 0) return;
    ++out->objects;
    out->objects_in_own_room += world::room_at(w, p.x(), p.y(), p.z()) == t ? 1 : 0;
  });
  neural_tree::RoomClassifier& classifier = shared_classifier();
  std::string error;
  if (!classifier.ready()) return false;
  neural_tree::ObjectRoomGraph input;
  std::map<sg::NodeId, int> node_of_room;
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kRoom) return;
    const sg::RoomAttributes* a = g.room(n.id);
    const bool box = a->bounding_box.type != sg::BoundingBox::Type::kInvalid;
    node_of_room[n.id] = input.add_room(
        a->position_m, box ? Eigen::Vector3d(a->bounding_box.max_m - a->bounding_box.min_m) : Eigen::Vector3d::Zero());
  });
  g.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kObject || n.parent == sg::kNoNode) return;
    const auto room = node_of_room.find(g.parent(n.parent));
    if (room == node_of_room.end()) return;
    const sg::ObjectAttributes* o = g.object(n.id);
    const Eigen::Vector3d size = o->bounding_box.max_m - o->bounding_box.min_m;
    input.add_object(room->second, classifier.word_index(static_cast<semantics::Label>(o->semantic_label), size),
                     o->position_m, size);
  });
  g.for_each_edge([&](const sg::EdgeRecord& e) {
    const auto a = node_of_room.find(e.source), b = node_of_room.find(e.target);
    if (a != node_of_room.end() && b != node_of_room.end()) input.add_edge(a->second, b->second);
  });
  if (!classifier.classify(input, &error)) {
    std::fprintf(stderr, "room labels: %s\n", error.c_str());
    return false;
  }
  std::map<int, semantics::RoomLabel> predicted;
  for (const neural_tree::RoomPrediction& p : classifier.predictions()) predicted[p.node] = p.label;
  std::map<std::int32_t, semantics::RoomLabel> truth_label;
  for (const world::Room& room : w.rooms) truth_label[room.id] = room.label;
  for (const auto& [room_id, node] : node_of_room) {
    std::map<std::int32_t, int> votes;
    g.for_each_child(room_id, [&](sg::NodeId child) {
      if (sg::node_prefix(child) != sg::kPlacePrefix) return;
      const Eigen::Vector3d& p = g.place(child)->position_m;
      const std::int32_t t = world::room_at(w, p.x(), p.y(), p.z());
      if (t >= 0) ++votes[t];
    });
    if (votes.empty()) continue;
    const std::int32_t truth = std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
                                 return a.second < b.second;
                               })->first;
    const semantics::RoomLabel want = truth_label[truth], got = predicted[node];
    ++out->rooms;
    out->correct += got == want ? 1 : 0;
    out->unknown += got == semantics::kRoomUnknown ? 1 : 0;
    if (got != want)
      ++out->confusions[std::string(semantics::room_label_name(want)) + " -> " + semantics::room_label_name(got)];
  }
  return true;
}

}  // namespace qsg::bench

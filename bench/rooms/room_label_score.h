// rooms_eval's room labels: the room classifier on the explored graph's rooms and on the generator's own rooms and
// objects, each room scored against the ground truth.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <utility>

#include "core/scene_graph/scene_graph.h"
#include "drivers/world/world.h"

namespace qsg::bench {

// Room labels on a generated building (whose rooms have known types): the room classifier (the neural tree blended
// with its LR head) labels the graph's rooms as the app does (objects in the room of the place they hang from,
// room-room edges), and each estimated room is scored against the ground-truth room that holds most of its places.
struct LabelScore {
  std::size_t rooms = 0, correct = 0, unknown = 0;
  std::map<std::string, std::size_t> confusions;  // "truth -> predicted"
  std::size_t truth_rooms = 0, truth_correct = 0;  // the classifier on the world's own rooms and objects
  std::size_t truth_unknown = 0;  // rooms the classifier left "unknown" (no objects, or below min_probability)
  std::map<std::string, std::size_t> truth_confusions;
  std::map<std::string, std::pair<std::size_t, std::size_t>> truth_per_type;  // type -> (correct, rooms)
  // Objects inside a ground-truth room with a parent place, and those whose parent place is in the same room
  // (the room the classifier then sees the object in follows that place).
  std::size_t objects = 0, objects_in_own_room = 0;
};

// The same classifier on the generator's ground truth (room footprints, object boxes, doors as room-room edges):
// what the labels can reach when rooms and objects are perfect.
void label_truth_rooms(const world::World& w, LabelScore* out);
// The classifier on the graph's rooms, each scored against the ground-truth room holding most of its places.
bool label_rooms(const world::World& w, const scene_graph::SceneGraph& g, LabelScore* out);

}  // namespace qsg::bench

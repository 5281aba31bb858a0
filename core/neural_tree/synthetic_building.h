// A deterministic synthetic object-room-building graph (rooms in corridors of five, objects near each other
// linked), the frozen input of the neural-tree tests and benchmark.
#pragma once

#include <cstdint>

#include "core/neural_tree/room_classifier.h"

namespace qsg::neural_tree {

// Fills `out` with one building, `rooms` rooms and `objects_per_room` objects per room. Objects carry mpcat40
// labels looked up in `classifier` (word -1 when it has no weights). Same seed, same graph.
inline void make_synthetic_building(int rooms, int objects_per_room, std::uint32_t seed,
                                    const RoomClassifier& classifier, ObjectRoomGraph* out) {
  static constexpr semantics::Label kLabels[] = {
      semantics::kChair,   semantics::kTable,    semantics::kBed,    semantics::kSofa,   semantics::kToilet,
      semantics::kSink,    semantics::kPlant,    semantics::kTvMonitor, semantics::kCabinet, semantics::kShelving,
      semantics::kLighting, semantics::kBathtub, semantics::kStool,  semantics::kTowel,  semantics::kCushion};
  std::uint32_t state = seed * 2654435761u + 12345u;
  auto uniform = [&state]() {  // xorshift32 in [0, 1)
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return static_cast<double>(state >> 8) / static_cast<double>(1u << 24);
  };
  out->clear();
  const int per_row = 5;
  const double room_m = 4.0;
  const int building = out->add_building({0.5 * room_m * per_row, 0.5 * room_m * (rooms / per_row), 1.25});
  (void)building;
  int first_room = static_cast<int>(out->nodes.size());
  for (int r = 0; r < rooms; ++r) {
    const Eigen::Vector3d c(room_m * (r % per_row), room_m * (r / per_row), 1.25);
    out->add_room(c, {room_m - 0.2 - uniform(), room_m - 0.2 - uniform(), 2.5});
  }
  // Rooms of a row form a corridor; rows meet at their first room, and every other row closes a loop.
  for (int r = 0; r < rooms; ++r) {
    if (r % per_row != 0) out->add_edge(first_room + r - 1, first_room + r);
    if (r >= per_row && r % per_row == 0) out->add_edge(first_room + r - per_row, first_room + r);
    if (r >= per_row && r % per_row == 1 && (r / per_row) % 2 == 0)
      out->add_edge(first_room + r - per_row, first_room + r);
  }
  for (int r = 0; r < rooms; ++r) {
    const int room = first_room + r;
    const int first_object = static_cast<int>(out->nodes.size());
    for (int k = 0; k < objects_per_room; ++k) {
      const semantics::Label label = kLabels[static_cast<int>(uniform() * 15) % 15];
      const Eigen::Vector3d c = out->nodes[room].centroid_m +
                                Eigen::Vector3d((uniform() - 0.5) * 3.5, (uniform() - 0.5) * 3.5, uniform() - 0.5);
      out->add_object(room, classifier.word_index(label), c,
                      {0.2 + uniform(), 0.2 + uniform(), 0.2 + 0.8 * uniform()});
    }
    // Objects closer than 1.2 m are linked (the frontend's proximity edges).
    for (int a = first_object; a < first_object + objects_per_room; ++a)
      for (int b = a + 1; b < first_object + objects_per_room; ++b)
        if ((out->nodes[a].centroid_m - out->nodes[b].centroid_m).norm() < 1.2) out->add_edge(a, b);
  }
}

}  // namespace qsg::neural_tree

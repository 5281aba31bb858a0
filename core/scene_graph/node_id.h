// Node identifiers and layer keys compatible with Spark-DSG: a character prefix in the top byte of a 64-bit id.
#pragma once

#include <cstdint>
#include <string>

namespace qsg::scene_graph {

using NodeId = std::uint64_t;
inline constexpr NodeId kNoNode = ~NodeId{0};

// Spark-DSG's layer numbering (DsgLayers). Agents share layer 2 with objects, in a per-robot partition.
enum class Layer : std::uint8_t {
  kMesh = 1,
  kObjects = 2,
  kAgents = 2,
  kPlaces = 3,
  kRooms = 4,
  kBuildings = 5,
};
inline constexpr std::uint8_t kMinLayer = 2;
inline constexpr std::uint8_t kMaxLayer = 5;

// Static layers have partition 0; an agent's dynamic layer is partitioned by its robot prefix ('a', 'b', ...).
struct LayerKey {
  std::uint8_t layer = 0;
  char partition = 0;
  friend bool operator==(const LayerKey& a, const LayerKey& b) {
    return a.layer == b.layer && a.partition == b.partition;
  }
  bool is_parent_of(const LayerKey& other) const { return layer == other.layer + 1; }
};

// Prefixes the reference system uses for each layer.
inline constexpr char kObjectPrefix = 'O';
inline constexpr char kPlacePrefix = 'p';
inline constexpr char kRoomPrefix = 'R';
inline constexpr char kBuildingPrefix = 'B';
inline constexpr char kDefaultAgentPrefix = 'a';

inline constexpr std::uint64_t kIndexMask = (std::uint64_t{1} << 56) - 1;

constexpr NodeId make_node_id(char prefix, std::uint64_t index) {
  return (static_cast<std::uint64_t>(static_cast<unsigned char>(prefix)) << 56) | (index & kIndexMask);
}
constexpr char node_prefix(NodeId id) { return static_cast<char>(id >> 56); }
constexpr std::uint64_t node_index(NodeId id) { return id & kIndexMask; }

// "p(12)", "O(3)", or the raw number when the prefix is not printable.
std::string node_label(NodeId id);

}  // namespace qsg::scene_graph

// Visibility merge (our refinement, not the paper's), last, when the update is given whole-map sight lines (the
// final door stage's; during a run the online window's are not used: the merge lowered precision there): two
// adjacent rooms (any place edge between them, open or closed) whose places see each other past every structural
// wall are one room that furniture or a false door cut in two. Up to samples places of each room (spread evenly
// over its places in id order) are paired with as many of the other's; the pair merges when at least min_share of
// those sight lines are clear. Pairs merge clearest first, each room once a round, for at most max_rounds rounds
// (rooms and their samples taken again each round). A door between two rooms is in a wall, so few of their sight
// lines are clear.
//
// Near the boundary: when the whole rooms' sight lines fall short (an L-shaped room, a bend, a cabinet row that
// joins a wall and hides one end from the other), each room's places within local_radius_m (in plan) of the other
// room's ends of the place edges between them are sampled as above; at least local_min_places on each side, and at
// least local_min_share of those lines clear. Such pairs merge after the pairs that qualify as whole rooms. 0: off.
//
// Touching spheres: rooms are adjacent also where the free-space spheres of a place of each touch (the distance
// between them below the sum of their clearances, each at most touch_max_clearance_m) and the two see each other,
// with no place edge between them: the places graph follows the free space's skeleton, so two pieces of one room on
// either side of a desk, or round a cabinet, can share open floor with no edge. Such pairs are found once per
// update (at most as many as places; more are counted) and count as the boundary's ends for the test near it too.
// What each part earned: core/rooms/README.md.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/memory/arena.h"
#include "core/rooms/door_cues.h"
#include "core/rooms/partition.h"

namespace qsg::rooms::refine {

struct VisibilityMergeConfig {
  static constexpr std::uint32_t kMaxSamples = 32;
  double min_share = 0.8;              // rooms::Config::visible_min_share
  std::uint32_t samples = 12;          // visible_samples, at most kMaxSamples
  std::uint32_t max_rounds = 32;       // visible_max_rounds
  double local_radius_m = 2.25;        // visible_local_radius_m (0: off)
  double local_min_share = 0.8;        // visible_local_min_share
  std::uint32_t local_min_places = 3;  // visible_local_min_places
  bool touching = true;                // visible_touching
  double touch_max_clearance_m = 4.0;  // visible_touch_max_clearance_m
};

struct VisibilityMergeStats {
  std::size_t merges = 0;            // rooms merged into an adjacent room they see
  std::size_t pairs = 0;             // adjacent room pairs whose sight lines were tested (all rounds)
  std::size_t near_merges = 0;       // of merges, those by the lines near the boundary
  std::size_t touching_pairs = 0;    // place pairs in two rooms, touching and in sight
  std::size_t touching_dropped = 0;  // ... beyond the room for them; 1 when the map was too large in cells
};

class VisibilityMerge {
 public:
  static void plan(memory::ArenaPlan* p, std::size_t places, std::size_t rooms);
  bool carve(memory::Arena& arena, std::size_t places, std::size_t rooms);
  Partition run(const VisibilityMergeConfig& config, const PlacesGraph& places, const SightLines& sight,
                Partition rooms, Workspace* ws, VisibilityMergeStats* stats);

 private:
  // One round's candidate pairs in ws->pairs (room pair key | priority), clearest first; returns their number.
  std::size_t candidates(const VisibilityMergeConfig& config, const PlacesGraph& places, const SightLines& sight,
                         const Partition& rooms, Workspace* ws, VisibilityMergeStats* stats);
  void take_samples(const VisibilityMergeConfig& config, const PlacesGraph& places, const Partition& rooms,
                    Workspace* ws);
  // The test near the boundary of rooms a and b: the share of clear sight lines (0..share_scale), or 0 with too
  // few places near it.
  std::uint64_t near_boundary_share(const VisibilityMergeConfig& config, const PlacesGraph& places,
                                    const SightLines& sight, const std::int32_t* room_of, std::uint32_t a,
                                    std::uint32_t b, std::uint64_t share_scale);
  // Pairs of places in different rooms whose spheres touch and that see each other (touching_pairs_).
  void find_touching_pairs(const VisibilityMergeConfig& config, const PlacesGraph& places, const SightLines& sight,
                           const std::int32_t* room_of, Workspace* ws, VisibilityMergeStats* stats);

  std::size_t places_capacity_ = 0;
  std::uint32_t* sight_samples_ = nullptr;  // per room slot, kMaxSamples place indices
  std::uint32_t* room_count_ = nullptr;     // per room slot: its places; then samples; then merged this round
  std::uint32_t* near_list_ = nullptr;      // 2 x places: a pair's boundary ends, then near places
  std::uint8_t* near_mark_ = nullptr;       // per place: a boundary end already listed
  std::uint64_t* touching_pairs_ = nullptr;  // (a << 32) | b place indices, a < b
  std::size_t num_touching_pairs_ = 0;
};

}  // namespace qsg::rooms::refine

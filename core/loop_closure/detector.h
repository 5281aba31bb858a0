// Top-down loop-closure detection and bottom-up verification over agent descriptors (the paper's section
// "Loop Closure Detection and Geometric Verification"):
//   places: a range search for past agents whose places descriptor is similar enough (a vantage-point tree over the
//           L1 distance, a metric: sublinear in the number of agents; rebuilt in batches, the newest batch scanned);
//   objects: the candidates' objects descriptors, best first, above a threshold, with a ratio test against the best
//            candidate elsewhere (perceptual aliasing);
//   verification, bottom-up: the appearance of the two agents' keyframes (appearance.h: ORB matches and RANSAC
//                 on their 3D points) for the best max_appearance_checks candidates, precise where it succeeds; else
//                 object-based registration (object_registration.h) of the best max_verifications, one per
//                 stretch of the trajectory (distinct_verification_m); the first candidate that registers gives
//                 the loop closure.
// Candidates must be at least min_time_separation_s and min_path_separation_m (along the trajectory) older than
// the query. Capacity is fixed at init; when full, every second agent of the older half is dropped (folds, counted).
// Backend thread only; nothing allocates after init.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/loop_closure/appearance.h"
#include "core/loop_closure/depth_cloud.h"
#include "core/loop_closure/local_map.h"
#include "core/loop_closure/object_registration.h"
#include "core/loop_closure/scene_descriptor.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/node_id.h"

namespace qsg::loop_closure {

struct DetectorConfig {
  double places_threshold = 0.6;       // places similarity a candidate must reach
  double objects_threshold = 0.5;      // objects similarity a candidate must reach to be verified
  std::uint32_t min_objects = 4;       // objects a descriptor needs to take part (fewer cannot register)
  double min_time_separation_s = 30.0;
  double min_path_separation_m = 8.0;
  // Ratio test: the best candidate's objects similarity must exceed `ratio` times the best candidate's at least
  // ratio_distance_m away from it (odometric positions), else the place is ambiguous and nothing is proposed.
  // 1 disables it.
  double ratio = 0.95;
  double ratio_distance_m = 4.0;
  std::uint32_t max_verifications = 3;  // candidates registered by their objects per query at most, best first
  // A verification covers a stretch of the trajectory, not one agent: ICP tries the match's neighbours and the
  // local maps its path. A candidate within this much path of one already verified for the query is skipped
  // (counted), so the max_verifications go to distinct places. 0: by rank only.
  double distinct_verification_m = 3.0;
  std::uint32_t max_appearance_checks = 8;  // candidates registered by appearance first (agents with features)
  std::uint32_t rebuild_batch = 64;     // agents scanned linearly before the tree is rebuilt over them
  RegistrationConfig registration;
  AppearanceConfig appearance;
  IcpConfig icp;  // refinement of object registrations on the two keyframes' depth
  // An object registration that ICP could not refine aligns centroids of partial views (about 0.1 m and a degree or
  // two off): false keeps it out of the graph (counted as objects_unrefined), true proposes it with a loose sigma.
  // Off because such closures made the map worse than the odometry on generated buildings at the VIO level, and no
  // better at the sim level (bench/results/loop_closure.md, "Coarse object closures").
  bool propose_unrefined_objects = false;
  double icp_neighbour_m = 3.0;  // ... also against the match's neighbours (in the database) this close to it
  // Where neither keyframe ICP refines an object registration: the two agents' local maps (local_map.h).
  LocalMapConfig local_map;

  std::string check() const;
  void print(std::FILE* out) const;
};

// One described agent: its pose as mapped and as the odometry gave it, time, distance travelled to it, descriptor.
struct AgentEntry {
  scene_graph::NodeId agent = scene_graph::kNoNode;
  std::uint64_t time_ns = 0;
  double path_m = 0.0;
  // As mapped: the frame of the graph's objects and places (the odometry's, or the frontend's corrected frame,
  // backend::LoopClosureConfig::map_in_corrected_frame); object registration and the closure's stored poses use it.
  Eigen::Isometry3d world_T_agent = Eigen::Isometry3d::Identity();
  // The frontend's frame correction world_T_agent includes (frame_corrected; identity otherwise).
  Eigen::Isometry3d map_T_odom = Eigen::Isometry3d::Identity();
  bool frame_corrected = false;
  // As the odometry gave it: keyframes are stitched (local maps, ICP neighbours) and gravity read by it, so that a
  // change of the frontend's frame between two keyframes is not taken for motion.
  Eigen::Isometry3d odom_T_agent() const {
    return frame_corrected ? map_T_odom.inverse() * world_T_agent : world_T_agent;
  }
  AgentDescriptor descriptor;
  AppearanceFeatures appearance;  // count 0: none (verification by objects only)
  DepthCloud cloud;               // count 0: none (no ICP refinement)
};

enum class ClosureSource : std::uint8_t { kAppearance, kObjects };
const char* to_string(ClosureSource s);

struct LoopClosure {
  scene_graph::NodeId match = scene_graph::kNoNode;  // the older agent
  scene_graph::NodeId query = scene_graph::kNoNode;
  std::uint64_t match_time_ns = 0;
  std::uint64_t query_time_ns = 0;
  Eigen::Isometry3d match_T_query = Eigen::Isometry3d::Identity();  // the measured relative pose
  // The two agents' odometric poses when the closure was found: the agent chain may fold either away later, and
  // the closure then joins the nearest chain nodes through the odometry between them (exact, odometric frame).
  Eigen::Isometry3d world_T_match = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d world_T_query = Eigen::Isometry3d::Identity();
  float places_similarity = 0.0f;
  float objects_similarity = 0.0f;
  ClosureSource source = ClosureSource::kObjects;
  Registration registration;            // kObjects
  AppearanceRegistration appearance;    // kAppearance
  bool refined = false;                 // the estimate refined by ICP on the keyframes' depth (either source)
  bool local_map = false;               // ... on the two agents' local maps (local_map.h) rather than one keyframe each
  IcpResult icp;
};

struct DetectorCounters {
  std::uint64_t queries = 0;
  std::uint64_t queries_without_objects = 0;  // descriptor below min_objects: no detection
  std::uint64_t places_candidates = 0;        // past agents within the places threshold (and separation)
  std::uint64_t objects_candidates = 0;       // ... also within the objects threshold
  std::uint64_t ratio_rejections = 0;
  std::uint64_t appearance_checks = 0;
  std::uint64_t appearance_accepted = 0;
  std::uint64_t verifications = 0;        // by objects
  std::uint64_t verifications_skipped = 0;  // candidates within distinct_verification_m of path of one verified
  std::uint64_t registration_failures = 0;
  std::uint64_t icp_refined = 0;          // registrations (appearance or objects) refined by ICP
  std::uint64_t icp_refused = 0;          // ... where ICP was tried and not trusted (coarse estimate kept)
  std::uint64_t local_map_refined = 0;    // object registrations keyframe ICP could not refine, refined on local maps
  std::uint64_t local_map_refused = 0;    // ... tried on local maps and not trusted, of which (IcpRefusal):
  std::uint64_t local_map_no_overlap = 0;  // ... too little overlap
  std::uint64_t local_map_degenerate = 0;  // ... a direction left free
  std::uint64_t local_map_correction = 0;  // ... too large a correction
  std::uint64_t objects_unrefined = 0;    // object registrations not refined, not proposed (propose_unrefined_objects)
  std::uint64_t proposed = 0;                 // verified loop closures handed to the optimizer
  std::uint64_t refused = 0;                  // agents not stored (a database of fewer than 4)
  std::uint64_t folds = 0;                    // full: every second agent of the older half dropped
  std::uint64_t tree_rebuilds = 0;
  void print(std::FILE* out) const;
};

class LoopClosureDetector {
 public:
  // capacity: agents kept; local_map: the local-map pass's buffers (both from the budget table).
  bool init(std::size_t capacity, const LocalMapCapacities& local_map, const DetectorConfig& config,
            std::string* error);
  // Looks for a verified match of `query` among the stored agents, then stores it. True with `out` filled when a
  // loop closure is proposed.
  bool add_and_detect(const AgentEntry& query, LoopClosure* out);
  std::size_t size() const { return entries_.size(); }
  const AgentEntry& entry(std::size_t i) const { return entries_[i]; }
  const DetectorCounters& counters() const { return counters_; }
  const DetectorConfig& config() const { return config_; }
  memory::ResourceStats stats() const;
  std::size_t bytes() const {
    return entries_.capacity() * sizeof(AgentEntry) + order_.capacity() * 12 + local_map_.bytes();
  }

 private:
  struct Candidate {
    std::uint32_t entry;
    float places;
    float objects;
  };
  float places_distance(std::uint32_t entry, const AgentDescriptor& d) const;
  void rebuild();
  void fold();
  static constexpr std::uint32_t kIcpNeighbours = 4;
  const AgentEntry* refine_with_neighbours(const AgentEntry& query, std::uint32_t match_entry, LoopClosure* out);
  bool refine_with_local_maps(const AgentEntry& query, std::uint32_t match_entry, LoopClosure* out);
  void build(std::uint32_t lo, std::uint32_t hi);
  void search(std::uint32_t lo, std::uint32_t hi, const AgentDescriptor& d, float radius, const AgentEntry& query);
  void consider(std::uint32_t entry, const AgentEntry& query);

  DetectorConfig config_;
  ObjectRegistration registration_;
  LocalMapVerifier local_map_;
  std::vector<AgentEntry> entries_;
  std::vector<std::uint32_t> order_;  // the vantage-point tree: entries in tree order over [0, indexed_)
  std::vector<float> mu_;             // per tree position: the split radius of the node rooted there
  std::vector<float> scratch_;
  std::uint32_t indexed_ = 0;
  std::vector<Candidate> candidates_;
  DetectorCounters counters_;
  std::uint64_t high_water_ = 0;
};

}  // namespace qsg::loop_closure

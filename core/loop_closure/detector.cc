#include "core/loop_closure/detector.h"

#include "core/loop_closure/detector_params.h"
#include "core/memory/prefault.h"

#include <algorithm>
#include <cmath>

namespace qsg::loop_closure {

std::string DetectorConfig::check() const {
  // Each field the app exposes within its declared range (detector_params.cc; then the fields without a table).
  if (std::string why = params::check(detector_params_table(), *this); !why.empty()) return why;
  if (min_objects > kMaxDescriptorObjects) return "min_objects must be at most 32";
  if (!(ratio_distance_m >= 0.0 && ratio_distance_m <= 1000.0)) return "ratio_distance_m must be in [0, 1000] m";
  if (max_verifications < 1 || max_verifications > 64) return "max_verifications must be in [1, 64]";
  if (rebuild_batch < 1 || rebuild_batch > 100000) return "rebuild_batch must be in [1, 100000]";
  if (max_appearance_checks > 64) return "max_appearance_checks must be in [0, 64]";
  if (const std::string why = appearance.check(); !why.empty()) return "appearance." + why;
  if (const std::string why = icp.check(); !why.empty()) return "icp." + why;
  if (const std::string why = registration.check(); !why.empty()) return "registration." + why;
  if (const std::string why = local_map.check(); !why.empty()) return "local_map." + why;
  return "";
}

void DetectorConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "loop-closure detection: places >= %.2f, objects >= %.2f (>= %u objects), separation >= %.0f s and "
               "%.1f m of path, ratio test %.2f beyond %.1f m, <= %u verifications per query\n",
               places_threshold, objects_threshold, min_objects, min_time_separation_s, min_path_separation_m, ratio,
               ratio_distance_m, max_verifications);
  registration.print(out);
  appearance.print(out);
  icp.print(out);
  local_map.print(out);
}

const char* to_string(ClosureSource s) { return s == ClosureSource::kAppearance ? "appearance" : "objects"; }

void DetectorCounters::print(std::FILE* out) const {
  std::fprintf(
      out,
      "loop closures: %llu queries (%llu without enough objects), %llu places candidates, %llu objects "
      "candidates, %llu ratio rejections, %llu appearance checks of which %llu registered, %llu verified by "
      "objects (%llu skipped as near one verified) of which %llu failed registration (%llu refined by ICP, %llu not, "
      "%llu then on local maps, %llu "
      "refused there (%llu no overlap, %llu degenerate, %llu too large a correction), %llu dropped), "
      "%llu proposed; "
      "%llu agents refused, %llu folds, %llu tree rebuilds\n",
      static_cast<unsigned long long>(queries), static_cast<unsigned long long>(queries_without_objects),
      static_cast<unsigned long long>(places_candidates), static_cast<unsigned long long>(objects_candidates),
      static_cast<unsigned long long>(ratio_rejections), static_cast<unsigned long long>(appearance_checks),
      static_cast<unsigned long long>(appearance_accepted), static_cast<unsigned long long>(verifications),
      static_cast<unsigned long long>(verifications_skipped), static_cast<unsigned long long>(registration_failures),
      static_cast<unsigned long long>(icp_refined), static_cast<unsigned long long>(icp_refused),
      static_cast<unsigned long long>(local_map_refined), static_cast<unsigned long long>(local_map_refused),
      static_cast<unsigned long long>(local_map_no_overlap), static_cast<unsigned long long>(local_map_degenerate),
      static_cast<unsigned long long>(local_map_correction), static_cast<unsigned long long>(objects_unrefined),
      static_cast<unsigned long long>(proposed), static_cast<unsigned long long>(refused),
      static_cast<unsigned long long>(folds), static_cast<unsigned long long>(tree_rebuilds));
}

bool LoopClosureDetector::init(std::size_t capacity, const LocalMapCapacities& local_map, const DetectorConfig& config,
                               std::string* error) {
  if (const std::string why = config.check(); !why.empty()) return *error = "loop_closure.detector: " + why, false;
  if (capacity == 0) return *error = "loop_closure.detector: capacity must be at least 1", false;
  config_ = config;
  registration_ = ObjectRegistration(config.registration);
  if (!local_map_.init(config.local_map, local_map, error)) return *error = "loop_closure.detector." + *error, false;
  entries_.clear();
  entries_.reserve(capacity);
  order_.assign(capacity, 0);
  mu_.assign(capacity, 0.0f);
  scratch_.assign(capacity, 0.0f);
  candidates_.reserve(capacity);
  memory::prefault_capacity(&entries_);
  memory::prefault_capacity(&candidates_);
  indexed_ = 0;
  counters_ = {};
  return true;
}

memory::ResourceStats LoopClosureDetector::stats() const {
  memory::ResourceStats s;
  s.name = "loop_closure.agents";
  s.unit = "agents";
  s.capacity = entries_.capacity();
  s.in_use = entries_.size();
  s.high_water = static_cast<std::size_t>(high_water_);
  s.failed = counters_.refused;
  return s;
}

float LoopClosureDetector::places_distance(std::uint32_t entry, const AgentDescriptor& d) const {
  const auto& a = entries_[entry].descriptor.places;
  float l1 = 0.0f;
  for (int i = 0; i < kPlaceBins; ++i) l1 += std::abs(a[static_cast<std::size_t>(i)] - d.places[static_cast<std::size_t>(i)]);
  return l1;
}

// Vantage-point tree over order_[lo, hi): order_[lo] is the vantage point, [lo + 1, mid) lie within mu_[lo] of it,
// [mid, hi) beyond. Median split, so the depth is log2(n).
void LoopClosureDetector::build(std::uint32_t lo, std::uint32_t hi) {
  if (hi - lo <= 1) return;
  const AgentDescriptor& v = entries_[order_[lo]].descriptor;
  for (std::uint32_t i = lo + 1; i < hi; ++i) scratch_[order_[i]] = places_distance(order_[i], v);
  const std::uint32_t mid = lo + 1 + (hi - lo - 1) / 2;
  std::nth_element(order_.begin() + lo + 1, order_.begin() + mid, order_.begin() + hi,
                   [&](std::uint32_t a, std::uint32_t b) { return scratch_[a] < scratch_[b]; });
  mu_[lo] = scratch_[order_[mid]];
  build(lo + 1, mid);
  build(mid, hi);
}

void LoopClosureDetector::rebuild() {
  indexed_ = static_cast<std::uint32_t>(entries_.size());
  for (std::uint32_t i = 0; i < indexed_; ++i) order_[i] = i;
  build(0, indexed_);
  ++counters_.tree_rebuilds;
}

// Full: every second agent of the older half goes (the chain's own folding policy), so a long mission keeps the
// whole trajectory at a coarser spacing instead of forgetting its start or refusing its present.
void LoopClosureDetector::fold() {
  const std::size_t half = entries_.size() / 2;
  std::size_t out = 0;
  for (std::size_t i = 0; i < entries_.size(); ++i)
    if (i >= half || i % 2 == 0) entries_[out++] = entries_[i];
  entries_.resize(out);
  ++counters_.folds;
  rebuild();
}

void LoopClosureDetector::consider(std::uint32_t entry, const AgentEntry& query) {
  const AgentEntry& e = entries_[entry];
  if (e.time_ns + static_cast<std::uint64_t>(config_.min_time_separation_s * 1e9) > query.time_ns) return;
  if (e.path_m + config_.min_path_separation_m > query.path_m) return;
  const float places = histogram_similarity(e.descriptor.places.data(), query.descriptor.places.data(), kPlaceBins);
  if (places < config_.places_threshold) return;
  ++counters_.places_candidates;
  if (e.descriptor.num_points < config_.min_objects) return;
  const float objects = histogram_similarity(e.descriptor.objects.data(), query.descriptor.objects.data(), kObjectBins);
  candidates_.push_back(Candidate{entry, places, objects});
}

void LoopClosureDetector::search(std::uint32_t lo, std::uint32_t hi, const AgentDescriptor& d, float radius,
                                 const AgentEntry& query) {
  if (lo >= hi) return;
  const float dist = places_distance(order_[lo], d);
  if (dist <= radius) consider(order_[lo], query);
  if (hi - lo == 1) return;
  const std::uint32_t mid = lo + 1 + (hi - lo - 1) / 2;
  if (dist - radius <= mu_[lo]) search(lo + 1, mid, d, radius, query);  // the ball reaches inside
  if (dist + radius >= mu_[lo]) search(mid, hi, d, radius, query);      // ... and outside
}

// The ICP refinement of an object registration: the match's keyframe may look elsewhere than the query's, so the
// agents described just before and after it (odometry between them is locally exact) are tried too, the ones whose
// optical axis is closest to the query's first. Returns the agent the closure ends up with (the match when nothing
// refines) and updates out->match_T_query, refined and icp.
const AgentEntry* LoopClosureDetector::refine_with_neighbours(const AgentEntry& query, std::uint32_t match_entry,
                                                             LoopClosure* out) {
  const AgentEntry& match = entries_[match_entry];
  // The query's camera in the match's odometric frame, by the coarse estimate.
  const Eigen::Isometry3d odom_T_query = match.odom_T_agent() * out->match_T_query;
  const Eigen::Vector3d axis = odom_T_query.linear().col(2);
  std::uint32_t order[2 * kIcpNeighbours + 1];
  double score[2 * kIcpNeighbours + 1];
  std::uint32_t n = 0;
  const std::uint32_t lo = match_entry >= kIcpNeighbours ? match_entry - kIcpNeighbours : 0;
  const std::uint32_t hi = std::min<std::uint32_t>(static_cast<std::uint32_t>(entries_.size()) - 1,
                                                   match_entry + kIcpNeighbours);
  for (std::uint32_t e = lo; e <= hi; ++e) {
    const AgentEntry& m = entries_[e];
    if (m.cloud.count == 0 || m.time_ns + static_cast<std::uint64_t>(config_.min_time_separation_s * 1e9) > query.time_ns)
      continue;
    if ((m.odom_T_agent().translation() - match.odom_T_agent().translation()).norm() > config_.icp_neighbour_m)
      continue;
    order[n] = e;
    score[n++] = -axis.dot(m.odom_T_agent().linear().col(2));
  }
  // Insertion sort by score (n <= 2 * kIcpNeighbours + 1).
  for (std::uint32_t i = 1; i < n; ++i)
    for (std::uint32_t j = i; j > 0 && score[j] < score[j - 1]; --j) {
      std::swap(score[j], score[j - 1]);
      std::swap(order[j], order[j - 1]);
    }
  for (std::uint32_t i = 0; i < n; ++i) {
    const AgentEntry& m = entries_[order[i]];
    const Eigen::Isometry3d initial = m.odom_T_agent().inverse() * odom_T_query;
    const GravityPrior gravity = GravityPrior::from_poses(m.odom_T_agent(), query.odom_T_agent());
    const IcpResult r = refine_icp(query.cloud, m.cloud, initial, config_.icp, &gravity);
    if (!r.ok) continue;
    out->icp = r;
    out->match_T_query = r.match_T_query;
    out->refined = true;
    ++counters_.icp_refined;
    return &m;
  }
  ++counters_.icp_refused;
  return &match;
}

// The local-map pass (local_map.h) on an object registration keyframe ICP could not refine: the query's keyframe
// with those of the agents stored just behind it, against the match's with its neighbours both ways (those old
// enough), each within local_map.path_m of path. Updates out as refine_with_neighbours does.
bool LoopClosureDetector::refine_with_local_maps(const AgentEntry& query, std::uint32_t match_entry, LoopClosure* out) {
  const double path = config_.local_map.path_m;
  const std::uint32_t max_keyframes = local_map_.capacities().keyframes;
  const auto separation_ns = static_cast<std::uint64_t>(config_.min_time_separation_s * 1e9);
  local_map_.begin(query.odom_T_agent());
  std::uint32_t keyframes = local_map_.add(query.cloud, query.odom_T_agent()) ? 1 : 0;
  for (std::size_t i = entries_.size(); i-- > 0 && keyframes < max_keyframes;) {
    const AgentEntry& e = entries_[i];
    if (query.path_m - e.path_m > path) break;
    if (e.cloud.count > 0 && local_map_.add(e.cloud, e.odom_T_agent())) ++keyframes;
  }
  local_map_.finish(&local_map_.query_cloud());
  const AgentEntry& match = entries_[match_entry];
  local_map_.begin(match.odom_T_agent());
  keyframes = match.cloud.count > 0 && local_map_.add(match.cloud, match.odom_T_agent()) ? 1 : 0;
  // Outwards from the match, alternately behind and ahead, so a full buffer keeps the nearest.
  std::size_t back = match_entry, ahead = match_entry + 1;
  bool more_back = true, more_ahead = true;
  while ((more_back || more_ahead) && keyframes < max_keyframes) {
    if (more_back) {
      more_back = back > 0 && match.path_m - entries_[back - 1].path_m <= path;
      if (more_back) {
        const AgentEntry& e = entries_[--back];
        if (e.cloud.count > 0 && local_map_.add(e.cloud, e.odom_T_agent())) ++keyframes;
      }
    }
    if (more_ahead && keyframes < max_keyframes) {
      more_ahead = ahead < entries_.size() && entries_[ahead].path_m - match.path_m <= path &&
                   entries_[ahead].time_ns + separation_ns <= query.time_ns;
      if (more_ahead) {
        const AgentEntry& e = entries_[ahead++];
        if (e.cloud.count > 0 && local_map_.add(e.cloud, e.odom_T_agent())) ++keyframes;
      }
    }
  }
  local_map_.finish(&local_map_.match_cloud());
  const GravityPrior gravity = GravityPrior::from_poses(match.odom_T_agent(), query.odom_T_agent());
  const IcpResult r = local_map_.register_clouds(local_map_.query_cloud(), local_map_.match_cloud(), out->match_T_query,
                                                 config_.icp, &gravity);
  if (!r.ok) {
    ++counters_.local_map_refused;
    if (r.refusal == IcpRefusal::kNoOverlap) ++counters_.local_map_no_overlap;
    if (r.refusal == IcpRefusal::kDegenerate) ++counters_.local_map_degenerate;
    if (r.refusal == IcpRefusal::kCorrection) ++counters_.local_map_correction;
    return false;
  }
  out->icp = r;
  out->match_T_query = r.match_T_query;
  out->refined = true;
  out->local_map = true;
  ++counters_.local_map_refined;
  return true;
}

bool LoopClosureDetector::add_and_detect(const AgentEntry& query, LoopClosure* out) {
  ++counters_.queries;
  bool found = false;
  if (query.descriptor.num_points < config_.min_objects) {
    ++counters_.queries_without_objects;
  } else {
    candidates_.clear();
    const float radius = 2.0f * (1.0f - static_cast<float>(config_.places_threshold));  // similarity -> L1
    search(0, indexed_, query.descriptor, radius, query);
    for (std::uint32_t i = indexed_; i < entries_.size(); ++i) consider(i, query);  // the newest, not in the tree
    std::sort(candidates_.begin(), candidates_.end(),
              [](const Candidate& a, const Candidate& b) { return a.objects > b.objects; });
    std::size_t n = 0;
    while (n < candidates_.size() && candidates_[n].objects >= config_.objects_threshold) ++n;
    counters_.objects_candidates += n;
    bool ambiguous = false;  // the ratio test failed: neither verification may pick one of the look-alikes
    if (n > 0 && config_.ratio < 1.0) {
      // The best candidate elsewhere (the list is sorted, so the first far one is the best far one).
      const Eigen::Vector3d best_at = entries_[candidates_[0].entry].world_T_agent.translation();
      for (const Candidate& c : candidates_) {
        if ((entries_[c.entry].world_T_agent.translation() - best_at).norm() < config_.ratio_distance_m) continue;
        if (c.objects > config_.ratio * candidates_[0].objects) {
          ++counters_.ratio_rejections;
          ambiguous = true;
          n = 0;
        }
        break;
      }
    }
    const auto propose = [&](const Candidate& c, const AgentEntry& match) {
      out->match = match.agent;
      out->query = query.agent;
      out->match_time_ns = match.time_ns;
      out->query_time_ns = query.time_ns;
      out->world_T_match = match.world_T_agent;
      out->world_T_query = query.world_T_agent;
      out->places_similarity = c.places;
      out->objects_similarity = c.objects;
      ++counters_.proposed;
      found = true;
    };
    // Appearance first (precise), over the best candidates whatever their objects score, unless the place is
    // ambiguous (n == 0 after the ratio test with candidates left).
    if (query.appearance.count > 0 && !ambiguous) {
      for (std::size_t k = 0; k < candidates_.size() && k < config_.max_appearance_checks && !found; ++k) {
        const AgentEntry& match = entries_[candidates_[k].entry];
        if (match.appearance.count == 0) continue;
        ++counters_.appearance_checks;
        const GravityPrior gravity = GravityPrior::from_poses(match.odom_T_agent(), query.odom_T_agent());
        const AppearanceRegistration a =
            register_appearance(query.appearance, match.appearance, config_.appearance,
                                static_cast<std::uint32_t>(counters_.appearance_checks), &gravity);
        if (!a.ok) continue;
        ++counters_.appearance_accepted;
        out->source = ClosureSource::kAppearance;
        out->appearance = a;
        out->match_T_query = a.match_T_query;
        out->refined = false;
        out->local_map = false;
        // The refinement pass on the same pair: a RANSAC pose from a dozen features can be a few degrees off in
        // rotation; ICP on the two views' depth pins it where the views constrain every direction.
        if (config_.icp.enabled && query.cloud.count > 0 && match.cloud.count > 0) {
          const IcpResult r = refine_icp(query.cloud, match.cloud, a.match_T_query, config_.icp, &gravity);
          if (r.ok) {
            out->icp = r;
            out->match_T_query = r.match_T_query;
            out->refined = true;
            ++counters_.icp_refined;
          }
        }
        propose(candidates_[k], match);
      }
    }
    double verified_path[64];  // the path of the candidates verified for this query (max_verifications <= 64)
    std::uint32_t verified = 0;
    for (std::size_t k = 0; k < n && verified < config_.max_verifications && !found; ++k) {
      const AgentEntry& match = entries_[candidates_[k].entry];
      bool near_verified = false;
      for (std::uint32_t v = 0; v < verified && !near_verified; ++v)
        near_verified = std::abs(match.path_m - verified_path[v]) <= config_.distinct_verification_m;
      if (near_verified) {
        ++counters_.verifications_skipped;
        continue;
      }
      verified_path[verified++] = match.path_m;
      ++counters_.verifications;
      const Registration r = registration_.register_sets(query.descriptor.points.data(), query.descriptor.num_points,
                                                         match.descriptor.points.data(), match.descriptor.num_points);
      if (!r.ok()) {
        ++counters_.registration_failures;
        continue;
      }
      // r maps the query's odometric frame onto the match's: match_T_query = (w_T_m)^-1 * T * w_T_q.
      out->source = ClosureSource::kObjects;
      out->registration = r;
      out->match_T_query = match.world_T_agent.inverse() * r.target_T_source * query.world_T_agent;
      out->refined = false;
      out->local_map = false;
      const AgentEntry* matched = &match;
      if (config_.icp.enabled && query.cloud.count > 0) matched = refine_with_neighbours(query, candidates_[k].entry, out);
      if (!out->refined && config_.local_map.enabled && config_.icp.enabled && query.cloud.count > 0)
        refine_with_local_maps(query, candidates_[k].entry, out);
      if (!out->refined && !config_.propose_unrefined_objects) {
        ++counters_.objects_unrefined;
        continue;
      }
      propose(candidates_[k], *matched);
    }
  }
  if (entries_.size() == entries_.capacity() && entries_.size() >= 4) fold();
  if (entries_.size() == entries_.capacity()) {
    ++counters_.refused;
  } else {
    entries_.push_back(query);
    if (entries_.size() - indexed_ >= config_.rebuild_batch) rebuild();
  }
  high_water_ = std::max<std::uint64_t>(high_water_, entries_.size());
  return found;
}

}  // namespace qsg::loop_closure

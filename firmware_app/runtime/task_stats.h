// Per-task run statistics in a fixed struct (F' rate-group style): runs, min / max / mean time, a log-scale
// histogram for percentiles, overruns (ran past its budget), slips (started late), skips and deferrals.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>

namespace qsg::runtime {

struct TaskStats {
  // Bucket b holds durations in [2^(b-1), 2^b) microseconds (bucket 0: below 1 us); 2^31 us is about 36 min.
  static constexpr int kBuckets = 32;

  std::uint64_t runs = 0;
  std::uint64_t overruns = 0;   // took longer than budget_us
  std::uint64_t slips = 0;      // rate tasks: periods that passed without a run; keyframe tasks: ran a keyframe late
  std::uint64_t skips = 0;      // rate tasks: due, but their budget did not fit the time left in the tick
  std::uint64_t deferrals = 0;  // keyframe tasks: moved to the next keyframe because an earlier stage overran
  std::int64_t min_us = 0;
  std::int64_t max_us = 0;
  std::int64_t total_us = 0;
  std::int64_t last_us = 0;
  std::array<std::uint32_t, kBuckets> histogram{};

  void record(std::int64_t duration_us, std::uint32_t budget_us) {
    if (duration_us < 0) duration_us = 0;
    min_us = runs == 0 ? duration_us : (duration_us < min_us ? duration_us : min_us);
    max_us = duration_us > max_us ? duration_us : max_us;
    total_us += duration_us;
    last_us = duration_us;
    ++runs;
    if (budget_us > 0 && duration_us > static_cast<std::int64_t>(budget_us)) ++overruns;
    int b = 0;
    while (b + 1 < kBuckets && (std::int64_t{1} << b) <= duration_us) ++b;
    ++histogram[static_cast<std::size_t>(b)];
  }
  double mean_us() const { return runs == 0 ? 0.0 : static_cast<double>(total_us) / static_cast<double>(runs); }
  // Upper edge of the histogram bucket holding quantile q (an upper bound, within a factor of 2; never below
  // the true quantile, so a budget check on it is conservative), clamped to max_us.
  std::int64_t quantile_upper_us(double q) const {
    if (runs == 0) return 0;
    const double target = q * static_cast<double>(runs);
    std::uint64_t seen = 0;
    for (int b = 0; b < kBuckets; ++b) {
      seen += histogram[static_cast<std::size_t>(b)];
      if (static_cast<double>(seen) >= target) {
        const std::int64_t edge = b == 0 ? 1 : (std::int64_t{1} << b);
        return edge < max_us ? edge : max_us;
      }
    }
    return max_us;
  }
};

}  // namespace qsg::runtime

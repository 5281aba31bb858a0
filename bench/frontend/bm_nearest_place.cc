// BM_nearest_place_*: the frontend's k-d tree over place positions (core/frontend/nearest_place_index). Rebuild
// over N places (each places cycle rebuilds the active places' tree; every Config::reparent_untracked_every cycles
// the whole graph's), and the 8-nearest query of one object or agent, against a brute-force scan over the same
// points (partial sort of all N distances) in the same run.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "core/frontend/nearest_place_index.h"

namespace {

using qsg::frontend::NearestPlaceCapacities;
using qsg::frontend::NearestPlaceIndex;
using qsg::frontend::PlaceNeighbor;

// Points over a building floor of sqrt(places_n / 3.5) m squared (3.5 places per m^2, rooms_eval's density) between
// heights z_lo and z_hi, frozen by the seed: the places (z 0.3-2.2 m) and the objects queried (z 0-2 m).
std::vector<Eigen::Vector3d> points(std::size_t n, std::size_t places_n, double z_lo, double z_hi, unsigned seed) {
  std::mt19937 rng(seed);
  const double side = std::sqrt(static_cast<double>(places_n) / 3.5);
  std::uniform_real_distribution<double> xy(0.0, side), z(z_lo, z_hi);
  std::vector<Eigen::Vector3d> out(n);
  for (Eigen::Vector3d& p : out) p = Eigen::Vector3d(xy(rng), xy(rng), z(rng));
  return out;
}
std::vector<Eigen::Vector3d> places(std::size_t n) { return points(n, n, 0.3, 2.2, 7); }
std::vector<Eigen::Vector3d> queries(std::size_t n, std::size_t places_n) { return points(n, places_n, 0.0, 2.0, 8); }

// An index holding up to n places; false (the benchmark skipped with the error) when init fails.
bool init_index(benchmark::State& state, std::size_t n, NearestPlaceIndex* index) {
  std::string error;
  const NearestPlaceCapacities caps{n};
  if (index->init(caps, NearestPlaceIndex::plan(caps).total_bytes(), &error)) return true;
  state.SkipWithError(error.c_str());
  return false;
}

void BM_nearest_place_rebuild(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  const std::vector<Eigen::Vector3d> pts = places(n);
  NearestPlaceIndex index;
  if (!init_index(state, n, &index)) return;
  for (auto _ : state) benchmark::DoNotOptimize(index.rebuild(pts.data(), nullptr, n));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
  state.counters["places"] = static_cast<double>(n);
}

// 300 objects' 8 nearest places (one refresh of the objects out of the window).
constexpr std::size_t kQueries = 300;
constexpr std::size_t kK = 8;

void BM_nearest_place_query_kdtree(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  const std::vector<Eigen::Vector3d> pts = places(n), q = queries(kQueries, n);
  NearestPlaceIndex index;
  if (!init_index(state, n, &index)) return;
  index.rebuild(pts.data(), nullptr, n);
  PlaceNeighbor out[kK];
  for (auto _ : state)
    for (const Eigen::Vector3d& p : q) benchmark::DoNotOptimize(index.nearest(p, kK, out));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kQueries));
}

void BM_nearest_place_query_brute_force(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  const std::vector<Eigen::Vector3d> pts = places(n), q = queries(kQueries, n);
  std::vector<std::pair<double, std::size_t>> d(n);
  for (auto _ : state)
    for (const Eigen::Vector3d& p : q) {
      for (std::size_t i = 0; i < n; ++i) d[i] = {(pts[i] - p).squaredNorm(), i};
      std::partial_sort(d.begin(), d.begin() + kK, d.end());
      benchmark::DoNotOptimize(d.data());
    }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kQueries));
}

BENCHMARK(BM_nearest_place_rebuild)->Arg(1000)->Arg(8000)->Arg(32768)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_nearest_place_query_kdtree)->Arg(1000)->Arg(8000)->Arg(32768)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_nearest_place_query_brute_force)->Arg(1000)->Arg(8000)->Arg(32768)->Unit(benchmark::kMicrosecond);

}  // namespace

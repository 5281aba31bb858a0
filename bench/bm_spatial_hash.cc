// BM_spatial_hash_*: the voxel-block index (fixed open-addressing hash) at 50 % and 90 % load, against
// std::unordered_map (the unbounded map voxblox and nvblox use) on the same keys in the same run.
#include <benchmark/benchmark.h>

#include <random>
#include <unordered_map>
#include <vector>

#include "core/memory/fixed_hash_map.h"

namespace {

using qsg::memory::Arena;
using qsg::memory::ArenaPlan;
using qsg::memory::Index3;
using Hash = qsg::memory::SpatialHash<std::uint32_t>;

constexpr std::size_t kSlots = 1 << 16;  // 65,536 slots: 1.5 MB, about an 8 m active window of 0.8 m blocks

struct StdHash {
  std::size_t operator()(const Index3& k) const { return qsg::memory::Index3Hash{}(k); }
};

// Block indices of a compact region around the robot, shuffled (frozen by the seed).
std::vector<Index3> keys(std::size_t n, unsigned seed) {
  std::vector<Index3> out;
  const int side = static_cast<int>(std::cbrt(static_cast<double>(n))) + 2;
  for (int z = 0; z < side && out.size() < n * 2; ++z)
    for (int y = -side; y < side && out.size() < n * 2; ++y)
      for (int x = -side; x < side && out.size() < n * 2; ++x) out.push_back({x, y, z});
  std::shuffle(out.begin(), out.end(), std::mt19937(seed));
  out.resize(n * 2);  // the first n are inserted, the second n are misses
  return out;
}

struct Fixture {
  explicit Fixture(double load) : n(static_cast<std::size_t>(load * kSlots)), k(keys(n, 1)) {
    ArenaPlan plan;
    Hash::plan(plan, kSlots);
    arena.create("bench", plan, plan.total_bytes(), nullptr);
    map.carve(arena, kSlots, kSlots - 1);
    arena.seal();
  }
  std::size_t n;
  std::vector<Index3> k;
  Arena arena;
  Hash map{"bench.blocks"};
};

double load_of(const benchmark::State& s) { return s.range(0) / 100.0; }

void BM_spatial_hash_insert(benchmark::State& state) {
  Fixture f(load_of(state));
  for (auto _ : state) {
    state.PauseTiming();
    f.map.clear();
    state.ResumeTiming();
    for (std::size_t i = 0; i < f.n; ++i) f.map.insert(f.k[i], static_cast<std::uint32_t>(i));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.n));
  state.counters["max_probe"] = static_cast<double>(f.map.max_probe_length());
}

void BM_spatial_hash_find_hit(benchmark::State& state) {
  Fixture f(load_of(state));
  for (std::size_t i = 0; i < f.n; ++i) f.map.insert(f.k[i], static_cast<std::uint32_t>(i));
  std::uint64_t sum = 0;
  for (auto _ : state) {
    for (std::size_t i = 0; i < f.n; ++i) sum += *f.map.find(f.k[i]);
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.n));
}

void BM_spatial_hash_find_miss(benchmark::State& state) {
  Fixture f(load_of(state));
  for (std::size_t i = 0; i < f.n; ++i) f.map.insert(f.k[i], static_cast<std::uint32_t>(i));
  std::size_t found = 0;
  for (auto _ : state) {
    for (std::size_t i = f.n; i < 2 * f.n; ++i) found += f.map.find(f.k[i]) != nullptr;
  }
  benchmark::DoNotOptimize(found);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.n));
}

// Erase half the entries, then re-insert them, so every iteration runs at the stated load.
void BM_spatial_hash_erase(benchmark::State& state) {
  Fixture f(load_of(state));
  for (std::size_t i = 0; i < f.n; ++i) f.map.insert(f.k[i], static_cast<std::uint32_t>(i));
  const std::size_t half = f.n / 2;
  for (auto _ : state) {
    for (std::size_t i = 0; i < half; ++i) f.map.erase(f.k[i]);
    state.PauseTiming();
    for (std::size_t i = 0; i < half; ++i) f.map.insert(f.k[i], static_cast<std::uint32_t>(i));
    state.ResumeTiming();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * half));
}

// Peer: std::unordered_map with the same keys and hash function.
void BM_std_unordered_map_insert(benchmark::State& state) {
  Fixture f(load_of(state));
  std::unordered_map<Index3, std::uint32_t, StdHash> map;
  for (auto _ : state) {
    state.PauseTiming();
    map.clear();
    state.ResumeTiming();
    for (std::size_t i = 0; i < f.n; ++i) map[f.k[i]] = static_cast<std::uint32_t>(i);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.n));
}

void BM_std_unordered_map_find_hit(benchmark::State& state) {
  Fixture f(load_of(state));
  std::unordered_map<Index3, std::uint32_t, StdHash> map;
  for (std::size_t i = 0; i < f.n; ++i) map[f.k[i]] = static_cast<std::uint32_t>(i);
  std::uint64_t sum = 0;
  for (auto _ : state) {
    for (std::size_t i = 0; i < f.n; ++i) sum += map.find(f.k[i])->second;
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.n));
}

void BM_std_unordered_map_find_miss(benchmark::State& state) {
  Fixture f(load_of(state));
  std::unordered_map<Index3, std::uint32_t, StdHash> map;
  for (std::size_t i = 0; i < f.n; ++i) map[f.k[i]] = static_cast<std::uint32_t>(i);
  std::size_t found = 0;
  for (auto _ : state) {
    for (std::size_t i = f.n; i < 2 * f.n; ++i) found += map.count(f.k[i]);
  }
  benchmark::DoNotOptimize(found);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.n));
}

void BM_std_unordered_map_erase(benchmark::State& state) {
  Fixture f(load_of(state));
  std::unordered_map<Index3, std::uint32_t, StdHash> map;
  for (std::size_t i = 0; i < f.n; ++i) map[f.k[i]] = static_cast<std::uint32_t>(i);
  const std::size_t half = f.n / 2;
  for (auto _ : state) {
    for (std::size_t i = 0; i < half; ++i) map.erase(f.k[i]);
    state.PauseTiming();
    for (std::size_t i = 0; i < half; ++i) map[f.k[i]] = static_cast<std::uint32_t>(i);
    state.ResumeTiming();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * half));
}

#define QSG_LOADS ->Arg(50)->Arg(90)->ArgName("load_pct")->Unit(benchmark::kMicrosecond)
BENCHMARK(BM_spatial_hash_insert) QSG_LOADS;
BENCHMARK(BM_std_unordered_map_insert) QSG_LOADS;
BENCHMARK(BM_spatial_hash_find_hit) QSG_LOADS;
BENCHMARK(BM_std_unordered_map_find_hit) QSG_LOADS;
BENCHMARK(BM_spatial_hash_find_miss) QSG_LOADS;
BENCHMARK(BM_std_unordered_map_find_miss) QSG_LOADS;
BENCHMARK(BM_spatial_hash_erase) QSG_LOADS;
BENCHMARK(BM_std_unordered_map_erase) QSG_LOADS;

}  // namespace

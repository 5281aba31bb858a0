// Counter-based hashing: random numbers as a pure function of (seed, frame, pixel, stream), so a render is
// bit-identical for a seed whatever order or thread computes each pixel.
#pragma once

#include <cstdint>

namespace qsg::render {

// SplitMix64 finaliser: a bijective 64-bit mixer with good avalanche.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

inline std::uint64_t hash_combine(std::uint64_t key, std::uint64_t value) {
  return mix64(key ^ (value * 0xD6E8FEB86659FD93ull));
}

// Uniform in (0, 1] from the top 53 bits.
inline double unit_double_open0(std::uint64_t h) {
  return (static_cast<double>(h >> 11) + 1.0) * (1.0 / 9007199254740992.0);
}

}  // namespace qsg::render

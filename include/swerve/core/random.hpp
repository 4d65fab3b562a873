// Seeded pseudo-random numbers shared by the annealer and the simulator. Our own generators, not
// <random>'s distributions, so a seed gives the same numbers with every standard library.
#pragma once

#include <cstdint>

namespace swerve {

// SplitMix64 (Steele, Lea, Flood 2014): advances `state` and returns the next 64-bit output.
inline std::uint64_t splitmix64(std::uint64_t* state) noexcept {
  std::uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace swerve

// Seeded pseudo-random numbers shared by the annealer, the simulator and the envelope's draws. Our
// own generators, not <random>'s distributions, so a seed gives the same numbers with every
// standard library.
#pragma once

#include <cmath>
#include <cstdint>

#include "swerve/core/constants.hpp"

namespace swerve {

// SplitMix64 (Steele, Lea, Flood 2014): advances `state` and returns the next 64-bit output.
inline std::uint64_t splitmix64(std::uint64_t* state) noexcept {
  std::uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// A double in [0, 1) from the top 53 bits of a generator's 64-bit output.
inline double unit_interval(std::uint64_t bits) noexcept { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

// Two independent standard normal deviates from u1 in (0, 1] and u2 in [0, 1): the Box-Muller
// transform (Box & Muller 1958), r = sqrt(-2 ln u1), (r cos 2 pi u2, r sin 2 pi u2).
struct NormalPair {
  double first, second;
};
inline NormalPair box_muller(double u1, double u2) noexcept {
  const double radius = std::sqrt(-2.0 * std::log(u1));
  return {radius * std::cos(2.0 * kPi * u2), radius * std::sin(2.0 * kPi * u2)};
}

// xoshiro256** (Blackman & Vigna 2018), its state seeded by SplitMix64: fast, and the same stream
// on every platform for a seed. gaussian() uses both deviates of each Box-Muller pair.
class RandomStream {
 public:
  explicit RandomStream(std::uint64_t seed) noexcept {
    for (std::uint64_t& word : state_) word = splitmix64(&seed);
  }

  double uniform() noexcept {  // [0, 1)
    const std::uint64_t result = rotate_left(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotate_left(state_[3], 45);
    return unit_interval(result);
  }

  double gaussian() noexcept {  // N(0, 1)
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: the logarithm is finite
    const NormalPair pair = box_muller(u1, uniform());
    spare_ = pair.second;
    has_spare_ = true;
    return pair.first;
  }

 private:
  static std::uint64_t rotate_left(std::uint64_t x, int k) noexcept { return (x << k) | (x >> (64 - k)); }

  std::uint64_t state_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace swerve

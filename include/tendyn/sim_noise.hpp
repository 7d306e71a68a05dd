// tendyn — the simulator's randomness (part of sim.hpp): a seeded splitmix64 stream and Box–Muller normal
// variates, the same on every platform, for the sensors' noise (encoder quantisation is in sim_control.hpp).
#pragma once

#include <cmath>
#include <cstdint>

namespace tendyn {

/// Deterministic normal variates: splitmix64 + Box–Muller (same stream on every platform).
struct Rng {
  std::uint64_t state = 0;
  bool has_spare = false;
  double spare = 0.0;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  double normal() {
    if (has_spare) { has_spare = false; return spare; }
    const double u1 = uniform(), u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 6.283185307179586 * u2;
    spare = r * std::sin(a);
    has_spare = true;
    return r * std::cos(a);
  }
};

}  // namespace tendyn

// The McGill 2N bench step allocates nothing (friction, noise, amplifier lag on).
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "counting_malloc.hpp"
#include "tendyn/tendon_bench.hpp"

int main(int argc, char** argv) {
  const long steps = argc > 1 ? std::atol(argv[1]) : 100000;
  tendyn::TendonBenchModel m;
  m.noise_force = 0.01;
  m.noise_position = 1e-6;
  m.amplifier_lag = 1e-4;
  m.k_z = 1e4;  // sub-stepped soft load
  tendyn::TendonBenchData d(m, 7);
  counting::armed = true;
  for (long s = 0; s < steps; ++s) tendyn::step(m, d, 2.0 * std::sin(2e-3 * s));
  counting::armed = false;
  std::printf("%ld steps, %ld allocations, F_m = %.4f N\n", steps, counting::count, d.force_measured);
  return counting::count == 0 ? 0 : 1;
}

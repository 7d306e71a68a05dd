// The McGill 2N bench step allocates nothing (friction, noise, amplifier lag on); and two physics checks
// against values computed by hand, so that this executable can fail on wrong bench physics by itself.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "counting_malloc.hpp"
#include "tendyn/tendon_bench.hpp"

// Friction grows with the node's OWN tendon (DEVICES.md 2): F_c = F_c0 + mu T_own. Node A is put at a
// stretch that gives T_a = 25 N while T_b = T_pre = 5 N (clamped load); a net force of 0.97 (F_c0 + mu T_a)
// must leave it stuck, 1.03 (F_c0 + mu T_a) must break it away.
static int own_tendon_friction() {
  tendyn::TendonBenchModel m;
  m.friction_c0 = 0.2;
  m.friction_mu_tension = 0.05;
  m.k_z = 1e9;
  int fails = 0;
  for (double frac : {0.97, -0.97, -1.03}) {
    tendyn::TendonBenchData d(m, 0);
    d.x_a = 20.0 / (0.5 * m.k_e());                  // T_a = T_pre + (k_e/2) x_a = 25 N
    const double t_a = m.pretension + 0.5 * m.k_e() * d.x_a;
    const double fc = m.friction_c0 + m.friction_mu_tension * t_a;
    const double u = t_a - m.pretension + frac * fc;  // A pulls with T_pre + u = T_a + frac F_c
    const double x0 = d.x_a;
    for (int k = 0; k < 2000; ++k) tendyn::tendon_bench_step(m, d, u);
    const bool held = d.x_a == x0;
    if (held != (std::fabs(frac) < 1.0)) {
      std::printf("PHYSICS FAIL own-tendon friction: net %.2f F_c, node %s\n", frac, held ? "held" : "slid");
      ++fails;
    }
  }
  return fails;
}

// Sensed displacement at a static equilibrium (friction off, clamped load, constant u): X_t = u/k2.
static int sensed_displacement() {
  tendyn::TendonBenchModel m;
  m.friction_c0 = 0.0;
  m.friction_mu_tension = 0.0;
  m.k_z = 1e9;
  tendyn::TendonBenchData d(m, 0);
  for (int k = 0; k < 60000; ++k) tendyn::tendon_bench_step(m, d, 3.0);
  const double want = 3.0 / m.k2;
  if (!(std::fabs(d.position_true - want) <= 1e-6 * want)) {
    std::printf("PHYSICS FAIL X_t = %.9g m, want u/k2 = %.9g m\n", d.position_true, want);
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  const long steps = argc > 1 ? std::atol(argv[1]) : 100000;
  const int physics = own_tendon_friction() + sensed_displacement();
  tendyn::TendonBenchModel m;
  m.noise_force = 0.01;
  m.noise_position = 1e-6;
  m.amplifier_lag = 1e-4;
  m.k_z = 1e4;  // sub-stepped soft load
  tendyn::TendonBenchData d(m, 7);
  counting::armed = true;
  for (long s = 0; s < steps; ++s) tendyn::tendon_bench_step(m, d, 2.0 * std::sin(2e-3 * s));
  counting::armed = false;
  std::printf("%ld steps, %ld allocations, F_m = %.4f N; physics checks: %d failed\n", steps, counting::count,
              d.force_measured, physics);
  return counting::count == 0 && physics == 0 ? 0 : 1;
}

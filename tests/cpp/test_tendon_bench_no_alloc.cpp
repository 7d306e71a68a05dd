// The McGill 2N bench step allocates nothing (friction, noise, amplifier lag on), open loop and with a
// 4th-order discrete controller in the loop (step_closed_loop / run_closed_loop); and two physics checks
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
    for (int k = 0; k < 2000; ++k) tendyn::step(m, d, u);
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
  for (int k = 0; k < 60000; ++k) tendyn::step(m, d, 3.0);
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
  for (long s = 0; s < steps; ++s) tendyn::step(m, d, 2.0 * std::sin(2e-3 * s));
  counting::armed = false;
  std::printf("open loop: %ld steps, %ld allocations, F_m = %.4f N\n", steps, counting::count, d.force_measured);
  const long open_count = counting::count;

  // Closed loop: a stable 4th-order C(z) (two damped pole pairs), 5 kHz control (decimation 4), limited u.
  tendyn::BenchControllerModel c;
  c.order = 4;
  const double a[4][4] = {{1.6, -0.7, 0, 0}, {1, 0, 0, 0}, {0, 0, 1.2, -0.5}, {0, 0, 1, 0}};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) c.A[i * tendyn::BenchControllerModel::max_order + j] = a[i][j];
  c.B[0] = 1.0; c.B[2] = 0.5;
  c.C[0] = 0.05; c.C[1] = -0.02; c.C[2] = 0.03; c.C[3] = 0.01;
  c.D = 0.8;
  c.decimation = 4;
  c.u_limit = 20.0;
  tendyn::BenchControllerData cd(c);
  tendyn::reset(c, cd);
  tendyn::TendonBenchData d2(m, 11);
  static double r[1000], fm[1000], u[1000], ft[1000];
  for (int i = 0; i < 1000; ++i) r[i] = 1.5 * std::sin(2e-2 * i);
  counting::count = 0;
  counting::armed = true;
  tendyn::Status st = tendyn::Status::Ok;
  for (long s = 0; s < steps && !tendyn::is_error(st); ++s) st = tendyn::step_closed_loop(m, d2, c, cd, r[s % 1000]);
  for (int k = 0; k < 20 && !tendyn::is_error(st); ++k) st = tendyn::run_closed_loop(m, d2, c, cd, r, 1000, fm, u, ft);
  counting::armed = false;
  std::printf("closed loop: %ld + 20000 steps, %ld allocations, status %d, F_m = %.4f N, u = %.4f N\n", steps,
              counting::count, static_cast<int>(st), d2.force_measured, cd.u);
  std::printf("physics checks: %d failed\n", physics);
  return (open_count == 0 && counting::count == 0 && !tendyn::is_error(st) && physics == 0) ? 0 : 1;
}

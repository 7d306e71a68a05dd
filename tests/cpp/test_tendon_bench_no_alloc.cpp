// The McGill 2N bench step allocates nothing (friction, noise, amplifier lag on), open loop and with a
// 4th-order discrete controller in the loop (step_closed_loop / run_closed_loop).
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
  return (open_count == 0 && counting::count == 0 && !tendyn::is_error(st)) ? 0 : 1;
}

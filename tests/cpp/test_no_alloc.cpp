// The real-time calls allocate nothing: 10^5 calls of each with malloc counted (DESIGN.md).
#include <cstdio>
#include <cstdlib>
#include <random>

#include "counting_malloc.hpp"
#include "tendyn/losses.hpp"

int main(int argc, char** argv) {
  const long calls = argc > 1 ? std::atol(argv[1]) : 100000;
  const int n = 4;
  Eigen::MatrixXd idle = Eigen::MatrixXd::Zero(n, n);
  idle(1, 0) = 0.015; idle(2, 0) = 0.015; idle(2, 1) = -0.015;
  idle(3, 0) = 0.015; idle(3, 1) = -0.015; idle(3, 2) = 0.015;
  tendyn::TransmissionModel m(Eigen::VectorXd::Constant(n, 0.008), idle,
                              (Eigen::VectorXd(n) << 0.04, 0.04, 0.09, 0.03).finished(),
                              (Eigen::VectorXd(n) << 8, 8, 1, 8).finished());
  m.reducer_efficiency << 0.9, 0.9, 1.0, 0.9;
  m.tau0.setConstant(1.0); m.nu.setConstant(10.0); m.beta.setConstant(0.02);
  m.pretension.setConstant(50.0);
  m.bearing_count(3, 2) = 2; m.bearing_radius(3, 2) = 0.01; m.bearing_wrap(3, 2) = 3.141592653589793;
  m.bearing_static_coefficient(3, 2) = 2e-4; m.bearing_dynamic_coefficient(3, 2) = 1.5e-4; m.bearing_h0(3, 2) = 1e-4; m.bearing_h1(3, 2) = 2e-5; m.bearing_n0(3, 2) = 5;
  if (tendyn::is_error(m.validate())) { std::puts("invalid model"); return 1; }
  tendyn::TransmissionData d(m);

  std::mt19937 rng(1234);
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::VectorXd tau(n), qd(n), cm(n), q(n);
  long bad = 0;
  // The counter itself must see an allocation, or this test could not fail.
  counting::armed = true;
  { Eigen::VectorXd probe(64); probe.setZero(); }
  const long probe_count = counting::count;
  counting::count = 0;
  if (probe_count == 0) { std::puts("malloc interposition does not work"); return 1; }
  for (long k = 0; k < calls; ++k) {
    for (int i = 0; i < n; ++i) { tau(i) = N(rng); qd(i) = (k % 7 == 0) ? 0.0 : N(rng); q(i) = N(rng); }
    if (tendyn::is_error(tendyn::motor_torque_feedforward(m, d, tau, qd))) ++bad;
    cm = d.torque_motor;
    if (tendyn::is_error(tendyn::joint_torque_forward(m, d, cm, qd))) ++bad;
    if (tendyn::is_error(tendyn::motor_from_joint(m, d, q))) ++bad;
    if (tendyn::is_error(tendyn::joint_from_motor(m, d, d.q_motor))) ++bad;
    tendyn::branch_displacements(m, d);
  }
  counting::armed = false;
  std::printf("%ld calls x 5 functions: %ld allocations, %ld error statuses\n", calls, counting::count, bad);
  return (counting::count == 0 && bad == 0) ? 0 : 1;
}

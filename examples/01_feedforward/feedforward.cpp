// Example 01 (C++): L-EXOS feedforward motor torques with cable losses, header-only core.
// Same inputs and output format as feedforward.c and feedforward.py.
#include <cstdio>

#include "tendyn/losses.hpp"

int main() {
  const int n = 4;
  Eigen::MatrixXd idle = Eigen::MatrixXd::Zero(n, n);  // signed idle radii [m] (lexos.toml)
  idle(1, 0) = 0.015;
  idle(2, 0) = 0.015; idle(2, 1) = -0.015;
  idle(3, 0) = 0.015; idle(3, 1) = -0.015; idle(3, 2) = 0.015;
  tendyn::TransmissionModel model(Eigen::VectorXd::Constant(n, 0.008), idle,
                                  (Eigen::VectorXd(n) << 0.04, 0.04, 0.09, 0.03).finished(),
                                  (Eigen::VectorXd(n) << 8, 8, 1, 8).finished());
  model.reducer_efficiency << 0.9, 0.9, 1.0, 0.9;
  for (int i = 0; i < n; ++i)
    for (int b = 0; b <= i; ++b) { model.tau0(i, b) = 1.0; model.nu(i, b) = 10.0; model.beta(i, b) = 0.02; }
  if (tendyn::is_error(model.validate())) return 1;
  tendyn::TransmissionData data(model);  // all allocation happens here

  const Eigen::Vector4d torque_joint(2.0, 0.0, 0.0, 1.0);  // N·m wanted
  const Eigen::Vector4d qdot(0.5, 0.0, 0.0, 0.2);          // rad/s now
  const tendyn::Status s = tendyn::motor_torque_feedforward(model, data, torque_joint, qdot);
  if (tendyn::is_error(s)) { std::fprintf(stderr, "%s\n", tendyn::status_message(s)); return 1; }
  std::printf("torque_motor");
  for (int i = 0; i < n; ++i) std::printf(" %.17g", data.torque_motor(i));
  std::printf("\n");
  return 0;
}

// Example 01 (C++): feedforward motor torques with cable losses, header-only core, for any device.
// The model is loaded from a model file exported by Python (see feedforward.c); n comes from the file.
// Usage: feedforward_cpp MODEL_FILE. Same inputs and output as feedforward.c and feedforward.py.
// Build against the installed package: docs/c-package.md (CMake target tendyn::core, needs Eigen).
#include <cstdio>
#include <string>

#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"

int main(int argc, char** argv) {
  if (argc != 2) { std::fprintf(stderr, "usage: %s MODEL_FILE\n", argv[0]); return 2; }
  tendyn::TransmissionModel model;
  std::string error;
  if (!tendyn::load_transmission_model(argv[1], &model, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  tendyn::TransmissionData data(model);  // all allocation happens here

  Eigen::VectorXd torque_joint(model.n), qd(model.n);
  for (int i = 0; i < model.n; ++i) {
    torque_joint(i) = 2.0 / (i + 1);  // N·m wanted
    qd(i) = 0.5 / (i + 1);            // rad/s now
  }
  const tendyn::Status s = tendyn::motor_torque_feedforward(model, data, torque_joint, qd);
  if (tendyn::is_error(s)) { std::fprintf(stderr, "%s\n", tendyn::status_message(s)); return 1; }
  std::printf("torque_motor");
  for (int i = 0; i < model.n; ++i) std::printf(" %.17g", data.torque_motor(i));
  std::printf("\n");
  return 0;
}

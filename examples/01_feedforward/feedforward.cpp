// Example 01 (C++): L-EXOS feedforward motor torques with cable losses, header-only core.
// The model is loaded from the model file exported by Python (see feedforward.c), not copied by hand.
// Usage: example_01_feedforward_cpp [model file]. Same inputs and output format as feedforward.c and .py.
#include <cstdio>
#include <string>

#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"

#ifndef TENDYN_EXAMPLE_MODEL
#define TENDYN_EXAMPLE_MODEL "lexos.model"
#endif

int main(int argc, char** argv) {
  tendyn::TransmissionModel model;
  std::string error;
  if (!tendyn::load_transmission_model(argc > 1 ? argv[1] : TENDYN_EXAMPLE_MODEL, &model, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  tendyn::TransmissionData data(model);  // all allocation happens here

  const Eigen::Vector4d torque_joint(2.0, 0.0, 0.0, 1.0);  // N·m wanted
  const Eigen::Vector4d qd(0.5, 0.0, 0.0, 0.2);          // rad/s now
  if (model.n != 4) { std::fprintf(stderr, "expected 4 transmissions\n"); return 1; }
  const tendyn::Status s = tendyn::motor_torque_feedforward(model, data, torque_joint, qd);
  if (tendyn::is_error(s)) { std::fprintf(stderr, "%s\n", tendyn::status_message(s)); return 1; }
  std::printf("torque_motor");
  for (int i = 0; i < model.n; ++i) std::printf(" %.17g", data.torque_motor(i));
  std::printf("\n");
  return 0;
}

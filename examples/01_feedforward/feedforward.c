/* Example 01 (C): L-EXOS feedforward motor torques with cable losses, through the C ABI.
 * The model (routing, reducers, branch losses, bearings) is loaded from a model file exported by Python,
 * never copied by hand:
 *     python -c "from tendyn.device import load_device; from tendyn.devices import bundled; \
 *                from tendyn.transmission import Transmission; \
 *                Transmission.from_device(load_device(bundled('lexos'))).export('lexos.model')"
 * Usage: example_01_feedforward_c [model file] (default: lexos.model next to this source).
 * Same inputs and output format as feedforward.cpp and feedforward.py. Build: see tests/cpp. */
#include <stdio.h>

#include "tendyn/c_api.h"

#ifndef TENDYN_EXAMPLE_MODEL
#define TENDYN_EXAMPLE_MODEL "lexos.model"
#endif

int main(int argc, char** argv) {
  const char* path = argc > 1 ? argv[1] : TENDYN_EXAMPLE_MODEL;
  char message[512];
  tendyn_transmission* t = NULL;
  tendyn_status s = tendyn_transmission_load(path, &t, message, sizeof message);
  if (s != TENDYN_OK) { fprintf(stderr, "load: %s\n", message); return 1; }
  enum { n = 4 };
  if (tendyn_transmission_size(t) != n) { fprintf(stderr, "expected %d transmissions\n", n); return 1; }

  const double torque_joint[n] = {2.0, 0.0, 0.0, 1.0}; /* N·m wanted */
  const double qd[n] = {0.5, 0.0, 0.0, 0.2};         /* rad/s now */
  double torque_motor[n];
  s = tendyn_motor_torque_feedforward(t, torque_joint, qd, torque_motor);
  if (s < 0) { fprintf(stderr, "feedforward: %s\n", tendyn_status_message(s)); return 1; }
  printf("torque_motor");
  for (int i = 0; i < n; ++i) printf(" %.17g", torque_motor[i]);
  printf("\n");
  tendyn_transmission_destroy(t);
  return 0;
}

/* Example 01 (C): feedforward motor torques with cable losses, through the C ABI, for any device.
 * The model (routing, reducers, branch losses, bearings) is loaded from a model file exported by Python,
 * never copied by hand; n comes from the file:
 *     python -c "from tendyn.device import load_device; from tendyn.transmission import Transmission; \
 *                Transmission.from_device(load_device('my_device.toml')).export('my_device.model')"
 * (a compensator model file, *.comp, works too: its transmission comes first).
 * Usage: feedforward_c MODEL_FILE. Inputs: joint i (0-based) wants tau_i = 2/(i+1) N·m and moves at
 * qd_i = 0.5/(i+1) rad/s. Same inputs and output as feedforward.cpp and feedforward.py.
 * Build against the installed package: docs/c-package.md (`cc feedforward.c $(tendyn config --cflags --libs)`). */
#include <stdio.h>
#include <stdlib.h>

#include "tendyn/c_api.h"

int main(int argc, char** argv) {
  if (argc != 2) { fprintf(stderr, "usage: %s MODEL_FILE\n", argv[0]); return 2; }
  char message[512];
  tendyn_transmission* t = NULL;
  tendyn_status s = tendyn_transmission_load(argv[1], &t, message, sizeof message);
  if (s != TENDYN_OK) { fprintf(stderr, "load: %s\n", message); return 1; }
  const int n = tendyn_transmission_size(t);
  double* buffer = malloc(3 * (size_t)n * sizeof(double)); /* setup time: the loop itself never allocates */
  if (!buffer) { tendyn_transmission_destroy(t); return 1; }
  double *torque_joint = buffer, *qd = buffer + n, *torque_motor = buffer + 2 * n;
  for (int i = 0; i < n; ++i) {
    torque_joint[i] = 2.0 / (i + 1); /* N·m wanted */
    qd[i] = 0.5 / (i + 1);           /* rad/s now */
  }
  s = tendyn_motor_torque_feedforward(t, torque_joint, qd, torque_motor);
  if (s < 0) fprintf(stderr, "feedforward: %s\n", tendyn_status_message(s));
  else {
    printf("torque_motor");
    for (int i = 0; i < n; ++i) printf(" %.17g", torque_motor[i]);
    printf("\n");
  }
  free(buffer);
  tendyn_transmission_destroy(t);
  return s < 0 ? 1 : 0;
}

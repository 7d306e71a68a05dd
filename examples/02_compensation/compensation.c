/* Example 02: compensation cycles on an exported compensator model, in C (the same in compensation.cpp and
 * compensation.py; tests/python/test_examples.py compares the three to 1e-12, on L-EXOS and other devices).
 *
 * A controller loads the compensator model file once (exported by Python from a device file:
 * `python compensation.py --export my_device.toml my_device.comp`), then calls
 * one cycle per control period: motor encoder readings + wanted joint torques -> motor torques covering gravity
 * and the transmission losses. n comes from the file.
 * Usage: compensation_c MODEL.comp [DEVICE_NAME] (with DEVICE_NAME, a file of another device is refused).
 * Motion: motor i (0-based) on its own sine, 2 sin(2π (0.5 + 0.3 i) t) + 0.1 i rad, 500 cycles at 1 kHz;
 * joint i wants 0.5 (−0.4)^i N·m. Build against the installed package: docs/c-package.md. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "tendyn/c_api.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) { fprintf(stderr, "usage: %s MODEL.comp [DEVICE_NAME]\n", argv[0]); return 2; }
  char message[512];
  tendyn_compensator* comp = NULL;
  if (tendyn_compensator_load(argv[1], argc > 2 ? argv[2] : NULL, &comp, message, sizeof message) != TENDYN_OK) {
    fprintf(stderr, "%s\n", message);
    return 1;
  }
  const int n = tendyn_compensator_size(comp);
  double* buffer = calloc(4 * (size_t)n, sizeof(double)); /* setup time: the cycles never allocate */
  if (!buffer) { tendyn_compensator_destroy(comp); return 1; }
  double *q_motor = buffer, *torque_joint = buffer + n, *torque_motor = buffer + 2 * n, *sum = buffer + 3 * n;
  for (int i = 0; i < n; ++i) torque_joint[i] = 0.5 * pow(-0.4, i);
  double compute_time = 0.0, worst = 0.0;
  const double rate_hz = 1000.0;
  tendyn_status s = TENDYN_OK;
  for (int k = 0; k < 500 && s >= 0; ++k) { /* 0.5 s of motion: every motor on its own sine */
    const double t = k / rate_hz;
    for (int i = 0; i < n; ++i) q_motor[i] = 2.0 * sin(2.0 * 3.141592653589793 * (0.5 + 0.3 * i) * t) + 0.1 * i;
    s = tendyn_compensator_cycle(comp, q_motor, torque_joint, torque_motor, &compute_time);
    if (s < 0) fprintf(stderr, "cycle %d: %s\n", k, tendyn_status_message(s));
    for (int i = 0; i < n; ++i) sum[i] += torque_motor[i];
    if (compute_time > worst) worst = compute_time;
  }
  if (s >= 0) {
    printf("torque_motor");
    for (int i = 0; i < n; ++i) printf(" %.17g", torque_motor[i]);
    printf("\nsum_torque_motor");
    for (int i = 0; i < n; ++i) printf(" %.17g", sum[i]);
    printf("\n# longest cycle %.3g us\n", 1e6 * worst);
  }
  free(buffer);
  tendyn_compensator_destroy(comp);
  return s < 0 ? 1 : 0;
}

/* Example 02: compensation cycles on the exported L-EXOS model, in C (the same in compensation.cpp and
 * compensation.py; tests/python/test_examples.py compares the three to 1e-12).
 *
 * A controller loads the compensator model file once (exported by Python from lexos.toml:
 * `Compensator.from_device(load_device(bundled("lexos"))).export("lexos.comp")`), then calls one cycle per
 * control period: motor encoder readings + wanted joint torques -> motor torques covering gravity and the
 * transmission losses. Built against the installed package (tendyn/include, tendyn/lib). */
#include <math.h>
#include <stdio.h>

#include "tendyn/c_api.h"

#ifndef TENDYN_EXAMPLE_MODEL
#define TENDYN_EXAMPLE_MODEL "lexos.comp"
#endif

int main(int argc, char** argv) {
  const char* path = argc > 1 ? argv[1] : TENDYN_EXAMPLE_MODEL;
  char message[512];
  tendyn_compensator* comp = NULL;
  if (tendyn_compensator_load(path, "L-EXOS", &comp, message, sizeof message) != TENDYN_OK) {
    fprintf(stderr, "%s\n", message);
    return 1;
  }
  const int n = tendyn_compensator_size(comp);
  double q_motor[4], torque_joint[4] = {0.5, -0.2, 0.1, 0.05}, torque_motor[4], sum[4] = {0, 0, 0, 0};
  double compute_time = 0.0, worst = 0.0;
  const double rate_hz = 1000.0;
  for (int k = 0; k < 500; ++k) { /* 0.5 s of motion: every motor on its own sine */
    const double t = k / rate_hz;
    for (int i = 0; i < n; ++i) q_motor[i] = 2.0 * sin(2.0 * 3.141592653589793 * (0.5 + 0.3 * i) * t) + 0.1 * i;
    const tendyn_status s = tendyn_compensator_cycle(comp, q_motor, torque_joint, torque_motor, &compute_time);
    if (s < 0) {
      fprintf(stderr, "cycle %d: %s\n", k, tendyn_status_message(s));
      tendyn_compensator_destroy(comp);
      return 1;
    }
    for (int i = 0; i < n; ++i) sum[i] += torque_motor[i];
    if (compute_time > worst) worst = compute_time;
  }
  printf("torque_motor");
  for (int i = 0; i < n; ++i) printf(" %.17g", torque_motor[i]);
  printf("\nsum_torque_motor");
  for (int i = 0; i < n; ++i) printf(" %.17g", sum[i]);
  printf("\n# longest cycle %.3g us\n", 1e6 * worst);
  tendyn_compensator_destroy(comp);
  return 0;
}

/* Example 01 (C): L-EXOS feedforward motor torques with cable losses, through the C ABI.
 * Same inputs and output format as feedforward.cpp and feedforward.py. Build: see tests/cpp. */
#include <stdio.h>

#include "tendyn/c_api.h"

int main(void) {
  enum { n = 4 };
  /* L-EXOS routing (python/tendyn/devices/lexos.toml): radii [m], reducers, efficiencies */
  const double motor_radius[n] = {0.008, 0.008, 0.008, 0.008};
  const double idle[n * n] = {0, 0, 0, 0,  0.015, 0, 0, 0,  0.015, -0.015, 0, 0,  0.015, -0.015, 0.015, 0};
  const double driven_radius[n] = {0.04, 0.04, 0.09, 0.03};
  const double ratio[n] = {8, 8, 1, 8};
  const double eta[n] = {0.9, 0.9, 1.0, 0.9};
  double tau0[n * n] = {0}, nu[n * n] = {0}, beta[n * n] = {0};
  for (int i = 0; i < n; ++i)
    for (int b = 0; b <= i; ++b) { tau0[i * n + b] = 1.0; nu[i * n + b] = 10.0; beta[i * n + b] = 0.02; }
  tendyn_transmission* t = NULL;
  tendyn_status s = tendyn_transmission_create(n, motor_radius, idle, driven_radius, ratio, eta, NULL,
                                               tau0, nu, beta, &t);
  if (s != TENDYN_OK) { fprintf(stderr, "create: %s\n", tendyn_status_message(s)); return 1; }

  const double torque_joint[n] = {2.0, 0.0, 0.0, 1.0}; /* N·m wanted */
  const double qdot[n] = {0.5, 0.0, 0.0, 0.2};         /* rad/s now */
  double torque_motor[n];
  s = tendyn_motor_torque_feedforward(t, torque_joint, qdot, torque_motor);
  if (s < 0) { fprintf(stderr, "feedforward: %s\n", tendyn_status_message(s)); return 1; }
  printf("torque_motor");
  for (int i = 0; i < n; ++i) printf(" %.17g", torque_motor[i]);
  printf("\n");
  tendyn_transmission_destroy(t);
  return 0;
}

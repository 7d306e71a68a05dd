/* The C ABI: create, round trip, feedforward/forward inverse, errors as status codes. */
#include <math.h>
#include <stdio.h>

#include "tendyn/c_api.h"

#define CHECK(cond)                                              \
  do {                                                           \
    if (!(cond)) {                                               \
      fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
      return 1;                                                  \
    }                                                            \
  } while (0)

int main(void) {
  enum { n = 3 };
  const double rm[n] = {0.01, 0.01, 0.01};
  const double idle[n * n] = {0, 0, 0, 0.02, 0, 0, 0.02, -0.015, 0};
  const double rd[n] = {0.04, 0.03, 0.03}, ratio[n] = {8, 1, 5}, eta[n] = {0.9, 1.0, 0.85};
  double tau0[n * n] = {0}, nu[n * n] = {0}, beta[n * n] = {0};
  for (int i = 0; i < n; ++i)
    for (int b = 0; b <= i; ++b) { tau0[i * n + b] = 0.5; nu[i * n + b] = 2.0; beta[i * n + b] = 0.02; }
  tendyn_transmission* t = NULL;
  CHECK(tendyn_transmission_create(n, rm, idle, rd, ratio, eta, NULL, tau0, nu, beta, &t) == TENDYN_OK);
  CHECK(tendyn_transmission_size(t) == n);

  const double q[n] = {0.3, -0.2, 0.7};
  double qm[n], q2[n];
  CHECK(tendyn_motor_from_joint(t, q, qm) == TENDYN_OK);
  CHECK(tendyn_joint_from_motor(t, qm, q2) == TENDYN_OK);
  for (int i = 0; i < n; ++i) CHECK(fabs(q[i] - q2[i]) < 1e-12);

  const double tj[n] = {1.0, -0.5, 0.25}, qd[n] = {0.4, -0.3, 0.8};
  double cm[n], tj2[n];
  CHECK(tendyn_motor_torque_feedforward(t, tj, qd, cm) == TENDYN_OK);
  CHECK(tendyn_joint_torque_forward(t, cm, qd, tj2) == TENDYN_OK);
  for (int i = 0; i < n; ++i) CHECK(fabs(tj[i] - tj2[i]) < 1e-12);

  const double bad[n] = {NAN, 0, 0};
  CHECK(tendyn_motor_torque_feedforward(t, bad, qd, cm) == TENDYN_NON_FINITE_INPUT);
  CHECK(tendyn_joint_from_motor(NULL, qm, q2) == TENDYN_NULL_ARGUMENT);
  tendyn_transmission_destroy(t);

  const double rd0[n] = {0.04, 0.0, 0.03}; /* zero driven radius: singular routing */
  tendyn_transmission* s = NULL;
  CHECK(tendyn_transmission_create(n, rm, idle, rd0, ratio, eta, NULL, NULL, NULL, NULL, &s) == TENDYN_INVALID_MODEL);
  CHECK(s == NULL);
  printf("C ABI: all checks passed\n");
  return 0;
}

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
  /* Physics through the C ABI, by hand (S0 eqs. 9-12, ERRATA). One joint, r_m = 10 mm, R = 50 mm,
   * tau0 = 1.5 N, nu = 10 N s/m: 2 N m at the joint is 40 N at the pulley; at qd = +2 rad/s (Sdot = 0.1 m/s)
   * the motor must give 40 + 1.5 + 1 = 42.5 N (C_m = 0.425 N m), at qd = -2 (back-driven) 40 - 2.5 = 37.5 N. */
  {
    const double rm1[1] = {0.01}, idle1[1] = {0}, rd1[1] = {0.05}, one[1] = {1.0}, t01[1] = {1.5}, nu1[1] = {10.0};
    tendyn_transmission* u = NULL;
    CHECK(tendyn_transmission_create(1, rm1, idle1, rd1, one, NULL, NULL, t01, nu1, NULL, &u) == TENDYN_OK);
    const double tau1[1] = {2.0}, up[1] = {2.0}, down[1] = {-2.0};
    double c1[1];
    CHECK(tendyn_motor_torque_feedforward(u, tau1, up, c1) == TENDYN_OK);
    CHECK(fabs(c1[0] - 0.425) < 1e-12);
    CHECK(tendyn_motor_torque_feedforward(u, tau1, down, c1) == TENDYN_OK);
    CHECK(fabs(c1[0] - 0.375) < 1e-12);
    tendyn_transmission_destroy(u);
    /* reducer n = 8, eta_d = 0.9 (eta_i = 8/9), r_m = 8 mm, pulley 40 mm: 1 N m driving needs
     * 0.2/(8*0.9) N m, back-driven 0.2*(8/9)/8 N m at the motor */
    const double rm2[1] = {0.008}, rd2[1] = {0.04}, n8[1] = {8.0}, eta9[1] = {0.9}, tj1[1] = {1.0};
    CHECK(tendyn_transmission_create(1, rm2, idle1, rd2, n8, eta9, NULL, NULL, NULL, NULL, &u) == TENDYN_OK);
    CHECK(tendyn_motor_torque_feedforward(u, tj1, up, c1) == TENDYN_OK);
    CHECK(fabs(c1[0] - 0.2 / (8 * 0.9)) < 1e-14);
    CHECK(tendyn_motor_torque_feedforward(u, tj1, down, c1) == TENDYN_OK);
    CHECK(fabs(c1[0] - 0.2 * (8.0 / 9.0) / 8) < 1e-14);
    double back[1];
    CHECK(tendyn_joint_torque_forward(u, c1, down, back) == TENDYN_OK);
    CHECK(fabs(back[0] - 1.0) < 1e-12);
    tendyn_transmission_destroy(u);
  }
  printf("C ABI: all checks passed\n");
  return 0;
}

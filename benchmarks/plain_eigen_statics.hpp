// Benchmark baseline (not part of the library): the feedforward statics with losses written plainly with
// Eigen, the way a careful engineer would write it without tuning: dynamic-size matrices, temporaries
// per call, the branch velocities by the recursion Ṡ_b = Ṡ_{b−1} − K_{i,b−1} q̇_{b−1}.
// Same physics as include/tendyn/losses.hpp motor_torque_feedforward (S0 eqs. 4, 6, 9–12, corrected:
// ERRATA), without bearings (the timers refuse a model that has any). Used by feedforward_timer.cpp and
// compensator_timer.cpp; checked against the core there before anything is timed.
#pragma once

#include <cmath>

#include <Eigen/Dense>

#include "tendyn/routing.hpp"

namespace bench {

struct PlainEigenStatics {
  int n = 0;
  Eigen::MatrixXd K, tau0, nu, beta;
  Eigen::VectorXd r_m, r_d, ratio, eta;

  explicit PlainEigenStatics(const tendyn::TransmissionModel& t)
      : n(t.n), K(t.K), tau0(t.tau0), nu(t.nu), beta(t.beta), r_m(t.motor_radius), r_d(t.driven_radius),
        ratio(t.reducer_ratio), eta(t.reducer_efficiency) {}

  /// True when the model has bearings (this baseline leaves them out).
  static bool has_bearings(const tendyn::TransmissionModel& t) { return t.bearing_count.cwiseAbs().sum() > 0.0; }

  /// Motor-side tension of a sliding branch from its joint-side tension x (S0 eq. 11, corrected).
  static double upstream(double x, double sdot, double a, double b, double nu_) {
    const double s = sdot > 0 ? 1.0 : -1.0, ax = std::abs(x), sb = s * b, c = x + s * a + nu_ * sdot;
    if (c < -ax * (1 + sb)) return c / (1 + sb);
    if (c <= ax * (1 - sb)) return c + sb * ax;
    return c / (1 - sb);
  }

  /// Motor torques C_m [N·m] for joint torques tau [N·m] at joint velocity qd [rad/s].
  Eigen::VectorXd feedforward(const Eigen::VectorXd& tau, const Eigen::VectorXd& qd) const {
    const Eigen::VectorXd qdm = (K * qd).cwiseQuotient(r_m);
    Eigen::MatrixXd Sdot = Eigen::MatrixXd::Zero(n, n), T = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) {
      Sdot(i, 0) = r_m(i) * qdm(i);
      for (int b = 1; b <= i; ++b) Sdot(i, b) = Sdot(i, b - 1) - K(i, b - 1) * qd(b - 1);
    }
    Eigen::VectorXd cm(n);
    for (int i = n - 1; i >= 0; --i) {
      double own = tau(i);
      for (int k = i + 1; k < n; ++k) own -= K(k, i) * T(k, i);
      const double p = own * qd(i);
      double pulley = own / ratio(i);
      if (p > 0) pulley = own / (eta(i) * ratio(i));
      else if (p < 0) pulley = eta(i) <= 0.5 ? 0.0 : (2 * eta(i) - 1) / eta(i) * own / ratio(i);
      double t = pulley / r_d(i);
      T(i, i) = t;
      for (int b = i; b >= 0; --b) {
        if (Sdot(i, b) != 0) t = upstream(t, Sdot(i, b), tau0(i, b), beta(i, b), nu(i, b));
        if (b > 0) T(i, b - 1) = t;
      }
      cm(i) = r_m(i) * t;
    }
    return cm;
  }
};

}  // namespace bench

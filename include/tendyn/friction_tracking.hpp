// tendyn — online friction tracking in the compensator: recursive least squares with forgetting on two scales
// per transmission, one for the constant losses τ_0 (the motor's C_m0) and one for the viscous losses ν.
//
// Friction drifts with temperature, wear and cable pretension (S0 and S2 under-compensate for it, C46). The
// compensator's model gives, at the current state, the friction part of each motor torque split in three:
//     C_c,i  from τ_0 alone (the model with ν = β = 0, η_d = 1, no bearings),
//     C_v,i = C_f,i − C_f,i|ν=0  from ν,
//     C_l,i = C_f,i|ν=0 − C_c,i  the load-dependent losses (β, η_d, bearings: tension times a coefficient)
// (all with the statics with losses of losses.hpp, S0 eqs. 4, 6, 9–12, corrected: ERRATA). The tracker
// estimates per transmission θ_i = (σ_c,i, σ_v,i) in
//     y_i − C_l,i = σ_c,i C_c,i + σ_v,i C_v,i,      y_i = C_m,i − R_m K⁻ᵀ g(q) |_i
// (y: the motor torque applied in the last period less the lossless gravity torque; in quasi-static motion
// without an external force this is the friction the motors overcame, the rest of the command being the
// outer controller's pull against it), so the tracked C_m0,i is σ_c,i times the identified one and ν σ_v,i.
// The load-dependent losses are held at the model's values, not scaled with C_m0: a self-test's cable tension
// is the pretension plus a gravity load that changes little, so a third scale on them is not identifiable
// (measured on the L-EXOS self-test: a free σ_β ran into its bounds), and lumping them into σ_c biased it by
// their share times the drift (7.7 % on L-EXOS transmission 2, where they are half the constant losses).
// Recursive least squares with forgetting λ (memory ≈ T / (1 − λ) seconds):
//     k = P φ / (λ + φᵀ P φ),  θ ← clamp(θ + k (y − φᵀ θ), [σ_min, σ_max]),  P ← (P − k φᵀ P) / λ,
// on the regression normalised by |φ| (P dimensionless), with P's trace held below p_max (no wind-up). Excitation-aware: no update when the
// caller says an unknown force acts (a hand on the handle: data.tracking_active = false), below velocity_min
// (near rest the friction is static and its sign unknown), above acceleration_max (inertia would be taken for
// friction), or when the regressor carries no information (|φ| below 1e-9 N·m). The compensator then commands
// k w (C_l + σ_c C_c + σ_v C_v) in place of k w C_f. Fixed cost per cycle: two more statics-with-losses
// evaluations and 2×2 updates; no allocation, no exception, Status codes.
#pragma once

#include "tendyn/losses.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Core>

namespace tendyn {

/// Settings of the friction tracker.
struct FrictionTrackingModel {
  bool enabled = false;           ///< tracking on (off: the compensator uses the model as identified)
  double forgetting = 0.9998;     ///< λ [-] in (0.9, 1]: memory T / (1 − λ) (5 s at 1 kHz). The estimate lags a
                                  ///< drift by about the memory: at ±30 % over 10 min (0.31 %/s at most) 10 s
                                  ///< lagged 3 %, 5 s lags 1.6 % (L-EXOS self-test), the noise still averaged
  double velocity_min = 2.0;      ///< no update below this motor speed [rad/s]
  double acceleration_max = 10.0; ///< no update above this motor acceleration [rad/s²] (quasi-static only)
  double scale_min = 0.2;         ///< bounds of both scales σ [-]
  double scale_max = 3.0;
  double covariance_max = 1.0;    ///< bound on trace(P) [-] (anti-wind-up), also the initial P = p_max / 2 · I

  std::string first_issue() const {
    if (!enabled) return std::string();
    if (!(forgetting > 0.9 && forgetting <= 1.0))
      return "tracking.forgetting = " + format_double(forgetting) + ": must be in (0.9, 1]";
    if (!(velocity_min > 0.0 && std::isfinite(velocity_min)))
      return "tracking.velocity_min = " + format_double(velocity_min) + ": must be finite and > 0 [rad/s]";
    if (!(acceleration_max > 0.0 && std::isfinite(acceleration_max)))
      return "tracking.acceleration_max = " + format_double(acceleration_max) + ": must be finite and > 0 [rad/s²]";
    if (!(scale_min >= 0.0 && scale_max > scale_min && std::isfinite(scale_max)))
      return "tracking.scale_min / scale_max = " + format_double(scale_min) + " / " + format_double(scale_max) +
             ": need 0 <= scale_min < scale_max, finite";
    if (!(scale_min <= 1.0 && scale_max >= 1.0))
      return "tracking.scale_min / scale_max: the identified model (scale 1) must lie inside";
    if (!(covariance_max > 0.0 && std::isfinite(covariance_max)))
      return "tracking.covariance_max = " + format_double(covariance_max) + ": must be finite and > 0";

    return std::string();
  }
};

/// The transmission `tm` with τ_0 alone: ν = β = 0, η_d = 1, no bearings (C_c of the header).
inline TransmissionModel tau0_only_transmission(TransmissionModel tm) {
  tm.nu.setZero();
  tm.beta.setZero();
  tm.reducer_efficiency.setOnes();
  tm.bearing_count.setZero();
  return tm;
}

/// The transmission `tm` with ν = 0 (C_c + C_l of the header).
inline TransmissionModel no_viscous_transmission(TransmissionModel tm) {
  tm.nu.setZero();
  return tm;
}

/// State of the tracker (preallocated for n transmissions).
struct FrictionTrackingData {
  TransmissionModel constant_model;  ///< the compensator's transmission with ν = 0 (built at setup)
  TransmissionData constant_data;
  TransmissionModel tau0_model;      ///< the compensator's transmission with τ_0 alone (built at setup)
  TransmissionData tau0_data;
  Eigen::VectorXd scale_constant;    ///< σ_c,i [-]
  Eigen::VectorXd scale_viscous;     ///< σ_v,i [-]
  Eigen::MatrixXd covariance;        ///< (n, 4): P_i row-major (p00 p01 p10 p11)
  Eigen::VectorXd friction_constant; ///< C_c,i of this cycle [N·m]
  Eigen::VectorXd friction_viscous;  ///< C_v,i of this cycle [N·m]
  Eigen::VectorXd friction_load;     ///< C_l,i of this cycle: load-dependent losses, held at the model [N·m]
  Eigen::VectorXd regressor_prev;    ///< (3n): C_c, C_v, C_l of the last cycle [N·m]
  Eigen::VectorXd gravity_motor_prev;///< R_m K⁻ᵀ g(q) of the last cycle [N·m]
  Eigen::VectorXd torque_motor_prev; ///< C_m commanded in the last cycle [N·m]
  Eigen::VectorXd velocity_prev;     ///< motor velocity of the last cycle [rad/s]
  Eigen::VectorXd acceleration;      ///< filtered motor acceleration [rad/s²]
  Eigen::VectorXd residual;          ///< y − φᵀθ of the last update [N·m] (0 without an update)
  Eigen::VectorXi updates;           ///< updates per transmission since reset
  bool has_prev = false;
  double covariance_initial = 0.5;   ///< P_i = covariance_initial · I after reset (p_max / 2)

  FrictionTrackingData() = default;
  FrictionTrackingData(const TransmissionModel& tm, const FrictionTrackingModel& fm)
      : constant_model(no_viscous_transmission(tm)), constant_data(constant_model), tau0_model(tau0_only_transmission(tm)),
        tau0_data(tau0_model) {
    const int n = tm.n;
    scale_constant = Eigen::VectorXd::Ones(n);
    scale_viscous = Eigen::VectorXd::Ones(n);
    covariance = Eigen::MatrixXd::Zero(n, 4);
    friction_constant = friction_viscous = friction_load = Eigen::VectorXd::Zero(n);
    regressor_prev = Eigen::VectorXd::Zero(3 * n);
    gravity_motor_prev = torque_motor_prev = velocity_prev = acceleration = residual = Eigen::VectorXd::Zero(n);
    updates = Eigen::VectorXi::Zero(n);
    covariance_initial = 0.5 * fm.covariance_max;
    reset();
  }

  /// Back to the identified model (scales 1) with the initial covariance.
  void reset() {
    scale_constant.setOnes();
    scale_viscous.setOnes();
    for (int i = 0; i < covariance.rows(); ++i) {
      covariance(i, 0) = covariance(i, 3) = covariance_initial;
      covariance(i, 1) = covariance(i, 2) = 0.0;
    }
    acceleration.setZero();
    residual.setZero();
    updates.setZero();
    has_prev = false;
  }
};

/// One RLS update of transmission i with regressor (φ_c, φ_v) [N·m] and measurement y [N·m] (θ, P bounded).
/// The regression is normalised by |φ_c| + |φ_v| (both sides), so P is dimensionless and the same settings
/// serve motors whose friction differs by orders of magnitude.
inline void friction_tracking_update(const FrictionTrackingModel& m, FrictionTrackingData& d, int i, double phi_c,
                                     double phi_v, double y) {
  const double norm = std::abs(phi_c) + std::abs(phi_v);
  if (!(norm > 0.0)) return;
  phi_c /= norm, phi_v /= norm, y /= norm;
  double p00 = d.covariance(i, 0), p01 = d.covariance(i, 1), p10 = d.covariance(i, 2), p11 = d.covariance(i, 3);
  const double pp0 = p00 * phi_c + p01 * phi_v, pp1 = p10 * phi_c + p11 * phi_v;   // P φ
  const double denom = m.forgetting + phi_c * pp0 + phi_v * pp1;
  const double k0 = pp0 / denom, k1 = pp1 / denom;
  const double e = y - (phi_c * d.scale_constant(i) + phi_v * d.scale_viscous(i));
  d.residual(i) = e * norm;
  d.scale_constant(i) = std::clamp(d.scale_constant(i) + k0 * e, m.scale_min, m.scale_max);
  d.scale_viscous(i) = std::clamp(d.scale_viscous(i) + k1 * e, m.scale_min, m.scale_max);
  const double q0 = phi_c * p00 + phi_v * p10, q1 = phi_c * p01 + phi_v * p11;     // φᵀ P
  p00 = (p00 - k0 * q0) / m.forgetting;
  p01 = (p01 - k0 * q1) / m.forgetting;
  p10 = (p10 - k1 * q0) / m.forgetting;
  p11 = (p11 - k1 * q1) / m.forgetting;
  const double trace = p00 + p11;
  if (trace > m.covariance_max) {
    const double s = m.covariance_max / trace;
    p00 *= s, p01 *= s, p10 *= s, p11 *= s;
  }
  d.covariance(i, 0) = p00, d.covariance(i, 1) = 0.5 * (p01 + p10), d.covariance(i, 2) = 0.5 * (p01 + p10);
  d.covariance(i, 3) = p11;
  ++d.updates(i);
}

}  // namespace tendyn

// tendyn — real-time compensator: gravity + transmission losses from motor encoders (S0 §IV-B, C10, C46).
//
// One cycle (S0 Fig. 6, feedforward β(q̄) = friction + gravity):
//   1. velocity from the encoders: a first-order filtered difference at the control rate,
//        q̇_m ← q̇_m + α ((q_m − q_m,prev)/T − q̇_m),  α = 1 − exp(−2π f_c T)  (f_c in Hz, 0 = no filter);
//   2. joint state through the transmission, q = K⁻¹ R_m q_m, q̇ = K⁻¹ R_m q̇_m (S0 eqs. 1–2, corrected: ERRATA);
//   3. gravity g(q) from the chain (chain.hpp, no Pinocchio), end-effector position and Jacobian;
//   4. joint torques to deliver τ = τ_wanted + g(q) (or Jᵀ F + g(q) for an end-effector force);
//   5. motor torques with the statics with losses of losses.hpp (motor_torque_feedforward: the
//      Newton–Euler-like recursion of S0 eqs. 4, 6, 9–12, corrected: ERRATA; direction of power flow
//      from the sign of torque · velocity), split into the lossless part C₀ = R_m K⁻ᵀ τ and the
//      friction part C_f = C_ff − C₀;
//   6. output C_m = C₀ + k · w_i · C_f,i with the under-estimation factor k ∈ [0, 1.5] (C46: friction
//      compensated with under-estimated coefficients) and w_i = min(1, |q̇_m,i| / v_band) fading the
//      friction feedforward linearly to zero inside the velocity band (no chatter at rest; static friction
//      is not compensated, S0 §III);
//   6b. with model.tracking enabled, C_f is split into its τ_0, ν and load-dependent parts, the first two scaled by the
//      scales tracked online (friction_tracking.hpp: RLS with forgetting), which are updated from the last
//      cycle's command first;
//   7. with model.passivity enabled: the passivity observer at each motor port and the controller's damping
//      torque τ_pc added to C_m (passivity.hpp: Hannaford & Ryu's PO/PC against a certified dissipation bound).
// The compute time of the cycle is reported in the output (data.compute_time [s]), as Ruckig does.
// Model / Data convention; no allocation, no exception on the real-time path; every call returns a Status.
#pragma once

#include "tendyn/chain.hpp"
#include "tendyn/friction_tracking.hpp"
#include "tendyn/losses.hpp"
#include "tendyn/passivity.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <string>

#include <Eigen/Core>

namespace tendyn {

/// Where a loss term of the compensator's transmission comes from. One loss model at a time: friction
/// identified at the motor (S0 eq. 13, constant-velocity tests) already contains every loss the motor saw —
/// branch τ0 and ν, bearings, β, the reducer — so identified terms never stack on the device file's.
enum class LossSource : int {
  Device = 0,      ///< the device file's nominal value
  Identified = 1,  ///< identified (FRICTION.json, decomposed over the branches)
  None = 2,        ///< absent: the term is lossless (zero, or η_d = 1)
};
/// The loss terms whose source is recorded, in the order of CompensatorModel::loss_source.
inline constexpr int loss_term_count = 5;
inline constexpr const char* loss_terms[loss_term_count] = {"tau0", "nu", "beta", "bearings", "reducer_efficiency"};
inline constexpr const char* loss_source_names[3] = {"device", "identified", "none"};

/// The first contradiction between the recorded sources and the transmission's values, or "" (setup time):
/// device and identified terms mixed, or a term recorded as absent that carries a loss.
inline std::string loss_sources_issue(const TransmissionModel& t, const std::array<LossSource, loss_term_count>& src) {
  int identified = -1, device = -1;
  for (int k = 0; k < loss_term_count; ++k) {
    if (src[k] == LossSource::Identified && identified < 0) identified = k;
    if (src[k] == LossSource::Device && device < 0) device = k;
  }
  if (identified >= 0 && device >= 0)
    return std::string("losses: ") + loss_terms[identified] + " is identified but " + loss_terms[device] +
           " comes from the device file: one loss model at a time (friction identified at the motor already "
           "contains it; record it as none)";
  auto nonzero = [](const Eigen::MatrixXd& a) { return (a.array() != 0.0).any(); };
  const bool lossy[loss_term_count] = {nonzero(t.tau0), nonzero(t.nu), nonzero(t.beta), nonzero(t.bearing_count),
                                       (t.reducer_efficiency.array() != 1.0).any()};
  for (int k = 0; k < loss_term_count; ++k)
    if (src[k] == LossSource::None && lossy[k])
      return std::string("losses: ") + loss_terms[k] + " is recorded as none but the transmission has nonzero " +
             loss_terms[k] + (k == 4 ? " (η_d != 1)" : "");
  return std::string();
}

/// Immutable compensator model: the transmissions, the chain they drive and the settings.
struct CompensatorModel {
  TransmissionModel transmission;  ///< routing and identified losses (motor_torque_feedforward)
  ChainModel chain;                ///< kinematics and gravity of the driven chain
  double underestimation = 1.0;    ///< k [-] in [0, 1.5], scales the friction part (0 = gravity only)
  double velocity_band = 0.0;      ///< v_band [rad/s], motor side: friction fades to 0 below it (0 = off)
  double velocity_cutoff_hz = 0.0; ///< cut-off of the first-order velocity filter [Hz] (0 = raw difference)
  double rate_hz = 1000.0;         ///< control rate [Hz] (one cycle per period)
  PassivityModel passivity;        ///< passivity observer + controller at the motor ports (off by default)
  FrictionTrackingModel tracking;  ///< online friction tracking (off by default)
  std::string device;              ///< name of the device the model belongs to (setup-time checks only)
  /// Source of each loss term (loss_terms order): all Device for a model built from a device file alone.
  std::array<LossSource, loss_term_count> loss_source{};
  std::string friction_source;     ///< the identified friction's origin (file name), "" if none (information)

  /// The first problem as text naming the field, or nullptr when usable. Allocates only to describe a
  /// transmission issue (setup time).
  std::string first_issue() const {
    ValidationIssue is;
    if (transmission.n < 1) return "transmission: missing (n = 0)";
    if (transmission.first_issue(&is)) return describe(is);
    int j = -1;
    if (const char* what = chain.first_issue(&j))
      return std::string("chain.") + what + (j >= 0 ? " (joint " + std::to_string(j) + ")" : std::string());
    if (chain.n_active() != transmission.n)
      return (chain.active_map.size() ? "chain.active_map has " + std::to_string(chain.n_active()) + " columns"
                                      : "chain.n = " + std::to_string(chain.n)) +
             ": must equal the number of transmissions (" + std::to_string(transmission.n) +
             "): the chain belongs to another device";
    if (!(underestimation >= 0.0 && underestimation <= 1.5))
      return "underestimation = " + format_double(underestimation) + ": must be in [0, 1.5]";
    if (!(velocity_band >= 0.0 && std::isfinite(velocity_band)))
      return "velocity_band = " + format_double(velocity_band) + ": must be finite and >= 0 [rad/s]";
    if (!(rate_hz >= 100.0 && rate_hz <= 100000.0))
      return "rate_hz = " + format_double(rate_hz) + ": must be in [100, 100000] Hz";
    if (!(velocity_cutoff_hz >= 0.0 && velocity_cutoff_hz < 0.5 * rate_hz))
      return "velocity_cutoff_hz = " + format_double(velocity_cutoff_hz) + ": must be in [0, rate_hz / 2)";
    if (std::string p = passivity.first_issue(transmission.n); !p.empty()) return p;
    if (std::string t = tracking.first_issue(); !t.empty()) return t;
    return loss_sources_issue(transmission, loss_source);
  }
  Status validate() const { return first_issue().empty() ? Status::Ok : Status::InvalidModel; }

  /// Control period T = 1 / rate_hz [s].
  double period() const { return 1.0 / rate_hz; }
  /// Filter gain α = 1 − exp(−2π f_c T) (1 without a filter).
  double filter_gain() const {
    return velocity_cutoff_hz > 0.0 ? 1.0 - std::exp(-6.283185307179586 * velocity_cutoff_hz * period()) : 1.0;
  }
};

/// Preallocated state and outputs of the compensator.
struct CompensatorData {
  TransmissionData transmission;
  ChainData chain;
  Eigen::VectorXd q_motor;                ///< last encoder reading [rad]
  Eigen::VectorXd q_motor_prev;           ///< previous reading [rad]
  Eigen::VectorXd qd_motor;               ///< filtered motor velocity estimate [rad/s]
  Eigen::VectorXd motor_step;             ///< displacement over the last period q_m − q_m,prev [rad]
  Eigen::VectorXd q, qd;                  ///< joint position [rad] / velocity [rad/s] estimates
  Eigen::VectorXd torque_joint_wanted;    ///< joint torques wanted on top of gravity [N·m]
  Eigen::VectorXd torque_joint;           ///< joint torques delivered: wanted + gravity [N·m]
  Eigen::VectorXd torque_motor_lossless;  ///< C₀ = R_m K⁻ᵀ τ [N·m]
  Eigen::VectorXd torque_motor_friction;  ///< k w C_f, the friction part commanded [N·m]
  Eigen::VectorXd friction_weight;        ///< w_i in [0, 1] (velocity band)
  Eigen::VectorXd torque_motor;           ///< C_m to command [N·m]
  PassivityData passivity;                ///< observer energy and controller torque per motor
  FrictionTrackingData tracking;          ///< tracked friction scales and the RLS state
  bool tracking_active = true;            ///< the caller's gate: false while an unknown force (a hand) acts
  bool first = true;                      ///< no previous reading yet (velocity 0)
  long cycles = 0;
  double compute_time = 0.0;              ///< wall time of the last cycle [s]
  double filter_alpha = 1.0;              ///< model.filter_gain(), computed once

  explicit CompensatorData(const CompensatorModel& m)
      : transmission(m.transmission), chain(m.chain),
        q_motor(Eigen::VectorXd::Zero(m.transmission.n)), q_motor_prev(Eigen::VectorXd::Zero(m.transmission.n)),
        qd_motor(Eigen::VectorXd::Zero(m.transmission.n)), motor_step(Eigen::VectorXd::Zero(m.transmission.n)),
        q(Eigen::VectorXd::Zero(m.transmission.n)),
        qd(Eigen::VectorXd::Zero(m.transmission.n)),
        torque_joint_wanted(Eigen::VectorXd::Zero(m.transmission.n)), torque_joint(Eigen::VectorXd::Zero(m.transmission.n)),
        torque_motor_lossless(Eigen::VectorXd::Zero(m.transmission.n)),
        torque_motor_friction(Eigen::VectorXd::Zero(m.transmission.n)),
        friction_weight(Eigen::VectorXd::Zero(m.transmission.n)),
        torque_motor(Eigen::VectorXd::Zero(m.transmission.n)), passivity(m.transmission.n),
        tracking(m.transmission, m.tracking), filter_alpha(m.filter_gain()) {}

  /// Forget the velocity history and the observed energy (the next reading starts at rest); keep what the
  /// friction tracker has learnt.
  void restart() {
    first = true;
    cycles = 0;
    qd_motor.setZero();
    motor_step.setZero();
    qd.setZero();
    passivity.reset();
    tracking.has_prev = false;
  }
  /// restart() and back to the identified friction (tracked scales 1).
  void reset() {
    restart();
    tracking.reset();
  }
};

/// Steps 1–3: read the encoders, estimate velocity, joint state, frames, end effector and gravity.
/// @param q_motor   motor encoder positions (n) [rad]
/// @param jacobian  also compute the end-effector Jacobian (data.chain.ee_jacobian_active, actuated joints); the wanted-joint-torque
///                  cycle does not need it
template <class V>
inline Status compensator_sense(const CompensatorModel& m, CompensatorData& d, const V& q_motor,
                                bool jacobian = true) {
  const int n = m.transmission.n;
  if (q_motor.size() != n) return Status::SizeMismatch;
  if (!all_finite(q_motor)) return Status::NonFiniteInput;
  for (int i = 0; i < n; ++i) d.q_motor(i) = q_motor(i);
  if (d.first) {
    d.q_motor_prev = d.q_motor;
    d.qd_motor.setZero();
    d.first = false;
  }
  const double alpha = d.filter_alpha, rate = m.rate_hz;
  for (int i = 0; i < n; ++i) {
    d.motor_step(i) = d.q_motor(i) - d.q_motor_prev(i);
    d.qd_motor(i) += alpha * (d.motor_step(i) * rate - d.qd_motor(i));
    d.q_motor_prev(i) = d.q_motor(i);
  }
  Status s = joint_from_motor(m.transmission, d.transmission, d.q_motor);
  if (is_error(s)) return s;
  d.q = d.transmission.q;
  d.qd.noalias() = m.transmission.joint_from_motor_position.lazyProduct(d.qd_motor);
  return chain_active(m.chain, d.chain, d.q, jacobian);
}

namespace detail {
/// Tracker step of compensator_command (friction_tracking.hpp), after the full feedforward of this cycle is in
/// d.transmission.torque_motor: acceleration estimate, RLS update from the last cycle, this cycle's split.
inline Status friction_tracking_step(const CompensatorModel& m, CompensatorData& d) {
  const int n = m.transmission.n;
  FrictionTrackingData& t = d.tracking;
  const FrictionTrackingModel& fm = m.tracking;
  for (int i = 0; i < n; ++i) {
    const double a_raw = t.has_prev ? (d.qd_motor(i) - t.velocity_prev(i)) * m.rate_hz : 0.0;
    t.acceleration(i) += d.filter_alpha * (a_raw - t.acceleration(i));
    t.residual(i) = 0.0;
    if (!t.has_prev || !d.tracking_active) continue;
    const double phi_c = t.regressor_prev(i), phi_v = t.regressor_prev(n + i);
    if (std::abs(t.velocity_prev(i)) < fm.velocity_min || std::abs(t.acceleration(i)) > fm.acceleration_max ||
        std::abs(phi_c) + std::abs(phi_v) < 1e-9)
      continue;  // no information: near rest, accelerating, or nothing to scale
    friction_tracking_update(fm, t, i, phi_c, phi_v,
                             t.torque_motor_prev(i) - t.gravity_motor_prev(i) - t.regressor_prev(2 * n + i));
  }
  Status s = motor_torque_feedforward(t.constant_model, t.constant_data, d.torque_joint, d.qd);
  if (is_error(s)) return s;
  s = worst(s, motor_torque_feedforward(t.tau0_model, t.tau0_data, d.torque_joint, d.qd));
  if (is_error(s)) return s;
  for (int i = 0; i < n; ++i) {
    t.friction_constant(i) = t.tau0_data.torque_motor(i) - d.torque_motor_lossless(i);
    t.friction_viscous(i) = d.transmission.torque_motor(i) - t.constant_data.torque_motor(i);
    t.friction_load(i) = t.constant_data.torque_motor(i) - t.tau0_data.torque_motor(i);
    t.regressor_prev(i) = t.friction_constant(i);
    t.regressor_prev(n + i) = t.friction_viscous(i);
    t.regressor_prev(2 * n + i) = t.friction_load(i);
  }
  return s;
}
}  // namespace detail

/// Steps 4–6: motor torques that deliver `torque_joint_wanted` plus gravity, with the losses covered.
/// Call compensator_sense first in the same cycle. Returns Ok, SelfLocked (flag) or an error.
/// @param torque_joint_wanted  joint torques to deliver on top of gravity (n) [N·m]
template <class V>
inline Status compensator_command(const CompensatorModel& m, CompensatorData& d, const V& torque_joint_wanted) {
  const int n = m.transmission.n;
  if (torque_joint_wanted.size() != n) return Status::SizeMismatch;
  if (!all_finite(torque_joint_wanted)) return Status::NonFiniteInput;
  for (int i = 0; i < n; ++i) {
    d.torque_joint_wanted(i) = torque_joint_wanted(i);
    d.torque_joint(i) = torque_joint_wanted(i) + d.chain.gravity_active(i);
  }
  d.torque_motor_lossless.noalias() = m.transmission.motor_from_joint_torque.lazyProduct(d.torque_joint);
  Status s = Status::Ok;
  const bool tracking = m.tracking.enabled;
  if (m.underestimation > 0.0 || tracking) {
    s = motor_torque_feedforward(m.transmission, d.transmission, d.torque_joint, d.qd);
    if (is_error(s)) return s;
  }
  if (tracking) {
    s = worst(s, detail::friction_tracking_step(m, d));
    if (is_error(s)) return s;
  }
  for (int i = 0; i < n; ++i) {
    const double v = std::abs(d.qd_motor(i));
    const double w = m.velocity_band > 0.0 ? std::min(1.0, v / m.velocity_band) : 1.0;
    d.friction_weight(i) = w;
    const double friction = tracking ? d.tracking.friction_load(i) +
                                           d.tracking.scale_constant(i) * d.tracking.friction_constant(i) +
                                           d.tracking.scale_viscous(i) * d.tracking.friction_viscous(i)
                                     : d.transmission.torque_motor(i) - d.torque_motor_lossless(i);
    d.torque_motor_friction(i) = m.underestimation > 0.0 ? m.underestimation * w * friction : 0.0;
    d.torque_motor(i) = d.torque_motor_lossless(i) + d.torque_motor_friction(i);
  }
  if (m.passivity.enabled) {
    const double T = m.period();
    for (int i = 0; i < n; ++i) {
      passivity_observe(m.passivity, d.passivity, i, d.motor_step(i), T);
      const double pc = passivity_control(m.passivity, d.passivity, i, d.qd_motor(i), T);
      d.torque_motor(i) += pc;
      d.passivity.torque_added_prev(i) = d.torque_motor_friction(i) + pc;
    }
  }
  if (tracking) {  // what the next cycle's tracker update measures against
    d.tracking.torque_motor_prev = d.torque_motor;
    d.tracking.gravity_motor_prev.noalias() = m.transmission.motor_from_joint_torque.lazyProduct(d.chain.gravity_active);
    d.tracking.velocity_prev = d.qd_motor;
    d.tracking.has_prev = true;
  }
  ++d.cycles;
  return s;
}

namespace detail {
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace detail

/// One compensator cycle: encoders + wanted joint torques → motor torques (data.torque_motor), with the
/// compute time of the cycle in data.compute_time [s].
/// @param q_motor              motor encoder positions (n) [rad]
/// @param torque_joint_wanted  joint torques to deliver on top of gravity (n) [N·m]
template <class V1, class V2>
inline Status compensator_cycle(const CompensatorModel& m, CompensatorData& d, const V1& q_motor,
                                const V2& torque_joint_wanted) {
  const auto t0 = std::chrono::steady_clock::now();
  Status s = compensator_sense(m, d, q_motor, false);
  if (!is_error(s)) s = compensator_command(m, d, torque_joint_wanted);
  d.compute_time = detail::seconds_since(t0);
  return s;
}

/// One cycle for a wanted end-effector force F [N] (base frame): τ_wanted = J(q)ᵀ F.
/// @param force_ee  (3) end-effector force to display [N]
template <class V1, class V2>
inline Status compensator_cycle_force(const CompensatorModel& m, CompensatorData& d, const V1& q_motor,
                                      const V2& force_ee) {
  const auto t0 = std::chrono::steady_clock::now();
  if (force_ee.size() != 3) return Status::SizeMismatch;
  if (!all_finite(force_ee)) return Status::NonFiniteInput;
  Status s = compensator_sense(m, d, q_motor);
  if (!is_error(s)) {
    const Eigen::Vector3d f(force_ee(0), force_ee(1), force_ee(2));
    d.torque_joint_wanted.noalias() = d.chain.ee_jacobian_active.transpose() * f;
    s = compensator_command(m, d, d.torque_joint_wanted);
  }
  d.compute_time = detail::seconds_since(t0);
  return s;
}

}  // namespace tendyn

// tendyn — the simulator's sensing and control (part of sim.hpp): slaved motor positions, quantised encoders,
// current noise, and the torque / joint-space PID / motor-space PID laws at the control rate with the C hook.
#pragma once

#include <algorithm>
#include <cmath>

#include "tendyn/sim_model.hpp"

namespace tendyn {

/// Motor position from the state (slaved for tendon drives).
inline void motor_state(const SimModel& m, SimData& d) {
  if (!m.slaved_motors()) return;
  const int n = m.na, nm = m.nm;
  const double* G = m.Gm.data();
  for (int i = 0; i < nm; ++i) {
    double a = 0.0, b = 0.0;
    for (int j = 0; j < n; ++j) {
      a += G[i + j * nm] * d.q(j);
      b += G[i + j * nm] * d.qd(j);
    }
    d.q_motor(i) = a;
    d.qd_motor(i) = b;
  }
}

/// Sense (encoders, current noise) and run the controller: writes torque_motor_cmd / torque_motor.
/// @param ref_q, ref_v  joint (JointPID) or motor (MotorPID) references [rad, rad/s]
/// @param ff            feedforward: motor torques (Torque, MotorPID) or joint torques (JointPID)
template <class V1, class V2, class V3>
inline void control(const SimModel& m, SimData& d, const V1& ref_q, const V2& ref_v, const V3& ff) {
  const double Tc = m.dt * m.control_decimation;
  for (int i = 0; i < m.nm; ++i) {  // quantised motor encoders
    const double counts = m.encoder_counts(i);
    const double qstep = counts > 0.0 ? 6.283185307179586 / counts : 0.0;
    d.q_motor_meas(i) = qstep > 0.0 ? qstep * std::floor(d.q_motor(i) / qstep + 0.5) : d.q_motor(i);
  }
  d.q_est.noalias() = m.joint_from_motor.lazyProduct(d.q_motor_meas);
  if (d.first_control) {
    d.q_est_prev = d.q_est;
    d.qm_meas_prev = d.q_motor_meas;
    d.first_control = false;
  }
  const double alpha = m.velocity_cutoff_hz > 0.0
                           ? 1.0 - std::exp(-6.283185307179586 * m.velocity_cutoff_hz * Tc) : 1.0;
  for (int i = 0; i < m.na; ++i) d.v_est(i) += alpha * ((d.q_est(i) - d.q_est_prev(i)) / Tc - d.v_est(i));
  for (int i = 0; i < m.nm; ++i)
    d.v_motor_est(i) += alpha * ((d.q_motor_meas(i) - d.qm_meas_prev(i)) / Tc - d.v_motor_est(i));
  d.q_est_prev = d.q_est;
  d.qm_meas_prev = d.q_motor_meas;

  switch (m.mode) {
    case ControlMode::Torque:
      for (int i = 0; i < m.nm; ++i) d.torque_motor_cmd(i) = ff(i);
      if (m.gravity_compensation) {
        d.q_tree.noalias() = m.L.lazyProduct(d.q_est);
        d.q_tree += m.c;
        pinocchio::computeGeneralizedGravity(m.body.pin, d.body.pin, d.q_tree);
        d.tmp_na.noalias() = m.L.transpose().lazyProduct(d.body.pin.g);
        d.torque_motor_cmd.noalias() += m.motor_from_joint_torque.lazyProduct(d.tmp_na);
      }
      break;
    case ControlMode::JointPID:
      for (int i = 0; i < m.na; ++i) {
        const double e = ref_q(i) - d.q_est(i);
        d.integral(i) += e * Tc;
        d.tmp_na(i) = m.kp(i) * e + m.kd(i) * (ref_v(i) - d.v_est(i)) + m.ki(i) * d.integral(i) + ff(i);
      }
      if (m.drive == DriveKind::Tendons) {  // tensions ≥ the floors (tendons.hpp), losses at ref_v if asked
        if (m.tendon_loss_compensation)
          detail::tendon_feedforward_impl(m.tendons, d.tmp_na, [&](int b) { return ref_v(b); }, d.tendon_data);
        else
          detail::tendon_feedforward_impl(m.tendons, d.tmp_na, [](int) { return 0.0; }, d.tendon_data);
        d.torque_motor_cmd = d.tendon_data.motor_torque;
      } else {
        d.torque_motor_cmd.noalias() = m.motor_from_joint_torque.lazyProduct(d.tmp_na);
      }
      break;
    case ControlMode::MotorPID:
      for (int i = 0; i < m.nm; ++i) {
        const double e = ref_q(i) - d.q_motor_meas(i);
        d.integral(i) += e * Tc;
        d.torque_motor_cmd(i) = m.kp(i) * e + m.kd(i) * (ref_v(i) - d.v_motor_est(i)) + m.ki(i) * d.integral(i) + ff(i);
      }
      break;
  }
  if (m.hook) m.hook(m.hook_user, m, d);
  for (int i = 0; i < m.nm; ++i) {
    const double lim = m.peak_torque(i);
    d.torque_motor(i) = std::max(-lim, std::min(lim, d.torque_motor_cmd(i)));
    d.torque_motor_meas(i) = d.torque_motor(i) + m.torque_constant(i) * m.current_noise(i) * d.rng.normal();
  }
}

}  // namespace tendyn

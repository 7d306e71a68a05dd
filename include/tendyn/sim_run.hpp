// tendyn — the simulator's run loop (part of sim.hpp): run() steps through per-step inputs and logs the
// state, the sensors and the commands every log_every steps into SimLog. Allocates nothing.
#pragma once

#include <Eigen/Core>

#include "tendyn/sim_model.hpp"
#include "tendyn/sim_step.hpp"

namespace tendyn {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Log channels written by run(), one row per logged sample (row-major: numpy's layout).
struct SimLog {
  Eigen::Ref<Eigen::VectorXd> time;
  Eigen::Ref<RowMatrixXd> q_motor_meas, torque_motor_meas, torque_motor_cmd, q_joint, qd_joint,
      q_motor, qd_motor;
};

/// Run n_steps with per-step inputs (rows = steps, columns = na) and log every `log_every` steps
/// (a multiple of the control decimation, so each logged measurement is fresh). A logged row holds
/// the state at the start of a step together with what the sensors read and the controller
/// commanded at that instant. The log must have ceil(n_steps / log_every) rows. Allocates nothing.
template <class Mat>
inline Status run(const SimModel& m, SimData& d, const Mat& ref_q, const Mat& ref_v, const Mat& ff,
                  const Mat& torque_ext, int log_every, SimLog& log) {
  const long n_steps = ref_q.rows();
  if (log_every < 1 || log_every % m.control_decimation != 0 || ref_v.rows() != n_steps ||
      ff.rows() != n_steps || torque_ext.rows() != n_steps || ref_q.cols() != m.n_ref() ||
      ref_v.cols() != m.n_ref() || ff.cols() != m.n_ff() || torque_ext.cols() != m.na ||
      log.time.size() != (n_steps + log_every - 1) / log_every)
    return Status::SizeMismatch;
  if (!all_finite(ref_q) || !all_finite(ref_v) || !all_finite(ff) || !all_finite(torque_ext))
    return Status::NonFiniteInput;
  if (d.step_count % m.control_decimation != 0) return Status::SizeMismatch;
  long row = 0;
  for (long s = 0; s < n_steps; ++s) {
    const bool logged = s % log_every == 0;
    if (logged) {
      motor_state(m, d);
      log.time(row) = d.time;
      log.q_joint.row(row) = d.q.transpose();
      log.qd_joint.row(row) = d.qd.transpose();
      log.q_motor.row(row) = d.q_motor.transpose();
      log.qd_motor.row(row) = d.qd_motor.transpose();
    }
    const Status st = step(m, d, ref_q.row(s).transpose(), ref_v.row(s).transpose(),
                           ff.row(s).transpose(), torque_ext.row(s).transpose());
    if (is_error(st)) return st;
    if (logged) {
      log.q_motor_meas.row(row) = d.q_motor_meas.transpose();
      log.torque_motor_meas.row(row) = d.torque_motor_meas.transpose();
      log.torque_motor_cmd.row(row) = d.torque_motor_cmd.transpose();
      ++row;
    }
  }
  return Status::Ok;
}

}  // namespace tendyn

// tendyn — transmission kinematics and lossless statics of a tendon-driven serial chain.
//
// S0 §II-A/B with the corrections of ERRATA (S0 eqs. 1–2, 5):
//   per transmission i: S_0^i = r_m^i q_m^i; S_j^i = S_{j-1}^i − r_j^i q_j (joints crossed);
//   at its driven joint q_i = S_{i-1}^i / r_i^i.  Compact form  R_m q_m = K q,
//   R_m = diag(r_m^i), K lower-triangular with K_ij = r_j^i (signed idle radius, j < i) and
//   K_ii = driven pulley radius · reducer ratio (S0 footnote 1: generalised radius).
//   Statics: τ_J = Kᵀ t, C_m = R_m t (t = cable tensions); virtual work q̇ᵀτ_J = q̇_mᵀC_m.
//
// Indices are 0-based: transmission i drives joint i and crosses joints 0…i−1. Branch b of
// transmission i (b = 0…i) is the stretch of cable just before joint b: branch 0 runs from the
// motor pulley to joint 0 on the base, branch i ends on the driven pulley of joint i.
//
// Model / Data convention: the model is immutable after construction; every call writes into a
// Data preallocated from it and allocates nothing.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "tendyn/status.hpp"

namespace tendyn {

/// Immutable description of n tendon transmissions on an n-joint serial chain.
struct TransmissionModel {
  int n = 0;                          ///< number of transmissions = number of joints
  Eigen::VectorXd motor_radius;       ///< r_m^i [m], motor pulley radius, > 0
  Eigen::MatrixXd K;                  ///< (n, n) transmission matrix [m], lower-triangular
  Eigen::VectorXd driven_radius;      ///< driven pulley radius [m] (without reducer)
  Eigen::VectorXd reducer_ratio;      ///< n_i [-], 1 when no reducer
  Eigen::VectorXd reducer_efficiency; ///< direct efficiency η_d [-] in (0, 1]
  Eigen::VectorXd pretension;         ///< cable pretension [N], loads the bearings

  // Per-branch loss parameters, (n, n), entry [i, b] for branch b ≤ i of transmission i.
  Eigen::MatrixXd tau0;   ///< constant tension loss τ_0 [N] (S0 eq. 12)
  Eigen::MatrixXd nu;     ///< viscous tension loss ν [N·s/m] (S0 eqs. 11–12)
  Eigen::MatrixXd beta;   ///< tension-proportional loss β [-] (S0 eq. 11), in [0, 1)
  // Bearings of the idle pulleys of a branch (S0 eqs. 7–8); count 0 = none.
  Eigen::MatrixXd bearing_count;   ///< number of identical bearings [-]
  Eigen::MatrixXd bearing_radius;  ///< pulley radius the cable wraps [m]
  Eigen::MatrixXd bearing_wrap;    ///< wrap angle of the cable on that pulley [rad]
  Eigen::MatrixXd bearing_alpha;   ///< static coefficient α [m] (torque per radial load)
  Eigen::MatrixXd bearing_beta;    ///< dynamic coefficient β [m]
  Eigen::MatrixXd bearing_h0;      ///< speed term below n0 [N·m]
  Eigen::MatrixXd bearing_h1;      ///< speed term coefficient above n0 [N·m·(rad/s)^(-2/3)]
  Eigen::MatrixXd bearing_n0;      ///< speed threshold [rad/s]

  // Matrices a controller needs, computed once at construction.
  Eigen::MatrixXd joint_from_motor_position;  ///< q = K⁻¹ R_m q_m
  Eigen::MatrixXd motor_from_joint_position;  ///< q_m = R_m⁻¹ K q
  Eigen::MatrixXd motor_from_joint_torque;    ///< C_m = R_m K⁻ᵀ τ_J
  Eigen::MatrixXd joint_from_motor_torque;    ///< τ_J = Kᵀ R_m⁻¹ C_m

  TransmissionModel() = default;

  /// Lossless routing: `idle` holds the signed idle radii in its strict lower part [m]
  /// (entries on and above the diagonal are ignored). Loss parameters start at zero.
  TransmissionModel(const Eigen::VectorXd& motor_radius_, const Eigen::MatrixXd& idle,
                    const Eigen::VectorXd& driven_radius_, const Eigen::VectorXd& reducer_ratio_)
      : n(static_cast<int>(motor_radius_.size())),
        motor_radius(motor_radius_),
        K(Eigen::MatrixXd::Zero(n, n)),
        driven_radius(driven_radius_),
        reducer_ratio(reducer_ratio_),
        reducer_efficiency(Eigen::VectorXd::Ones(n)),
        pretension(Eigen::VectorXd::Zero(n)) {
    for (auto* m : {&tau0, &nu, &beta, &bearing_count, &bearing_alpha, &bearing_beta, &bearing_h0,
                    &bearing_h1, &bearing_n0})
      m->setZero(n, n);
    bearing_radius.setOnes(n, n);
    bearing_wrap.setConstant(n, n, 3.141592653589793);
    if (idle.rows() != n || idle.cols() != n || driven_radius.size() != n ||
        reducer_ratio.size() != n)
      return;  // validate() reports InvalidModel
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) K(i, j) = idle(i, j);
      K(i, i) = driven_radius(i) * reducer_ratio(i);  // S0 footnote 1
    }
    update_matrices();
  }

  /// Recompute the four matrices after K or motor_radius changed (setup time; allocates).
  void update_matrices() {
    const Eigen::MatrixXd Kinv = K.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
    joint_from_motor_position = Kinv * motor_radius.asDiagonal();
    motor_from_joint_position = motor_radius.cwiseInverse().asDiagonal() * K;
    motor_from_joint_torque = motor_radius.asDiagonal() * Kinv.transpose();
    joint_from_motor_torque = K.transpose() * motor_radius.cwiseInverse().asDiagonal();
  }

  /// Ok when the routing is usable: sizes agree, K lower-triangular with a non-zero diagonal,
  /// positive radii, η_d in (0, 1], β + bearing terms < 1 (otherwise no tension can pass).
  Status validate() const;
};

/// Preallocated workspace and outputs of the transmission calls.
struct TransmissionData {
  Eigen::VectorXd q, qdot;            ///< joint position [rad], velocity [rad/s]
  Eigen::VectorXd q_motor, qdot_motor;///< motor position [rad], velocity [rad/s]
  Eigen::MatrixXd S, Sdot;            ///< branch displacement [m] / velocity [m/s], [i, b]
  Eigen::MatrixXd tension;            ///< tension at joint b after branch b [N], [i, b]
  Eigen::VectorXd tension_motor;      ///< tension leaving the motor pulley [N]
  Eigen::VectorXd torque_motor;       ///< motor torque C_m [N·m]
  Eigen::VectorXd torque_joint;       ///< joint torque τ_J [N·m]
  Eigen::MatrixXi stuck;              ///< 1 where a branch does not slide (Ṡ = 0) [i, b]
  Eigen::VectorXi self_locked;        ///< 1 where a self-locking reducer holds the load

  explicit TransmissionData(const TransmissionModel& m)
      : q(Eigen::VectorXd::Zero(m.n)), qdot(Eigen::VectorXd::Zero(m.n)),
        q_motor(Eigen::VectorXd::Zero(m.n)), qdot_motor(Eigen::VectorXd::Zero(m.n)),
        S(Eigen::MatrixXd::Zero(m.n, m.n)), Sdot(Eigen::MatrixXd::Zero(m.n, m.n)),
        tension(Eigen::MatrixXd::Zero(m.n, m.n)), tension_motor(Eigen::VectorXd::Zero(m.n)),
        torque_motor(Eigen::VectorXd::Zero(m.n)), torque_joint(Eigen::VectorXd::Zero(m.n)),
        stuck(Eigen::MatrixXi::Zero(m.n, m.n)), self_locked(Eigen::VectorXi::Zero(m.n)) {}
};

inline Status TransmissionModel::validate() const {
  if (n <= 0 || motor_radius.size() != n || K.rows() != n || K.cols() != n ||
      driven_radius.size() != n || reducer_ratio.size() != n || reducer_efficiency.size() != n ||
      pretension.size() != n || tau0.rows() != n || nu.rows() != n || beta.rows() != n)
    return Status::InvalidModel;
  for (int i = 0; i < n; ++i) {
    if (!(motor_radius(i) > 0.0) || !(driven_radius(i) > 0.0) || !(reducer_ratio(i) > 0.0))
      return Status::InvalidModel;
    if (!(reducer_efficiency(i) > 0.0 && reducer_efficiency(i) <= 1.0)) return Status::InvalidModel;
    if (K(i, i) == 0.0) return Status::InvalidModel;
    for (int j = i + 1; j < n; ++j)
      if (K(i, j) != 0.0) return Status::InvalidModel;
  }
  if (!all_finite(K) || !all_finite(motor_radius)) return Status::InvalidModel;
  for (int i = 0; i < n; ++i)
    for (int b = 0; b <= i; ++b) {
      if (!(tau0(i, b) >= 0.0) || !(nu(i, b) >= 0.0) || !(beta(i, b) >= 0.0) ||
          !(bearing_count(i, b) >= 0.0) || !(bearing_radius(i, b) > 0.0))
        return Status::InvalidModel;
      // Tension-proportional friction must stay below 1, or no tension passes the branch.
      const double k = 2.0 * std::sin(0.5 * bearing_wrap(i, b)) / bearing_radius(i, b);
      const double coef = std::max(bearing_alpha(i, b), bearing_beta(i, b));
      if (!(beta(i, b) + bearing_count(i, b) * coef * k < 1.0)) return Status::InvalidModel;
    }
  return Status::Ok;
}

// ---- kinematics (S0 eqs. 1–2, corrected) ---------------------------------------------------

/// q = K⁻¹ R_m q_m by forward substitution (the recursion of S0 eq. 2, driven joint by driven joint).
/// Writes data.q_motor (copy of the input) and data.q.
template <class VecIn>
inline Status joint_from_motor(const TransmissionModel& m, TransmissionData& d, const VecIn& q_motor) {
  if (q_motor.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(q_motor)) return Status::NonFiniteInput;
  for (int i = 0; i < m.n; ++i) {
    double s = m.motor_radius(i) * q_motor(i);  // S_0^i
    for (int j = 0; j < i; ++j) s -= m.K(i, j) * d.q(j);
    d.q_motor(i) = q_motor(i);
    d.q(i) = s / m.K(i, i);
  }
  return Status::Ok;
}

/// q_m = R_m⁻¹ K q. Writes data.q (copy) and data.q_motor.
template <class VecIn>
inline Status motor_from_joint(const TransmissionModel& m, TransmissionData& d, const VecIn& q) {
  if (q.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(q)) return Status::NonFiniteInput;
  for (int i = 0; i < m.n; ++i) d.q(i) = q(i);
  for (int i = 0; i < m.n; ++i) {
    double s = 0.0;
    for (int j = 0; j <= i; ++j) s += m.K(i, j) * q(j);
    d.q_motor(i) = s / m.motor_radius(i);
  }
  return Status::Ok;
}

/// Branch displacements S[i, b] [m] from data.q_motor and data.q (call a position map first):
/// S[i,0] = r_m q_m, S[i,b] = S[i,b−1] − K(i,b−1) q_{b−1}; consistency S[i,i] = K(i,i) q_i.
inline void branch_displacements(const TransmissionModel& m, TransmissionData& d) {
  for (int i = 0; i < m.n; ++i) {
    d.S(i, 0) = m.motor_radius(i) * d.q_motor(i);
    for (int b = 1; b <= i; ++b) d.S(i, b) = d.S(i, b - 1) - m.K(i, b - 1) * d.q(b - 1);
  }
}

/// Joint velocities → motor and branch velocities (same linear maps as positions).
/// Writes data.qdot, data.qdot_motor, data.Sdot.
template <class VecIn>
inline Status velocities_from_joint(const TransmissionModel& m, TransmissionData& d, const VecIn& qdot) {
  if (qdot.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(qdot)) return Status::NonFiniteInput;
  for (int i = 0; i < m.n; ++i) d.qdot(i) = qdot(i);
  for (int i = 0; i < m.n; ++i) {
    double s = 0.0;
    for (int j = 0; j <= i; ++j) s += m.K(i, j) * qdot(j);
    d.qdot_motor(i) = s / m.motor_radius(i);
    // Ṡ_b = Σ_{l≥b} K_il q̇_l summed directly (not Ṡ_{b−1} − K_i,b−1 q̇_{b−1}): a branch beyond every
    // moving joint must come out exactly 0, or the statics would treat it as sliding (stuck test Ṡ = 0).
    for (int b = 0; b <= i; ++b) {
      double sb = 0.0;
      for (int l = b; l <= i; ++l) sb += m.K(i, l) * qdot(l);
      d.Sdot(i, b) = sb;
    }
  }
  return Status::Ok;
}

// ---- lossless statics (S0 eqs. 4–5, corrected) ------------------------------------------------

/// Lossless: joint torques wanted → tensions t = K⁻ᵀ τ_J (back substitution from the distal joint)
/// → motor torques C_m = R_m t. Writes data.tension_motor (= t), data.torque_joint, data.torque_motor.
template <class VecIn>
inline Status motor_torque_lossless(const TransmissionModel& m, TransmissionData& d, const VecIn& torque_joint) {
  if (torque_joint.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(torque_joint)) return Status::NonFiniteInput;
  for (int j = m.n - 1; j >= 0; --j) {
    double s = torque_joint(j);  // S0 eq. 4: C_j = Σ_{k≥j} τ_k r_j^k
    for (int k = j + 1; k < m.n; ++k) s -= m.K(k, j) * d.tension_motor(k);
    d.tension_motor(j) = s / m.K(j, j);
  }
  for (int i = 0; i < m.n; ++i) {
    d.torque_joint(i) = torque_joint(i);
    d.torque_motor(i) = m.motor_radius(i) * d.tension_motor(i);
  }
  return Status::Ok;
}

/// Lossless: motor torques → tensions t = R_m⁻¹ C_m → joint torques τ_J = Kᵀ t.
template <class VecIn>
inline Status joint_torque_lossless(const TransmissionModel& m, TransmissionData& d, const VecIn& torque_motor) {
  if (torque_motor.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(torque_motor)) return Status::NonFiniteInput;
  for (int i = 0; i < m.n; ++i) {
    d.torque_motor(i) = torque_motor(i);
    d.tension_motor(i) = torque_motor(i) / m.motor_radius(i);
  }
  for (int j = 0; j < m.n; ++j) {
    double s = 0.0;
    for (int k = j; k < m.n; ++k) s += m.K(k, j) * d.tension_motor(k);
    d.torque_joint(j) = s;
  }
  return Status::Ok;
}

}  // namespace tendyn

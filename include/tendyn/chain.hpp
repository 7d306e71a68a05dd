// tendyn — allocation-free kinematics and gravity of the chain a compensator serves (no Pinocchio).
//
// The C ABI (`libtendyn_c`) deliberately does not link Pinocchio, yet a compensator needs the gravity
// torques g(q) and the end-effector position / Jacobian (S0 §IV-B: X̂ from the motor encoders through the
// direct kinematics, feedforward β(q̄) = friction + gravity). This header gives both for a tree of
// one-DOF joints described exactly as the rigid-body model is (python/tendyn/device/rigid_body.py,
// JointFrame): per joint its parent, the constant placement of its frame in the parent joint frame, its
// axis in its own frame, revolute or prismatic, and the mass and centre of mass of the link it moves.
// Gravity needs only mass and first moment m·c per link, so identified gravity base parameters fit too
// (put the first moments of the identified model in mass·com).
//
//   forward pass (base → tip):  R_j = R_p(j) R°_j Rot(a_j, q_j),  o_j = o_p(j) + R_p(j) p°_j (+ R_p(j) R°_j a_j q_j)
//   backward pass (tip → base): m̄_j = m_j + Σ_children m̄_k,  h̄_j = m_j c_j^0 + Σ_children h̄_k  (c_j^0 world COM)
//   gravity (= ∂V/∂q, Pinocchio's computeGeneralizedGravity convention, M q̈ + C q̇ + g = τ):
//       revolute:  g_j = −z_jᵀ ((h̄_j − m̄_j o_j) × g⃗),   prismatic:  g_j = −m̄_j z_jᵀ g⃗,   z_j = R_j a_j.
//
// Closed-loop trees (σ = 2 cut frames, python/tendyn/device/closed_loop.py): the tree's joints follow the
// n_a actuated joints through the linear map q = L q_a + c (active_map, active_offset). By virtual work
// (δW = g(q)ᵀ δq = g(q)ᵀ L δq_a) the gravity torques at the actuated joints are Lᵀ g(q) and the end-effector
// Jacobian is J L (chain_active below). An empty map is the identity (a serial chain, n_a = n).
//
// Model / Data convention: ChainModel is immutable after setup; ChainData holds every output; the
// real-time calls allocate nothing and return a Status.
#pragma once

#include "tendyn/status.hpp"

#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tendyn {

/// Immutable description of an n-joint tree of one-DOF joints with point-mass gravity data.
struct ChainModel {
  int n = 0;                                ///< number of joints
  Eigen::Vector3d gravity{0.0, 0.0, -9.81}; ///< gravity acceleration in the base frame [m/s²]
  Eigen::VectorXi parent;                   ///< (n) 0-based parent joint, −1 = base; parent(j) < j
  std::vector<Eigen::Matrix3d> rotation;    ///< (n) rotation of the joint frame in the parent joint frame at q = 0
  std::vector<Eigen::Vector3d> translation; ///< (n) origin of the joint frame in the parent joint frame [m]
  std::vector<Eigen::Vector3d> axis;        ///< (n) unit axis of motion in the joint frame
  Eigen::VectorXi prismatic;                ///< (n) 1 = prismatic [m], 0 = revolute [rad]
  Eigen::VectorXd mass;                     ///< (n) link mass [kg]
  std::vector<Eigen::Vector3d> com;         ///< (n) centre of mass in the joint frame [m]
  int ee_joint = -1;                        ///< 0-based joint carrying the end effector (−1: the last)
  Eigen::Vector3d ee_point = Eigen::Vector3d::Zero();  ///< end-effector point in that joint frame [m]
  /// (n, n_a) L of q = L q_a + c for a closed-loop tree driven by n_a actuated joints; empty = identity.
  Eigen::MatrixXd active_map;
  Eigen::VectorXd active_offset;            ///< (n) c [rad or m]; empty with an empty active_map

  /// Number of actuated joints n_a: the columns of active_map, n without one.
  int n_active() const { return active_map.size() ? static_cast<int>(active_map.cols()) : n; }

  ChainModel() = default;
  /// n joints at their defaults: serial (parent j − 1), identity placements, revolute about z, no mass.
  explicit ChainModel(int n_) : n(n_ > 0 ? n_ : 0) {
    parent.resize(n);
    prismatic.setZero(n);
    mass.setZero(n);
    rotation.assign(n, Eigen::Matrix3d::Identity());
    translation.assign(n, Eigen::Vector3d::Zero());
    axis.assign(n, Eigen::Vector3d::UnitZ());
    com.assign(n, Eigen::Vector3d::Zero());
    for (int j = 0; j < n; ++j) parent(j) = j - 1;
    ee_joint = n - 1;
  }

  /// The first problem as "field[j]: rule", or nullptr when the model is usable. Allocates nothing.
  /// `j` receives the 0-based joint index (−1 when not applicable).
  const char* first_issue(int* j) const {
    if (j) *j = -1;
    if (n < 1) return "n: must be >= 1";
    if (parent.size() != n || prismatic.size() != n || mass.size() != n ||
        static_cast<int>(rotation.size()) != n || static_cast<int>(translation.size()) != n ||
        static_cast<int>(axis.size()) != n || static_cast<int>(com.size()) != n)
      return "chain: every per-joint field must have n entries";
    if (!gravity.allFinite()) return "gravity: must be finite";
    for (int k = 0; k < n; ++k) {
      if (j) *j = k;
      if (!(parent(k) >= -1 && parent(k) < k)) return "parent: must be -1 (base) or an earlier joint";
      if (!rotation[k].allFinite() || !translation[k].allFinite()) return "placement: must be finite";
      if (!((rotation[k].transpose() * rotation[k] - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9 &&
            rotation[k].determinant() > 0.0))
        return "placement: the rotation part must be a proper rotation";
      if (!axis[k].allFinite() || std::abs(axis[k].norm() - 1.0) > 1e-9) return "axis: must be a unit vector";
      if (prismatic(k) != 0 && prismatic(k) != 1) return "prismatic: must be 0 or 1";
      if (!(std::isfinite(mass(k)) && mass(k) >= 0.0)) return "mass: must be finite and >= 0";
      if (!com[k].allFinite()) return "com: must be finite";
    }
    if (j) *j = -1;
    if (!(ee_joint >= 0 && ee_joint < n)) return "ee_joint: must be a joint index in [0, n)";
    if (!ee_point.allFinite()) return "ee_point: must be finite";
    if (active_map.size() || active_offset.size()) {
      if (active_map.rows() != n || active_map.cols() < 1) return "active_map: must be (n, n_active), n_active >= 1";
      if (active_offset.size() != n) return "active_offset: must have n entries";
      if (!active_map.allFinite() || !active_offset.allFinite()) return "active_map: must be finite";
    }
    return nullptr;
  }
  Status validate() const { return first_issue(nullptr) ? Status::InvalidModel : Status::Ok; }
};

/// Preallocated workspace and outputs of the chain calls.
struct ChainData {
  std::vector<Eigen::Matrix3d> R;       ///< world rotation of each joint frame (after its motion)
  std::vector<Eigen::Vector3d> origin;  ///< world origin of each joint frame [m]
  std::vector<Eigen::Vector3d> z;       ///< world axis of each joint
  std::vector<Eigen::Vector3d> moment;  ///< h̄_j: first moment of the subtree of joint j, world [kg·m]
  Eigen::VectorXd subtree_mass;         ///< m̄_j [kg]
  Eigen::VectorXd gravity_torque;       ///< g(q) [N·m or N]
  Eigen::Vector3d ee_position = Eigen::Vector3d::Zero();  ///< end-effector point, world [m]
  Eigen::Matrix<double, 3, Eigen::Dynamic> ee_jacobian;   ///< (3, n) ∂x_ee/∂q [m/rad]
  Eigen::VectorXi on_ee_path;           ///< 1 where joint j moves the end effector
  Eigen::VectorXi axis_z;               ///< 1 where the axis is exactly +z (fast rotation)
  Eigen::VectorXd q_tree;               ///< (n) q = L q_a + c of the last chain_active call [rad or m]
  Eigen::VectorXd gravity_active;       ///< (n_a) Lᵀ g(q) [N·m or N] (chain_active)
  Eigen::Matrix<double, 3, Eigen::Dynamic> ee_jacobian_active;  ///< (3, n_a) J L [m/rad] (chain_active)

  explicit ChainData(const ChainModel& m)
      : R(m.n, Eigen::Matrix3d::Identity()), origin(m.n, Eigen::Vector3d::Zero()),
        z(m.n, Eigen::Vector3d::UnitZ()), moment(m.n, Eigen::Vector3d::Zero()),
        subtree_mass(Eigen::VectorXd::Zero(m.n)), gravity_torque(Eigen::VectorXd::Zero(m.n)),
        ee_jacobian(Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, m.n)), on_ee_path(Eigen::VectorXi::Zero(m.n)),
        axis_z(Eigen::VectorXi::Zero(m.n)), q_tree(Eigen::VectorXd::Zero(m.n)),
        gravity_active(Eigen::VectorXd::Zero(m.n_active())),
        ee_jacobian_active(Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, m.n_active())) {
    if (m.n < 1 || m.parent.size() != m.n || static_cast<int>(m.axis.size()) != m.n) return;
    for (int k = 0; k < m.n; ++k) axis_z(k) = m.axis[k] == Eigen::Vector3d::UnitZ();
    int j = m.ee_joint >= 0 && m.ee_joint < m.n ? m.ee_joint : m.n - 1;
    while (j >= 0) {
      on_ee_path(j) = 1;
      j = m.parent(j);
    }
  }
};

/// Rotation about the unit axis a by angle t (Rodrigues), written out (no allocation).
inline Eigen::Matrix3d axis_rotation(const Eigen::Vector3d& a, double t) {
  const double c = std::cos(t), s = std::sin(t), v = 1.0 - c;
  Eigen::Matrix3d r;
  r << c + a.x() * a.x() * v, a.x() * a.y() * v - a.z() * s, a.x() * a.z() * v + a.y() * s,
      a.y() * a.x() * v + a.z() * s, c + a.y() * a.y() * v, a.y() * a.z() * v - a.x() * s,
      a.z() * a.x() * v - a.y() * s, a.z() * a.y() * v + a.x() * s, c + a.z() * a.z() * v;
  return r;
}

/// Joint frames at q (no end effector). Writes data.R, origin, z.
/// @param q  joint positions (n) [rad or m]
template <class V>
inline Status chain_frames(const ChainModel& m, ChainData& d, const V& q) {
  if (q.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(q)) return Status::NonFiniteInput;
  for (int j = 0; j < m.n; ++j) {
    const int p = m.parent(j);
    Eigen::Matrix3d R0;
    if (p < 0) {
      R0 = m.rotation[j];
      d.origin[j] = m.translation[j];
    } else {
      R0.noalias() = d.R[p] * m.rotation[j];
      d.origin[j] = d.origin[p] + d.R[p] * m.translation[j];
    }
    d.z[j] = R0 * m.axis[j];
    if (m.prismatic(j)) {
      d.R[j] = R0;
      d.origin[j] += d.z[j] * q(j);
    } else if (d.axis_z(j)) {  // R0 Rz(q), column by column (the common DH / modified-DH case)
      const double c = std::cos(q(j)), s = std::sin(q(j));
      d.R[j].col(0) = c * R0.col(0) + s * R0.col(1);
      d.R[j].col(1) = c * R0.col(1) - s * R0.col(0);
      d.R[j].col(2) = R0.col(2);
    } else {
      d.R[j].noalias() = R0 * axis_rotation(m.axis[j], q(j));
    }
  }
  return Status::Ok;
}

/// End-effector position and, if `jacobian`, its (3, n) Jacobian from the frames of the last chain_frames
/// call. Writes data.ee_position (and data.ee_jacobian).
inline void chain_end_effector(const ChainModel& m, ChainData& d, bool jacobian = true) {
  const int e = m.ee_joint;
  d.ee_position = d.origin[e] + d.R[e] * m.ee_point;
  if (!jacobian) return;
  for (int j = 0; j < m.n; ++j) {
    if (!d.on_ee_path(j)) d.ee_jacobian.col(j).setZero();
    else if (m.prismatic(j)) d.ee_jacobian.col(j) = d.z[j];
    else d.ee_jacobian.col(j) = d.z[j].cross(d.ee_position - d.origin[j]);
  }
}

/// Forward kinematics: joint frames, end-effector position and its (3, n) Jacobian at q.
/// @param q  joint positions (n) [rad or m]
/// Writes data.R, origin, z, ee_position, ee_jacobian.
template <class V>
inline Status chain_forward_kinematics(const ChainModel& m, ChainData& d, const V& q) {
  const Status s = chain_frames(m, d, q);
  if (is_error(s)) return s;
  chain_end_effector(m, d, true);
  return Status::Ok;
}

/// Generalized gravity g(q) = ∂V/∂q [N·m] from the frames of the last chain_forward_kinematics call
/// (call that first with the same q). Writes data.moment, subtree_mass, gravity_torque.
inline void chain_gravity_from_frames(const ChainModel& m, ChainData& d) {
  for (int j = 0; j < m.n; ++j) {
    d.subtree_mass(j) = m.mass(j);
    d.moment[j] = m.mass(j) * (d.origin[j] + d.R[j] * m.com[j]);
  }
  for (int j = m.n - 1; j >= 0; --j) {
    const int p = m.parent(j);
    if (p >= 0) {
      d.subtree_mass(p) += d.subtree_mass(j);
      d.moment[p] += d.moment[j];
    }
    if (m.prismatic(j))
      d.gravity_torque(j) = -d.subtree_mass(j) * d.z[j].dot(m.gravity);
    else
      d.gravity_torque(j) = -d.z[j].dot((d.moment[j] - d.subtree_mass(j) * d.origin[j]).cross(m.gravity));
  }
}

/// Forward kinematics and generalized gravity g(q) at q [N·m] (see the header comment).
template <class V>
inline Status chain_gravity_torque(const ChainModel& m, ChainData& d, const V& q) {
  const Status s = chain_forward_kinematics(m, d, q);
  if (is_error(s)) return s;
  chain_gravity_from_frames(m, d);
  return Status::Ok;
}

/// Frames, gravity and (with `jacobian`) the end-effector Jacobian at the actuated joint positions q_a (n_a)
/// [rad or m]: q = L q_a + c (identity without an active map), then chain_frames, chain_gravity_from_frames and
/// chain_end_effector at q, and the actuated-joint views gravity_active = Lᵀ g(q) [N·m], ee_jacobian_active = J L
/// (virtual work, header comment). Writes data.q_tree and everything those calls write. Allocates nothing.
template <class V>
inline Status chain_active(const ChainModel& m, ChainData& d, const V& q_active, bool jacobian = true) {
  const bool mapped = m.active_map.size() > 0;
  if (q_active.size() != m.n_active()) return Status::SizeMismatch;
  if (!all_finite(q_active)) return Status::NonFiniteInput;
  if (mapped) {
    d.q_tree = m.active_offset;
    for (int k = 0; k < m.active_map.cols(); ++k) d.q_tree += m.active_map.col(k) * q_active(k);
  } else {
    for (int j = 0; j < m.n; ++j) d.q_tree(j) = q_active(j);
  }
  const Status s = chain_frames(m, d, d.q_tree);
  if (is_error(s)) return s;
  chain_gravity_from_frames(m, d);
  chain_end_effector(m, d, jacobian);
  if (mapped) {
    d.gravity_active.noalias() = m.active_map.transpose().lazyProduct(d.gravity_torque);
    if (jacobian) d.ee_jacobian_active.noalias() = d.ee_jacobian.lazyProduct(m.active_map);
  } else {
    d.gravity_active = d.gravity_torque;
    if (jacobian) d.ee_jacobian_active = d.ee_jacobian;
  }
  return Status::Ok;
}

}  // namespace tendyn

// tendyn — mass matrix and bias forces of a tree of one-DOF joints in one kinematics pass (simulator step).
//
// Pinocchio's crba() and nonLinearEffects() each recompute the forward kinematics and dispatch joint by
// joint through the joint variant; the simulator needs both at the same (q, v) every step. This header
// computes them together for a tree of revolute / prismatic joints (what RigidBodyModel::add_joint
// builds), all in the world frame at the world origin, so that no spatial transform of an inertia is ever
// needed (inertias about the origin add up):
//
//   kinematics (base → tip):  R_j = R_p(j) R°_j Rot(a_j, q_j),  o_j = o_p(j) + R_p(j) p°_j (+ z_j q_j, prismatic)
//       z_j = R_p(j) R°_j a_j;  motion subspace at the origin S_j = (v, ω) = (o_j × z_j, z_j) revolute, (z_j, 0) prismatic
//   body inertia about the origin:  m_j,  h_j = m_j c_j (c_j world COM),  I_O,j = R_j I_c,j R_jᵀ + m_j (|c_j|² 1 − c_j c_jᵀ)
//       (computed from the link's ten dynamic parameters about its joint origin, linear: set_parameters)
//       applied to a motion (v, ω):  f = m v + ω × h,  n = I_O ω + h × v        (momentum about the origin)
//   bias forces (RNEA with q̈ = 0, Featherstone ch. 5 in base coordinates):
//       V_j = V_p + S_j q̇_j,  A_j = A_p + (V_j × S_j) q̇_j,  A_0 = (−g, 0)
//       f_j = I_j A_j + V_j ×* (I_j V_j),  F_j = f_j + Σ_children F_k,  nle_j = S_jᵀ F_j
//       motion cross (v₁, ω₁) × (v₂, ω₂) = (ω₁ × v₂ + v₁ × ω₂, ω₁ × ω₂);  force cross (v, ω) ×* (f, n) = (ω × f, ω × n + v × f)
//   mass matrix (CRBA): composite Ī_j = I_j + Σ_children Ī_k;  M_ij = S_iᵀ (Ī_j S_j) for i = j and every ancestor i of j.
//
// M q̈ + nle(q, q̇) = τ, Pinocchio's convention (nle = C(q, q̇) q̇ + g(q)); checked against Pinocchio's crba
// and nonLinearEffects to 1e-12 (tests/cpp/test_sim_no_alloc.cpp, tests/python/test_sim.py).
// Model / Data convention; tree_mass_and_bias() allocates nothing.
#pragma once

#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>

namespace tendyn {

/// sin and cos of one angle: glibc's sincos (one range reduction, the same results as sin and cos; what
/// Pinocchio's joints call), std::sin / std::cos elsewhere.
inline void sin_cos(double x, double& s, double& c) {
#if defined(__GLIBC__)
  ::sincos(x, &s, &c);
#else
  s = std::sin(x);
  c = std::cos(x);
#endif
}

/// The tree as the step needs it, read once from a Pinocchio model (setup time; allocates).
struct TreeDynamicsModel {
  int n = 0;              ///< joints (= nq = nv of the tree)
  bool valid = false;     ///< false: a joint is not a one-DOF revolute / prismatic joint (use Pinocchio)
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  std::vector<int> parent;                       ///< 0-based parent joint, −1 = base
  std::vector<Eigen::Matrix3d> rotation;         ///< R°_j: joint frame in the parent joint frame at q = 0
  std::vector<Eigen::Vector3d> translation;      ///< p°_j [m]
  std::vector<Eigen::Vector3d> axis;             ///< a_j, unit, joint frame
  std::vector<int> prismatic;                    ///< 1 prismatic, 0 revolute
  std::vector<int> axis_z;                       ///< 1: a_j = +z exactly (rotation written column-wise)
  std::vector<double> mass;                      ///< [kg]
  std::vector<Eigen::Vector3d> com;              ///< [m], joint frame (as read from Pinocchio; not used by the pass)
  std::vector<Eigen::Matrix3d> inertia;          ///< about the COM, joint-frame axes [kg·m²] (idem)
  // What the pass uses: the ten dynamic parameters of each link, linear in the dynamics (so that any vector of
  // identified parameters, even a regrouped one with a zero mass and a nonzero first moment, can be simulated):
  std::vector<Eigen::Vector3d> first_moment;     ///< m c [kg·m], joint frame
  std::vector<Eigen::Matrix3d> inertia_origin;   ///< about the joint-frame origin, joint-frame axes [kg·m²]

  TreeDynamicsModel() = default;
  explicit TreeDynamicsModel(const pinocchio::Model& pin) { build(pin); }

  /// Read the tree from `pin`. The motion subspace of each joint is measured through Pinocchio itself
  /// (the local velocity of joint j for q̇ = e_j at the neutral configuration), so an axis or a joint
  /// kind is never guessed from a type name. Sets valid = false for anything else than one-DOF
  /// revolute / prismatic joints numbered in order.
  void build(const pinocchio::Model& pin) {
    valid = false;
    n = pin.njoints - 1;
    if (n < 1 || pin.nq != n || pin.nv != n) return;
    gravity = pin.gravity.linear();
    parent.assign(n, -1); rotation.assign(n, Eigen::Matrix3d::Identity());
    translation.assign(n, Eigen::Vector3d::Zero()); axis.assign(n, Eigen::Vector3d::UnitZ());
    prismatic.assign(n, 0); axis_z.assign(n, 0); mass.assign(n, 0.0);
    com.assign(n, Eigen::Vector3d::Zero()); inertia.assign(n, Eigen::Matrix3d::Zero());
    first_moment.assign(n, Eigen::Vector3d::Zero()); inertia_origin.assign(n, Eigen::Matrix3d::Zero());
    pinocchio::Data data(pin);
    const Eigen::VectorXd q0 = pinocchio::neutral(pin);
    for (int j = 0; j < n; ++j) {
      const auto jj = static_cast<pinocchio::JointIndex>(j + 1);
      if (pin.nqs[jj] != 1 || pin.nvs[jj] != 1 || pin.idx_qs[jj] != j || pin.idx_vs[jj] != j) return;
      if (q0(j) != 0.0) return;
      parent[j] = static_cast<int>(pin.parents[jj]) - 1;
      if (parent[j] >= j) return;
      rotation[j] = pin.jointPlacements[jj].rotation();
      translation[j] = pin.jointPlacements[jj].translation();
      mass[j] = pin.inertias[jj].mass();
      com[j] = pin.inertias[jj].lever();
      inertia[j] = pin.inertias[jj].inertia().matrix();
      first_moment[j] = mass[j] * com[j];
      inertia_origin[j] = inertia[j] + mass[j] * (com[j].squaredNorm() * Eigen::Matrix3d::Identity() -
                                                  com[j] * com[j].transpose());
      Eigen::VectorXd v = Eigen::VectorXd::Zero(n);
      v(j) = 1.0;
      pinocchio::forwardKinematics(pin, data, q0, v);
      const Eigen::Vector3d lin = data.v[jj].linear(), ang = data.v[jj].angular();
      if (lin.norm() < 1e-14 && std::abs(ang.norm() - 1.0) < 1e-12) {
        axis[j] = ang; prismatic[j] = 0;
      } else if (ang.norm() < 1e-14 && std::abs(lin.norm() - 1.0) < 1e-12) {
        axis[j] = lin; prismatic[j] = 1;
      } else {
        return;
      }
      axis_z[j] = axis[j] == Eigen::Vector3d::UnitZ();
    }
    valid = true;
  }

  /// Set link j's dynamic parameters from ten values in Pinocchio's order (the regressor's columns 10 j …
  /// 10 j + 9): m [kg], m c_x, m c_y, m c_z [kg·m], I_xx, I_xy, I_yy, I_xz, I_yz, I_zz [kg·m²] about the
  /// joint-frame origin. Any real values (a base-parameter vector need not be physical). `com` and `inertia`
  /// are left as they were.
  void set_parameters(int j, const double* pi) {
    mass[j] = pi[0];
    first_moment[j] = Eigen::Vector3d(pi[1], pi[2], pi[3]);
    Eigen::Matrix3d I;
    I << pi[4], pi[5], pi[7], pi[5], pi[6], pi[8], pi[7], pi[8], pi[9];
    inertia_origin[j] = I;
  }
};

/// Workspace and outputs of tree_mass_and_bias (sized at construction).
struct TreeDynamicsData {
  struct Joint {
    Eigen::Matrix3d R;                 // world rotation of the joint frame
    Eigen::Vector3d o, z;              // world origin and axis
    Eigen::Vector3d sv, sw;            // motion subspace at the origin (linear, angular)
    Eigen::Vector3d vv, vw, av, aw;    // spatial velocity / bias acceleration at the origin
    Eigen::Vector3d ff, fn;            // force accumulated over the subtree (linear, moment about the origin)
    double mc;                         // composite mass
    Eigen::Vector3d hc;                // composite first moment
    Eigen::Matrix3d Ic;                // composite rotational inertia about the origin
  };
  std::vector<Joint> joint;
  Eigen::MatrixXd M;      ///< (n, n) mass matrix, both triangles
  Eigen::VectorXd nle;    ///< (n) C(q, q̇) q̇ + g(q)

  TreeDynamicsData() = default;
  explicit TreeDynamicsData(const TreeDynamicsModel& m)
      : joint(m.n), M(Eigen::MatrixXd::Zero(m.n, m.n)), nle(Eigen::VectorXd::Zero(m.n)) {}
};

/// Mass matrix and bias forces at (q, q̇) in one kinematics pass (header comment). Allocates nothing.
/// @param q, qd  tree joint positions / velocities (n) [rad or m, rad/s or m/s]
template <class V1, class V2>
inline void tree_mass_and_bias(const TreeDynamicsModel& m, TreeDynamicsData& d, const V1& q, const V2& qd) {
  const int n = m.n;
  // forward pass: frames, motion subspaces, body inertias about the origin, velocities, bias accelerations
  for (int j = 0; j < n; ++j) {
    auto& J = d.joint[j];
    const int p = m.parent[j];
    Eigen::Matrix3d R0;
    if (p < 0) {
      R0 = m.rotation[j];
      J.o = m.translation[j];
    } else {
      const auto& P = d.joint[p];
      R0.noalias() = P.R * m.rotation[j];
      J.o.noalias() = P.R * m.translation[j];
      J.o += P.o;
    }
    J.z.noalias() = R0 * m.axis[j];
    const double qj = q(j);
    if (m.prismatic[j]) {
      J.R = R0;
      J.o += J.z * qj;
      J.sv = J.z;
      J.sw.setZero();
    } else {
      double s, c;
      sin_cos(qj, s, c);
      if (m.axis_z[j]) {  // R0 Rz(q), column by column
        J.R.col(0) = c * R0.col(0) + s * R0.col(1);
        J.R.col(1) = c * R0.col(1) - s * R0.col(0);
        J.R.col(2) = R0.col(2);
      } else {  // Rodrigues about the unit axis
        const Eigen::Vector3d& a = m.axis[j];
        const double t = 1.0 - c;
        Eigen::Matrix3d r;
        r << c + a.x() * a.x() * t, a.x() * a.y() * t - a.z() * s, a.x() * a.z() * t + a.y() * s,
            a.y() * a.x() * t + a.z() * s, c + a.y() * a.y() * t, a.y() * a.z() * t - a.x() * s,
            a.z() * a.x() * t - a.y() * s, a.z() * a.y() * t + a.x() * s, c + a.z() * a.z() * t;
        J.R.noalias() = R0 * r;
      }
      J.sv = J.o.cross(J.z);
      J.sw = J.z;
    }
    // body inertia about the origin (starts the composite), linear in the link's parameters: with g = R h
    // (h = m c in the joint frame) and I_j about the joint origin, I_O = R I_j Rᵀ + m (|o|² 1 − o oᵀ)
    // + 2 (o·g) 1 − g oᵀ − o gᵀ (parallel axes with the first moment)
    const double mj = m.mass[j];
    const Eigen::Vector3d g = J.R * m.first_moment[j];
    J.mc = mj;
    J.hc = mj * J.o + g;
    Eigen::Matrix3d RI;
    RI.noalias() = J.R * m.inertia_origin[j];
    J.Ic.noalias() = RI * J.R.transpose();
    J.Ic.diagonal().array() += mj * J.o.squaredNorm() + 2.0 * J.o.dot(g);
    J.Ic.noalias() -= (mj * J.o + g) * J.o.transpose();
    J.Ic.noalias() -= J.o * g.transpose();
    // velocity and bias acceleration (q̈ = 0)
    const double w = qd(j);
    if (p < 0) {
      J.vv = w * J.sv;
      J.vw = w * J.sw;
      J.av = -m.gravity;
      J.aw.setZero();
    } else {
      const auto& P = d.joint[p];
      J.vv = P.vv + w * J.sv;
      J.vw = P.vw + w * J.sw;
      // (V × S) q̇ with V the parent's velocity (S × S = 0)
      J.av = P.av + w * (P.vw.cross(J.sv) + P.vv.cross(J.sw));
      J.aw = P.aw + w * P.vw.cross(J.sw);
    }
    // body force f = I A + V ×* (I V), I about the origin: I (v, ω) = (m v + ω × h, I_O ω + h × v)
    const Eigen::Vector3d pv = mj * J.vv + J.vw.cross(J.hc);
    const Eigen::Vector3d pw = J.Ic * J.vw + J.hc.cross(J.vv);
    J.ff = mj * J.av + J.aw.cross(J.hc) + J.vw.cross(pv);
    J.fn = J.Ic * J.aw + J.hc.cross(J.av) + J.vw.cross(pw) + J.vv.cross(pv);
  }
  // backward pass: bias forces, composite inertias, mass-matrix columns
  for (int j = n - 1; j >= 0; --j) {
    auto& J = d.joint[j];
    d.nle(j) = J.sv.dot(J.ff) + J.sw.dot(J.fn);
    // F = Ī_j S_j, projected on S_j and on every ancestor's S
    const Eigen::Vector3d Fl = J.mc * J.sv + J.sw.cross(J.hc);
    const Eigen::Vector3d Fn = J.Ic * J.sw + J.hc.cross(J.sv);
    d.M(j, j) = J.sv.dot(Fl) + J.sw.dot(Fn);
    for (int i = m.parent[j]; i >= 0; i = m.parent[i]) {
      const auto& I = d.joint[i];
      d.M(i, j) = d.M(j, i) = I.sv.dot(Fl) + I.sw.dot(Fn);
    }
    const int p = m.parent[j];
    if (p >= 0) {
      auto& P = d.joint[p];
      P.ff += J.ff;
      P.fn += J.fn;
      P.mc += J.mc;
      P.hc += J.hc;
      P.Ic += J.Ic;
    }
  }
}

}  // namespace tendyn

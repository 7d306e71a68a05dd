// tendyn — the simulator's model and data (part of sim.hpp): SimModel (the immutable model: tree, drives,
// friction sites, sensors, control settings; finalize() once at setup) and SimData (preallocated state and
// workspace; reset()). Model/Data convention: nothing below allocates after construction.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "tendyn/losses.hpp"
#include "tendyn/rigid_body.hpp"
#include "tendyn/sim_noise.hpp"
#include "tendyn/tendons.hpp"
#include "tendyn/tree_dynamics.hpp"

/// SimModel has pgs_speed_tolerance (tools built against several versions of this header test it).
#define TENDYN_HAS_PGS_SPEED_TOLERANCE 1

namespace tendyn {

enum class DriveKind : int { Tendon = 0, Elastic = 1, Tendons = 2 };
enum class ControlMode : int { Torque = 0, JointPID = 1, MotorPID = 2 };
enum class SiteKind : int { Branch = 0, Reducer = 1, MotorCoulomb = 2, JointCoulomb = 3, Lock = 4 };

struct SimModel;
struct SimData;
/// Plug-in slot for a controller written in C/C++ (compensator, renderer): called at the control
/// rate after the built-in law, it may overwrite data.torque_motor_cmd [N·m].
using ControlHook = void (*)(void* user, const SimModel& model, SimData& data);

/// Immutable simulation model. Fill the public fields, then call finalize() once (setup time).
struct SimModel {
  RigidBodyModel body;          ///< joint-side tree
  Eigen::MatrixXd L;            ///< (nq_tree, na) q_tree = L q_a + c
  Eigen::VectorXd c;            ///< (nq_tree) [rad]
  int na = 0;                   ///< active joints = motors
  DriveKind drive = DriveKind::Tendon;
  TransmissionModel tendon;     ///< Tendon drives: routing + cable/reducer losses
  TendonModel tendons;          ///< Tendons (N+1) drives: K (na + 1, na), branch losses τ0, ν (S0 eq. 12)
  /// Tendons drives in JointPID mode: allocate the PID torque to tensions with the branch losses of S0 eq. 12
  /// at the reference velocity (tendon_feedforward with q̇ = ref_v); false: the lossless allocation.
  bool tendon_loss_compensation = false;

  // Elastic drives (per motor): joint speed × ratio = motor speed.
  Eigen::VectorXd ratio;            ///< N [-]
  Eigen::VectorXd stiffness_motor;  ///< K_T [N·m/rad], motor side
  Eigen::VectorXd damping_motor;    ///< [N·m·s/rad], motor side

  // Motors (both kinds).
  Eigen::VectorXd rotor_inertia;    ///< [kg·m²]
  Eigen::VectorXd torque_constant;  ///< k_t [N·m/A]
  Eigen::VectorXd peak_torque;      ///< saturation [N·m]
  Eigen::VectorXd coulomb_motor;    ///< Coulomb friction on the motor shaft [N·m]
  Eigen::VectorXd viscous_motor;    ///< [N·m·s/rad]
  // Joint side (active joints).
  Eigen::VectorXd coulomb_joint;    ///< [N·m]
  Eigen::VectorXd viscous_joint;    ///< [N·m·s/rad]
  Eigen::VectorXd offset_joint;     ///< constant torque the drive must overcome [N·m]
  Eigen::VectorXd lock_joint;       ///< 1 = the link is blocked (blocked-link tests), 0 = free
  /// Position-dependent joint torques (the device file's [[terms]]: springs, cable torques, known torques),
  /// one uniform table per active joint over its own position, linear between knots, constant beyond the
  /// ends: a torque the actuators must supply, like offset_joint. term_torque empty (0 columns) = none.
  Eigen::VectorXd term_lo;          ///< (na) position of the first knot [rad or m]
  Eigen::VectorXd term_step;        ///< (na) knot spacing [rad or m], > 0
  Eigen::MatrixXd term_torque;      ///< (na, knots) torque at each knot [N·m or N]
  /// End stops of the tree joints (issue 40: the twin keeps to the device's limits). A tree joint k past its
  /// range by δ_k (q_k − upper_k > 0 or q_k − lower_k < 0) meets the spring–damper τ_k = −K_s δ_k − B_s q̇_k,
  /// applied linearly implicit (the spring at the step's end, K_s (δ_k + h q̇_k⁺): stable at any K_s); through
  /// the map, the active joints feel Lᵀ τ. Energy: ½ K_s δ² is in mechanical_energy; each step adds to
  /// data.dissipated what the stop took, −h q̇⁺ τ − Δ(½ K_s δ²) (the damper's h B_s q̇², the implicit spring's
  /// ½ K_s h² q̇², and the entry/exit steps exactly). The step's own loss at an impact (½ Δvᵀ M Δv, large when
  /// a stop changes v by much in one step) is data.numerical_loss. Both empty
  /// (the default) = no stops; ±inf = no stop on that side.
  Eigen::VectorXd stop_lower;       ///< (nq_tree) [rad or m]
  Eigen::VectorXd stop_upper;       ///< (nq_tree) [rad or m]
  double stop_stiffness = 0.0;      ///< K_s [N·m/rad or N/m], >= 0
  double stop_damping = 0.0;        ///< B_s [N·m·s/rad or N·s/m], >= 0
  /// Torque mode: the controller adds the lossless motor torques of gravity at its encoder estimate,
  /// C_g = motor_from_joint_torque · Lᵀ g(L q̂ + c) (what a lab's controller runs under a torque-mode test
  /// such as a stepped sine: the arm is held where gravity would pull it into a stop).
  bool gravity_compensation = false;

  // Sensors.
  Eigen::VectorXd encoder_counts;   ///< counts per motor revolution after decoding (0 = ideal)
  Eigen::VectorXd current_noise;    ///< measured-current noise [A rms]

  // Timing and control.
  double dt = 1e-4;                 ///< integration step [s]
  int control_decimation = 10;      ///< control period = dt · control_decimation
  ControlMode mode = ControlMode::Torque;
  Eigen::VectorXd kp, kd, ki;       ///< PID gains (joint: N·m/rad …; motor: N·m/rad at the motor)
  double velocity_cutoff_hz = 0.0;  ///< first-order filter on the velocity estimate (0 = none)
  ControlHook hook = nullptr;
  void* hook_user = nullptr;

  // Friction solver.
  int pgs_max_iterations = 200;
  double pgs_relaxation = 1.3;      ///< projected SOR factor in (0, 2); 1.3 cut the sweeps by ~30 % on stuck chains
  double pgs_tolerance = 1e-13;     ///< on the impulse change, relative to the largest impulse
  /// Physically scaled stop [rad/s] (0 = off): a sweep converges when the velocity it moved every site by,
  /// |Δp_k| W_kk, is at most pgs_speed_tolerance · ‖g_k‖ (a joint-velocity change of about that size; on a
  /// cable branch, ‖g_k‖ ~ 0.01–0.05 m, about kRestSpeed = 1e-12 m/s). Either test stops the sweeps.
  /// 1e-10 rad/s is 2e-10 rad over 2 s, 1e-5 of an encoder count. Once met, one plain (ω = 1) sweep more
  /// brings stuck sites to rest to rounding (holds stay bit-identical). On the stick–slip test of
  /// benchmarks/sim_bench.py, exact finish off, the sweeps fall from 15.1 to 7.9 per step and the 2 s
  /// trajectory moves by 4.1e-13 rad (tests/python/test_sim_pgs.py bounds it by 1e-9 rad; docs/simulator.md).
  /// It is also the tolerance to which the exact finish checks Coulomb's law.
  double pgs_speed_tolerance = 1e-10;
  /// Solve the friction exactly (detail::finish_friction) for the classification of the sites (stuck
  /// inside its box / sliding at its lower / upper bound) of the warm start, and of each new one a sweep
  /// reaches if that fails: project v onto the velocities that keep every stuck site at rest, with the
  /// sliding sites at their bounds, active-set changes as the laws ask; kept only when Coulomb's law holds at
  /// every site to pgs_speed_tolerance. Sliding sites are warm-started at their new bound. Needs
  /// pgs_speed_tolerance > 0; off: the sweeps alone, as before issue 12.
  bool pgs_exact_finish = true;

  // ---- derived at finalize() ----
  int nm = 0;                       ///< motors: na, or na + 1 (Tendons)
  int nv = 0;                       ///< velocity dimension: na (tendon) or 2 na (elastic)
  int n_sites = 0;
  bool identity_map = false;        ///< L = I and c = 0 (serial chain)
  Eigen::MatrixXd Gm;               ///< (nm, na) motor velocity from joint velocity (tendon)
  Eigen::MatrixXd joint_from_motor; ///< (na, nm) joint estimate from motor positions (N+1: least squares)
  Eigen::MatrixXd motor_from_joint_torque;  ///< (nm, na) control: C_m from τ_J (lossless; N+1: minimum-norm)
  Eigen::MatrixXd M_rotor;          ///< constant mass added by the rotors
  Eigen::MatrixXd D;                ///< (nv, nv) implicit viscous damping
  Eigen::MatrixXd G;                ///< (n_sites, nv) site velocity Jacobians
  Eigen::MatrixXd Gt;               ///< (nv, n_sites) Gᵀ: column k = g_kᵀ, contiguous
  Eigen::VectorXi site_begin, site_end;  ///< nonzero range [begin, end) of each row g_k
  Eigen::VectorXd site_norm;        ///< ‖g_k‖₂ (scale of the speed tolerance)
  Eigen::VectorXi site_kind, site_i, site_b;
  TreeDynamicsModel tree;           ///< the tree for the one-pass dynamics (tree.valid = false: Pinocchio)

  /// Size every default, build the site layout and the constant matrices. Allocates.
  Status finalize();
  int nq_tree() const { return body.pin.nq; }
  /// Columns of the references ref_q, ref_v: motors (MotorPID) or joints.
  int n_ref() const { return mode == ControlMode::MotorPID ? nm : na; }
  /// Columns of the feedforward ff: joint torques (JointPID) or motor torques.
  int n_ff() const { return mode == ControlMode::JointPID ? na : nm; }
  bool slaved_motors() const { return drive == DriveKind::Tendon || drive == DriveKind::Tendons; }
};

/// Preallocated state and workspace.
struct SimData {
  RigidBodyData body;
  double time = 0.0;
  long step_count = 0;
  Eigen::VectorXd q, qd;            ///< active joint position [rad] / velocity [rad/s] (truth)
  Eigen::VectorXd q_motor, qd_motor; ///< motor position / velocity (truth) [rad, rad/s]
  Eigen::VectorXd q_tree, v_tree;
  TreeDynamicsData tree;            ///< one-pass mass matrix and bias forces of the tree
  Eigen::MatrixXd ML, M, Mt, Linv, Minv, B;  // Mt: Cholesky factor L of M + hD; Minv = (M + hD)⁻¹; B = Minv Gᵀ
  Eigen::VectorXd F, v, rhs, vfree, Lrecip, Wdiag, Wrecip, sdot, u, p, lo, hi;  // sdot: site speeds at the step start; Lrecip = 1/L_jj; Wrecip = 1/W_kk
  Eigen::VectorXd ext;              ///< external joint torque net of the offset, this step [N·m]
  Eigen::VectorXd stop_depth;       ///< (nq_tree) δ_k past the end stop at the step start (0 inside) [rad or m]
  int stops_touched = 0;            ///< tree joints past a stop at the last step's start
  double stop_contact_time = 0.0;   ///< time spent with some joint past a stop since the reset [s]
  Eigen::VectorXi active;           ///< indices of the sites in this step's friction solve
  Eigen::VectorXi site_state;       ///< where each site ended the last step: 0 inside its box, 1 at lo, 2 at hi
  // exact finish (detail::finish_friction): ≤ nv kept stuck sites, A-orthogonal directions, coefficients
  Eigen::MatrixXd fin_e, fin_f, fin_c;  ///< (nv, nv) columns: velocity e_i, force f_i, impulse coefficients c_i
  Eigen::VectorXd fin_piv, fin_v, fin_vb, fin_p;  ///< 1/(f_i·e_i); projected v; v at fin_p; impulses tried
  Eigen::VectorXi fin_site;             ///< site of kept slot j
  Eigen::VectorXi fin_state;            ///< per site: 0 sticks, 1 slides at lo, 2 slides at hi
  int pgs_finished = 0;                 ///< 1 when this step's solve ended with an accepted exact finish
  Eigen::VectorXd v_end;            ///< v⁺ of the last step (d.u holds the site speeds there)
  bool v_end_valid = false;
  // control and sensing
  Eigen::VectorXd q_motor_meas, torque_motor_meas, torque_motor_cmd, torque_motor;
  Eigen::VectorXd q_est, v_est, q_est_prev, integral, v_motor_est, qm_meas_prev, tmp_na;
  Eigen::MatrixXd tension;          ///< cable tension estimate at joint b after branch b [N]
  Eigen::VectorXd tension_motor;    ///< tension leaving each motor pulley [N]
  Eigen::VectorXd qd_motor_prev;    ///< motor velocity at the previous step (rotor inertia share)
  TendonData tendon_data;           ///< Tendons drives: the allocation of the joint-space controller
  Rng rng;
  bool first_control = true;
  // diagnostics
  int pgs_iterations = 0;          ///< sweeps of the last step (0: no friction, or the warm start finished exactly)
  double work_motor = 0.0;          ///< ∫ C_mᵀ q̇_m dt [J]
  double work_external = 0.0;       ///< ∫ τ_extᵀ q̇_a dt [J]
  double dissipated = 0.0;          ///< energy taken by friction and damping [J]
  /// Energy the implicit (backward-Euler in v) step itself removes [J]: Σ ½ (v⁺ − v)ᵀ M (v⁺ − v). With
  /// M (v⁺ − v) = h F(v⁺) and every force's work booked at v⁺, ½ v⁺ᵀ M v⁺ − ½ vᵀ M v = h v⁺ᵀ F − ½ Δvᵀ M Δv:
  /// first order in h, negligible on smooth motion, 4–14 % of the energy exchanged on an arm falling into its
  /// end stops at 20–5 kHz (issue 40). Balance: ΔE = work_motor + work_external − dissipated − numerical_loss.
  double numerical_loss = 0.0;

  explicit SimData(const SimModel& m);
  /// Set the joint state (velocities zero) and reset sensors, controller, diagnostics. Motor positions
  /// start at zero: for capstan drives set q_motor (e.g. N q0 for relaxed springs) after the reset.
  void reset(const Eigen::VectorXd& q0, std::uint64_t seed);
};

// ---------------------------------------------------------------------------------------------

inline Status SimModel::finalize() {
  na = static_cast<int>(L.cols());
  if (na <= 0 || L.rows() != body.pin.nq || c.size() != body.pin.nq) return Status::InvalidModel;
  nm = drive == DriveKind::Tendons ? na + 1 : na;
  auto fill_n = [](Eigen::VectorXd& v, int n, double def) {
    if (v.size() != n) v = Eigen::VectorXd::Constant(n, def);
  };
  auto fill = [&](Eigen::VectorXd& v, double def) { fill_n(v, na, def); };
  auto fill_m = [&](Eigen::VectorXd& v, double def) { fill_n(v, nm, def); };
  fill(ratio, 1.0); fill(stiffness_motor, 0.0); fill(damping_motor, 0.0);
  fill_m(rotor_inertia, 0.0); fill_m(torque_constant, 1.0); fill_m(peak_torque, 1e300);
  fill_m(coulomb_motor, 0.0); fill_m(viscous_motor, 0.0);
  fill(coulomb_joint, 0.0); fill(viscous_joint, 0.0); fill(offset_joint, 0.0); fill(lock_joint, 0.0);
  fill_m(encoder_counts, 0.0); fill_m(current_noise, 0.0);
  fill_n(kp, n_ref(), 0.0); fill_n(kd, n_ref(), 0.0); fill_n(ki, n_ref(), 0.0);
  if (!(dt > 0.0) || control_decimation < 1 || !(pgs_relaxation > 0.0 && pgs_relaxation < 2.0))
    return Status::InvalidModel;
  if (term_torque.cols() > 0) {
    if (term_torque.rows() != na || term_torque.cols() < 2 || term_lo.size() != na || term_step.size() != na ||
        !(term_step.array() > 0.0).all() || !term_torque.allFinite())
      return Status::InvalidModel;
  }
  identity_map = L.rows() == na && L.isIdentity(0.0) && c.isZero(0.0);
  if (stop_lower.size() || stop_upper.size()) {
    const int nt = static_cast<int>(L.rows());
    if (stop_lower.size() != nt || stop_upper.size() != nt || !(stop_lower.array() <= stop_upper.array()).all() ||
        stop_lower.hasNaN() || stop_upper.hasNaN() || !(stop_stiffness >= 0.0) || !(stop_damping >= 0.0) ||
        !std::isfinite(stop_stiffness) || !std::isfinite(stop_damping))
      return Status::InvalidModel;
  }

  if (drive == DriveKind::Tendon) {
    if (tendon.n != na || is_error(tendon.validate())) return Status::InvalidModel;
    nv = na;
    Gm = tendon.motor_from_joint_position;
    joint_from_motor = tendon.joint_from_motor_position;
    motor_from_joint_torque = tendon.motor_from_joint_torque;
    M_rotor = Gm.transpose() * rotor_inertia.asDiagonal() * Gm;
  } else if (drive == DriveKind::Tendons) {
    if (tendons.n != na || tendons.m != nm || tendons.K.rows() != nm || tendons.K.cols() != na)
      return Status::InvalidModel;
    nv = na;
    Gm = tendons.motor_radius.cwiseInverse().asDiagonal() * tendons.K;  // q̇_m = R_m⁻¹ K q̇
    joint_from_motor = (Gm.transpose() * Gm).ldlt().solve(Gm.transpose());  // least squares (exact when rigid)
    motor_from_joint_torque = tendons.motor_radius.asDiagonal() * tendons.tension_from_torque;  // R_m P
    M_rotor = Gm.transpose() * rotor_inertia.asDiagonal() * Gm;  // Kᵀ R_m⁻¹ I_m R_m⁻¹ K
  } else {
    for (int i = 0; i < na; ++i)
      if (!(ratio(i) > 0.0) || !(stiffness_motor(i) > 0.0)) return Status::InvalidModel;
    nv = 2 * na;
    Gm = ratio.asDiagonal();
    joint_from_motor = ratio.cwiseInverse().asDiagonal();
    motor_from_joint_torque = ratio.cwiseInverse().asDiagonal();
    M_rotor = Eigen::MatrixXd::Zero(nv, nv);
    M_rotor.bottomRightCorner(na, na) = rotor_inertia.asDiagonal();
  }

  // Sites: every cable branch and reducer (tendon), motor and joint Coulomb where non-zero.
  int n_branch = 0;  // cable i has branches 0 … last_joint(i) (serial: i)
  if (drive == DriveKind::Tendon)
    for (int i = 0; i < na; ++i) n_branch += tendon.last_joint(i) + 1;
  if (drive == DriveKind::Tendons)
    for (int i = 0; i < nm; ++i) n_branch += tendons.last_joint(i) + 1;
  const int n_red = drive == DriveKind::Tendon ? na : 0;
  int n_mc = 0, n_jc = 0, n_lock = 0;
  for (int i = 0; i < nm; ++i) n_mc += coulomb_motor(i) > 0.0;
  for (int i = 0; i < na; ++i) {
    n_jc += coulomb_joint(i) > 0.0;
    n_lock += lock_joint(i) != 0.0;
  }
  n_sites = n_branch + n_red + n_mc + n_jc + n_lock;
  G = Eigen::MatrixXd::Zero(n_sites, nv);
  site_kind.resize(n_sites); site_i.resize(n_sites); site_b.resize(n_sites);
  D = Eigen::MatrixXd::Zero(nv, nv);
  int k = 0;
  if (drive == DriveKind::Tendon) {
    for (int i = 0; i < na; ++i)
      for (int b = 0; b <= tendon.last_joint(i); ++b, ++k) {
        for (int j = b; j <= tendon.last_joint(i); ++j) G(k, j) = tendon.K(i, j);  // Ṡ_ib = Σ_{j≥b} K_ij q̇_j
        site_kind(k) = static_cast<int>(SiteKind::Branch); site_i(k) = i; site_b(k) = b;
        D += tendon.nu(i, b) * G.row(k).transpose() * G.row(k);
      }
    for (int i = 0; i < na; ++i, ++k) {
      G(k, i) = 1.0;
      site_kind(k) = static_cast<int>(SiteKind::Reducer); site_i(k) = i; site_b(k) = i;
    }
    D += Gm.transpose() * viscous_motor.asDiagonal() * Gm;
    D.diagonal() += viscous_joint;
  } else if (drive == DriveKind::Tendons) {
    for (int i = 0; i < nm; ++i)  // every branch of every tendon: g_ib = [0 … 0 K_ib … K_i,last]
      for (int b = 0; b <= tendons.last_joint(i); ++b, ++k) {
        for (int j = b; j <= tendons.last_joint(i); ++j) G(k, j) = tendons.K(i, j);
        site_kind(k) = static_cast<int>(SiteKind::Branch); site_i(k) = i; site_b(k) = b;
        D += tendons.nu(i, b) * G.row(k).transpose() * G.row(k);  // ν Ṡ², implicit
      }
    D += Gm.transpose() * viscous_motor.asDiagonal() * Gm;
    D.diagonal() += viscous_joint;
  } else {
    for (int i = 0; i < na; ++i) {
      const double N = ratio(i), d = damping_motor(i);
      D(i, i) += viscous_joint(i) + d * N * N;
      D(na + i, na + i) += viscous_motor(i) + d;
      D(i, na + i) -= d * N;
      D(na + i, i) -= d * N;
    }
  }
  for (int i = 0; i < nm; ++i)
    if (coulomb_motor(i) > 0.0) {
      if (slaved_motors()) G.row(k) = Gm.row(i); else G(k, na + i) = 1.0;
      site_kind(k) = static_cast<int>(SiteKind::MotorCoulomb); site_i(k) = i; site_b(k) = 0; ++k;
    }
  for (int i = 0; i < na; ++i)
    if (coulomb_joint(i) > 0.0) {
      G(k, i) = 1.0;
      site_kind(k) = static_cast<int>(SiteKind::JointCoulomb); site_i(k) = i; site_b(k) = 0; ++k;
    }
  for (int i = 0; i < na; ++i)
    if (lock_joint(i) != 0.0) {  // a bilateral velocity constraint: an unbounded friction site
      G(k, i) = 1.0;
      site_kind(k) = static_cast<int>(SiteKind::Lock); site_i(k) = i; site_b(k) = 0; ++k;
    }
  Gt = G.transpose();
  site_begin.resize(n_sites); site_end.resize(n_sites);
  site_norm = G.rowwise().norm();
  if (!(pgs_speed_tolerance >= 0.0)) return Status::InvalidModel;
  for (int s = 0; s < n_sites; ++s) {
    int b = 0, e = nv;
    while (b < nv && G(s, b) == 0.0) ++b;
    while (e > b && G(s, e - 1) == 0.0) --e;
    site_begin(s) = b; site_end(s) = e;
  }
  tree.build(body.pin);
  return Status::Ok;
}

inline SimData::SimData(const SimModel& m)
    : body(m.body),
      q(Eigen::VectorXd::Zero(m.na)), qd(Eigen::VectorXd::Zero(m.na)),
      q_motor(Eigen::VectorXd::Zero(m.nm)), qd_motor(Eigen::VectorXd::Zero(m.nm)),
      q_tree(Eigen::VectorXd::Zero(m.nq_tree())), v_tree(Eigen::VectorXd::Zero(m.nq_tree())),
      tree(m.tree), ML(Eigen::MatrixXd::Zero(m.nq_tree(), m.na)), M(Eigen::MatrixXd::Zero(m.nv, m.nv)),
      Mt(Eigen::MatrixXd::Zero(m.nv, m.nv)), Linv(Eigen::MatrixXd::Zero(m.nv, m.nv)),
      Minv(Eigen::MatrixXd::Zero(m.nv, m.nv)),
      B(Eigen::MatrixXd::Zero(m.nv, m.n_sites)),
      F(Eigen::VectorXd::Zero(m.nv)), v(Eigen::VectorXd::Zero(m.nv)), rhs(Eigen::VectorXd::Zero(m.nv)),
      vfree(Eigen::VectorXd::Zero(m.nv)), Lrecip(Eigen::VectorXd::Zero(m.nv)), Wdiag(Eigen::VectorXd::Zero(m.n_sites)),
      Wrecip(Eigen::VectorXd::Zero(m.n_sites)),
      sdot(Eigen::VectorXd::Zero(m.n_sites)),
      u(Eigen::VectorXd::Zero(m.n_sites)), p(Eigen::VectorXd::Zero(m.n_sites)),
      lo(Eigen::VectorXd::Zero(m.n_sites)), hi(Eigen::VectorXd::Zero(m.n_sites)), ext(Eigen::VectorXd::Zero(m.na)),
      stop_depth(Eigen::VectorXd::Zero(m.nq_tree())),
      active(Eigen::VectorXi::Zero(m.n_sites)), site_state(Eigen::VectorXi::Zero(m.n_sites)),
      fin_e(Eigen::MatrixXd::Zero(m.nv, m.nv)), fin_f(Eigen::MatrixXd::Zero(m.nv, m.nv)),
      fin_c(Eigen::MatrixXd::Zero(m.nv, m.nv)), fin_piv(Eigen::VectorXd::Zero(m.nv)),
      fin_v(Eigen::VectorXd::Zero(m.nv)), fin_vb(Eigen::VectorXd::Zero(m.nv)),
      fin_p(Eigen::VectorXd::Zero(m.n_sites)), fin_site(Eigen::VectorXi::Zero(m.nv)),
      fin_state(Eigen::VectorXi::Zero(m.n_sites)),
      v_end(Eigen::VectorXd::Zero(m.nv)),
      q_motor_meas(Eigen::VectorXd::Zero(m.nm)), torque_motor_meas(Eigen::VectorXd::Zero(m.nm)),
      torque_motor_cmd(Eigen::VectorXd::Zero(m.nm)), torque_motor(Eigen::VectorXd::Zero(m.nm)),
      q_est(Eigen::VectorXd::Zero(m.na)), v_est(Eigen::VectorXd::Zero(m.na)),
      q_est_prev(Eigen::VectorXd::Zero(m.na)), integral(Eigen::VectorXd::Zero(std::max(m.na, m.nm))),
      v_motor_est(Eigen::VectorXd::Zero(m.nm)), qm_meas_prev(Eigen::VectorXd::Zero(m.nm)),
      tmp_na(Eigen::VectorXd::Zero(m.na)),
      tension(Eigen::MatrixXd::Zero(m.nm, m.na)), tension_motor(Eigen::VectorXd::Zero(m.nm)),
      qd_motor_prev(Eigen::VectorXd::Zero(m.nm)),
      tendon_data(m.drive == DriveKind::Tendons ? make_tendon_data(m.tendons) : TendonData{}) {}

inline void SimData::reset(const Eigen::VectorXd& q0, std::uint64_t seed) {
  q = q0;
  qd.setZero();
  qd_motor.setZero();
  qd_motor_prev.setZero();
  q_motor.setZero();
  time = 0.0;
  step_count = 0;
  p.setZero();
  site_state.setZero();
  integral.setZero();
  v_est.setZero();
  v_motor_est.setZero();
  tension.setZero();
  tension_motor.setZero();
  torque_motor.setZero();
  torque_motor_cmd.setZero();
  first_control = true;
  v_end_valid = false;
  rng = Rng{};
  rng.state = seed;
  work_motor = work_external = dissipated = numerical_loss = 0.0;
  stop_depth.setZero();
  stops_touched = 0;
  stop_contact_time = 0.0;
}

}  // namespace tendyn

// tendyn — fixed-step simulator of a tendon-driven device with friction inside the loop.
//
// Mechanics: a Pinocchio tree (joint side) seen through an affine map to the active joints,
// q_tree = L q_a + c (identity for serial chains; the CEA parallelogram otherwise, S2 eq. 12:
// Γ_a = Lᵀ Γ_tree). Two kinds of drives:
//   * Tendon — inextensible cables (S0's hypothesis): motors are slaved, q_m = R_m⁻¹ K q_a; the
//     rotor inertia is reflected through the lossless map; the friction of every cable branch
//     (S0 eqs. 11–12) and every reducer (eq. 9–10) acts where it is, on the branch velocity
//     Ṡ_ib = Σ_{j=b..last_joint(i)} K_ij q̇_j and on the driven joint.
//   * Tendons — N+1 tendons (issue 19; include/tendyn/tendons.hpp): nm = na + 1 rigid inextensible tendons
//     share the na joints, K (nm, na) [m]: tendon velocities ℓ̇ = K q̇, motor velocities q̇_m = R_m⁻¹ K q̇ =: G_m q̇
//     (G_m (nm, na), R_m = diag(motor radii)). Reduced dynamics (d'Alembert over the na joint coordinates, the
//     motors slaved by the constraint; virtual work C_mᵀ δq_m = (G_mᵀ C_m)ᵀ δq):
//         (M(q) + G_mᵀ I_m G_m) q̈ + b(q, q̇) = G_mᵀ C_m − Σ_ib g_ibᵀ f_ib   (+ external, terms, joint friction)
//     with I_m = diag(rotor inertias) and, for branch b of tendon i (between joint b − 1 and joint b, branch 0
//     from the motor pulley to joint 0), its sliding velocity Ṡ_ib = g_ib q̇, g_ib = [0 … 0 K_ib … K_i,last]
//     (the same Ṡ as tendons.hpp and routing.hpp), and its friction force f_ib ∈ τ0_ib Sgn(Ṡ_ib) + ν_ib Ṡ_ib
//     [N] (S0 eq. 12, motion sign restored: ERRATA; set-valued at Ṡ = 0: a stuck branch holds any
//     |f| ≤ τ0 — the square drive's Branch site, solved by the same Moreau–Jean step below; with the
//     tension-proportional β of S0 eq. 11 the bound is τ0 + β max(|T_up|, |T_down|), the tensions estimated at
//     the last step as for the square drive). Power:
//     C_mᵀ q̇_m = d/dt(½ q̇ᵀ(M + G_mᵀ I_m G_m) q̇ + U) + Σ f_ib Ṡ_ib, each f_ib Ṡ_ib = τ0|Ṡ| + ν Ṡ² ≥ 0.
//     The rigid tendons carry one internal tension the joints do not feel (Kᵀh = 0); each tendon's tension
//     still follows from its own motor, t_i = (C_m,i − I_m,i q̈_m,i)/r_m,i (update_tensions). Bearings and
//     reducers of the square drive are not modelled on N+1 tendons (refused by the loader). Joint-space control allocates the PID torque to tensions with tendons.hpp's feedforward
//     (floors = the tendons' pretension; with tendon_loss_compensation, the branch losses at the reference
//     velocity too: the S0 eq. 12 compensation in the loop).
//   * Elastic — a capstan drive per active joint: motor inertia on a spring K_T (motor side) to
//     the joint through ratio N (S2 §V-B); Coulomb/viscous friction on the motor.
// Friction is solved at the velocity level every step (Moreau–Jean time stepping): each friction
// site k has a Jacobian row g_k and a box [lo_k, hi_k] for its force; the impulses follow from a
// projected Gauss–Seidel on the Delassus matrix W = G (M + hD)⁻¹ Gᵀ, warm-started, run in velocity
// space: W is never formed; with B = (M + hD)⁻¹ Gᵀ and the diagonal W_kk = g_k B_k, a site update reads
// its velocity u_k = g_k v (a dense length-nv sum) and moves v by B_k Δp_k — the same iterates as
// the sweep on W, at two length-nv products per site instead of one length-n_sites one. The solve ends
// exactly (detail::finish_friction): for the classification the warm start or a sweep reaches (stuck /
// sliding at a bound) v is projected onto the stuck sites' rest, active-set changes as the friction laws
// ask, kept only if Coulomb's law then holds at every site. A site whose
// force stays inside its box does not move: true stick, no creep; outside it slides with the
// bound force (Coulomb). Viscous terms are implicit (D). Reducers get an asymmetric box: the
// loss (1 − η_d)|n M_p| when the pulley drives the joint, (1 − η_d)/(2η_d − 1)|n M_p| when the joint
// back-drives it (S0 eq. 10), unbounded when self-locking (η_d ≤ 0.5).
// Sensors: quantised motor encoders, motor-torque (current) noise, sampling at the log rate.
// Control: torque mode, joint-space or motor-space PID at a control rate, and a C hook.
// Rigid body: mass matrix and bias forces in one kinematics pass (tree_dynamics.hpp) for trees of
// revolute / prismatic joints; Pinocchio's crba + nonLinearEffects for anything else.
// Model/Data convention; step() and run() allocate nothing; randomness from a seeded splitmix64.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/energy.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include "tendyn/losses.hpp"
#include "tendyn/rigid_body.hpp"
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

/// Deterministic normal variates: splitmix64 + Box–Muller (same stream on every platform).
struct Rng {
  std::uint64_t state = 0;
  bool has_spare = false;
  double spare = 0.0;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  double normal() {
    if (has_spare) { has_spare = false; return spare; }
    const double u1 = uniform(), u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 6.283185307179586 * u2;
    spare = r * std::sin(a);
    has_spare = true;
    return r * std::cos(a);
  }
};

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

// ---- pieces of a step --------------------------------------------------------------------------

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

/// Branch speed [m/s] at or below which a branch counts as at rest in the simulator (the velocity a
/// stuck site keeps is the solver's rounding residue, ~1e-18 m/s).
constexpr double kRestSpeed = 1e-12;

namespace detail {
/// Where impulse p sits in its box [lo, hi]: 0 inside, 1 at lo, 2 at hi (a zero-width box counts as inside).
inline int site_class(double p, double lo, double hi) { return lo == hi ? 0 : p <= lo ? 1 : p >= hi ? 2 : 0; }

/// Compile-time size N (1 … 8, loops unrolled) or the run-time n (N ≤ 0).
template <int N>
constexpr int dim(int n) { return N > 0 ? N : n; }
}  // namespace detail

/// Velocity of friction site k [m/s or rad/s]: g_k v as a dense ascending sum over the nv entries
/// (the zeros before the first nonzero add nothing: for a branch this is Ṡ_ib = Σ_{j=b..i} K_ij q̇_j, summed
/// from joint b up; the statics of losses.hpp sum the same terms from the driven joint down).
template <int NV = 0>
inline double site_speed(const SimModel& m, int k, const double* v) {
  const int nv = detail::dim<NV>(m.nv);
  const double* g = m.Gt.data() + static_cast<Eigen::Index>(k) * nv;
  double s = 0.0;
  for (int j = 0; j < nv; ++j) s += g[j] * v[j];
  return s;
}

/// Friction force boxes [lo, hi] of every site from the current tension estimate and the site speeds
/// d.sdot at the start of the step [N or N·m].
inline void friction_bounds(const SimModel& m, SimData& d) {
  for (int k = 0; k < m.n_sites; ++k) {
    const int i = m.site_i(k), b = m.site_b(k);
    double lo = 0.0, hi = 0.0;
    switch (static_cast<SiteKind>(m.site_kind(k))) {
      case SiteKind::Branch: {
        double sdot = d.sdot(k);
        // A stuck site keeps a PGS residue of ~1e-18 m/s: it is at rest (static threshold α p, S0 eq. 7),
        // not sliding at that speed (β p + h0).
        if (std::abs(sdot) <= kRestSpeed) sdot = 0.0;
        if (m.drive == DriveKind::Tendons) {  // S0 eqs. 11–12: τ0 + β|τ_drive| at rest (break-away) and sliding
          const double up = b == 0 ? d.tension_motor(i) : d.tension(i, b - 1);
          hi = m.tendons.tau0(i, b) + m.tendons.beta(i, b) * std::max(std::abs(up), std::abs(d.tension(i, b)));
          lo = -hi;
          break;
        }
        const BranchFriction f = branch_friction(m.tendon, i, b, sdot);
        const double up = b == 0 ? d.tension_motor(i) : d.tension(i, b - 1);
        const double drive = std::max(std::abs(up), std::abs(d.tension(i, b)));
        hi = f.a + f.b * drive;
        lo = -hi;
        break;
      }
      case SiteKind::Reducer: {
        const double eta = m.tendon.reducer_efficiency(i);
        const double out = m.tendon.reducer_ratio(i) * m.tendon.driven_radius(i) * d.tension(i, i);  // n M_p
        const double driving = (1.0 - eta) * std::abs(out);
        const double back = reducer_self_locking(eta) ? 1e300 : (1.0 - eta) / (2.0 * eta - 1.0) * std::abs(out);
        // the loss opposes motion; back-driving (motion against n M_p) meets the larger bound
        if (out >= 0.0) { lo = -driving; hi = back; } else { lo = -back; hi = driving; }
        break;
      }
      case SiteKind::MotorCoulomb: hi = m.coulomb_motor(i); lo = -hi; break;
      case SiteKind::JointCoulomb: hi = m.coulomb_joint(i); lo = -hi; break;
      case SiteKind::Lock: hi = 1e300; lo = -hi; break;
    }
    d.lo(k) = lo;
    d.hi(k) = hi;
  }
}

/// Tensions along each cable after a step, from the motor torque net of rotor inertia and the
/// friction forces found on the branches (tension drop Δ = −λ + ν Ṡ, S0 eq. 6). The branch speeds are
/// the site speeds d.u at the end of the step (branch sites come first, in this order).
inline void update_tensions(const SimModel& m, SimData& d) {
  if (!m.slaved_motors()) return;
  const bool np1 = m.drive == DriveKind::Tendons;
  const double h = m.dt;
  int k = 0;
  for (int i = 0; i < m.nm; ++i) {
    const double accel = (d.qd_motor(i) - d.qd_motor_prev(i)) / h;
    const double r_m = np1 ? m.tendons.motor_radius(i) : m.tendon.motor_radius(i);
    const int last = np1 ? m.tendons.last_joint(i) : m.tendon.last_joint(i);
    double t = (d.torque_motor(i) - m.rotor_inertia(i) * accel) / r_m;
    d.tension_motor(i) = t;
    for (int b = 0; b <= last; ++b, ++k) {
      t -= -d.p(k) / h + (np1 ? m.tendons.nu(i, b) : m.tendon.nu(i, b)) * d.u(k);
      d.tension(i, b) = t;
    }
  }
}

namespace detail {

/// Exact finish of the friction solve for a classification of the sites (issue 12), starting from the
/// current iterate's: a site at a bound slides with that bound's force, a site inside its box sticks (the
/// set S). The velocity of that case is the (M + hD)-orthogonal projection of v onto {v : g_k v = 0, k ∈ S}:
/// with b_k = (M + hD)⁻¹ g_kᵀ and ⟨b_j, b_k⟩ = g_j b_k = W_jk, a Gram–Schmidt over S (site order) keeps at
/// most nv independent sites (velocity directions e_i, force directions f_i = Σ c_ij g_j, f_i e_j = 0 for
/// i ≠ j); a site whose pivot f e is below 1e-9 W_kk is a combination of kept ones (the last branch of a
/// cable and its reducer, the redundant sites of a stuck chain) and keeps its impulse. Then
/// v⁺ = v − Σ_i e_i (f_i v)/(f_i e_i) and the kept impulses move by Σ_i α_i c_i. Active-set changes, at most
/// max_changes: a kept impulse that leaves its box is held at the bound it crossed (another redundant site
/// takes the share, or the site slides); a site at a bound that moves the way its force pushes is released
/// into S (it sticks). Accepted only when the result satisfies the friction laws — kept impulses inside
/// their boxes, every stuck site at rest and every sliding site moving against its force, to
/// tol_k = pgs_speed_tolerance ‖g_k‖; else p and v are left as they were. Returns true if accepted.
template <int NV>
inline bool finish_friction(const SimModel& m, SimData& d, const int* active, int n_active, int max_changes) {
  const int nv = dim<NV>(m.nv);
  if (NV <= 0 && nv > 64) return false;
  const double *B = d.B.data(), *Gt = m.Gt.data(), *W = d.Wdiag.data();
  const double *lo = d.lo.data(), *hi = d.hi.data(), *gn = m.site_norm.data();
  const double vtol = m.pgs_speed_tolerance;
  double* pw = d.fin_p.data();  // the impulses of this attempt
  int* state = d.fin_state.data();  // 0 sticks (in S), 1 slides at lo, 2 slides at hi
  for (int a = 0; a < n_active; ++a) {
    const int k = active[a];
    pw[k] = d.p(k);
    state[k] = site_class(pw[k], lo[k], hi[k]);
  }
  double* vb = d.fin_vb.data();  // v at the impulses pw
  for (int j = 0; j < nv; ++j) vb[j] = d.v(j);
  double *E = d.fin_e.data(), *Fd = d.fin_f.data(), *C = d.fin_c.data();
  double* piv = d.fin_piv.data();  // 1 / (f_i e_i)
  double* v = d.fin_v.data();
  int* kept = d.fin_site.data();
  double alpha[NV > 0 ? NV : 64], dp[NV > 0 ? NV : 64];
  int r = 0;
  // orthogonalise site k against the kept slots and keep it as slot r if independent; v moves by its share
  auto append = [&](int k) {
    double* e = E + r * nv;
    double* f = Fd + r * nv;
    double* c = C + r * nv;
    for (int j = 0; j < nv; ++j) { e[j] = B[k * nv + j]; f[j] = Gt[k * nv + j]; c[j] = 0.0; }
    c[r] = 1.0;
    for (int i = 0; i < r; ++i) {  // modified Gram–Schmidt in the (M + hD) inner product
      double fe = 0.0;
      for (int j = 0; j < nv; ++j) fe += Fd[i * nv + j] * e[j];
      const double t = fe * piv[i];
      for (int j = 0; j < nv; ++j) {
        e[j] -= t * E[i * nv + j];
        f[j] -= t * Fd[i * nv + j];
        c[j] -= t * C[i * nv + j];
      }
    }
    double pv = 0.0;
    for (int j = 0; j < nv; ++j) pv += f[j] * e[j];
    if (!(pv > 1e-9 * W[k])) return false;  // dependent on the kept sites
    piv[r] = 1.0 / pv;
    double fv = 0.0;
    for (int j = 0; j < nv; ++j) fv += f[j] * v[j];
    alpha[r] = -fv * piv[r];
    for (int j = 0; j < nv; ++j) v[j] += alpha[r] * e[j];
    kept[r++] = k;
    return true;
  };
  bool rebuild = true;
  for (int change = 0;; ++change) {
    if (change > max_changes) return false;
    if (rebuild) {  // the projection from vb over S in site order
      for (int j = 0; j < nv; ++j) v[j] = vb[j];
      r = 0;
      for (int a = 0; a < n_active && r < nv; ++a)
        if (state[active[a]] == 0) append(active[a]);
      rebuild = false;
    }
    int out = -1;  // the first kept site whose impulse leaves its box: hold it at the bound it crossed
    for (int j = 0; j < r && out < 0; ++j) {
      dp[j] = 0.0;
      for (int i = j; i < r; ++i) dp[j] += alpha[i] * C[i * nv + j];
      const double pk = pw[kept[j]] + dp[j];
      if (!(pk >= lo[kept[j]] && pk <= hi[kept[j]])) out = j;
    }
    if (out >= 0) {
      const int k = kept[out];
      const bool low = pw[k] + dp[out] < lo[k];
      const double step = (low ? lo[k] : hi[k]) - pw[k];
      pw[k] += step;
      state[k] = low ? 1 : 2;
      for (int j = 0; j < nv; ++j) vb[j] += B[k * nv + j] * step;
      rebuild = true;
      continue;
    }
    // every site obeys its law at the projected velocity (the kept impulses only change v through e_i)
    int wrong = -1;
    for (int a = 0; a < n_active && wrong < 0; ++a) {
      const int k = active[a];
      const double uk = site_speed<NV>(m, k, v), tk = vtol * gn[k];
      if (state[k] == 1 ? uk < -tk : state[k] == 2 ? uk > tk : std::abs(uk) > tk) wrong = k;
    }
    if (wrong < 0) break;
    // a stuck site not at rest (dependent, but not exactly), or one that cannot join S: give up
    if (state[wrong] == 0 || r == nv) return false;
    state[wrong] = 0;  // pushed the way its force acts: it sticks (its impulse moves inside the box)
    if (!append(wrong)) return false;
  }
  for (int j = 0; j < r; ++j) pw[kept[j]] += dp[j];
  for (int a = 0; a < n_active; ++a) d.p(active[a]) = pw[active[a]];
  for (int j = 0; j < nv; ++j) d.v(j) = v[j];
  return true;
}

/// Projected Gauss–Seidel (SOR) on the friction impulses p, warm-started, in velocity space: v starts at
/// v_free + B p and follows every update (v += B_k Δp_k); u_k = g_k v is the site velocity G v_free + W p
/// of the sweep on the Delassus matrix W, which is never formed. Needs d.B, d.Wdiag and the boxes scaled
/// to impulses (h lo, h hi) with p clamped into them. With pgs_exact_finish, the warm start's classification
/// is tried exactly first (finish_friction) and each new classification a sweep reaches after it; an accepted
/// finish ends the solve (d.pgs_finished = 1). Returns the sweeps used (0 when the warm start finished).
template <int NV>
inline int solve_friction(const SimModel& m, SimData& d) {
  const int nv = dim<NV>(m.nv), ns = m.n_sites;
  double* v = d.v.data();
  double* p = d.p.data();
  const double* B = d.B.data();
  const double *lo = d.lo.data(), *hi = d.hi.data(), *W = d.Wdiag.data(), *rW = d.Wrecip.data();
  for (int j = 0; j < nv; ++j) v[j] = d.vfree(j);
  for (int k = 0; k < ns; ++k)
    if (p[k] != 0.0)
      for (int j = 0; j < nv; ++j) v[j] += B[k * nv + j] * p[k];
  // the sites that take part this step: a nonzero box and a positive W_kk
  int* active = d.active.data();
  int na_sites = 0;
  for (int k = 0; k < ns; ++k)
    if (W[k] > 0.0 && !(lo[k] == 0.0 && hi[k] == 0.0)) active[na_sites++] = k;
  const double omega = m.pgs_relaxation;
  const double vtol = m.pgs_speed_tolerance;
  const double* gn = m.site_norm.data();
  const bool finish = m.pgs_exact_finish && vtol > 0.0;
  // classification of the iterate, site by site: 0 inside its box, 1 at lo, 2 at hi (hashed)
  auto classify = [&]() {
    std::uint64_t h = 1469598103934665603ull;
    for (int a = 0; a < na_sites; ++a) {
      const int k = active[a];
      h = (h ^ static_cast<std::uint64_t>(site_class(p[k], lo[k], hi[k]))) * 1099511628211ull;
    }
    return h;
  };
  d.pgs_finished = 0;
  // the warm start's classification first (no hold): in a step that sticks or slides as the last one, no sweep
  std::uint64_t tried = 0;  // the classification tried last
  if (finish) {
    if (finish_friction<NV>(m, d, active, na_sites, na_sites)) { d.pgs_finished = 1; return 0; }
    tried = classify();
  }
  for (int a = 0; a < na_sites; ++a) d.Wrecip(active[a]) = 1.0 / W[active[a]];  // the sweeps need 1/W_kk
  int it = 0;
  bool polish = false;  // the last sweep, plain Gauss–Seidel (ω = 1), after the speed test was met
  for (; it < m.pgs_max_iterations; ++it) {
    const double w = polish ? 1.0 : omega;
    double change = 0.0, pmax = 0.0;
    bool slow = vtol > 0.0;  // every site moved by at most vtol ‖g_k‖ in this sweep
    for (int a = 0; a < na_sites; ++a) {
      const int k = active[a];
      const double Wkk = W[k];
      const double uk = site_speed<NV>(m, k, v);
      const double pold = p[k];
      // 1/W_kk taken before the sweeps: no division on the chain of dependent site updates
      const double pk = std::max(lo[k], std::min(hi[k], pold - uk * (w * rW[k])));
      const double dp = pk - pold;
      change = std::max(change, std::abs(dp));
      pmax = std::max(pmax, std::abs(pk));
      slow = slow && std::abs(dp) * Wkk <= vtol * gn[k];
      p[k] = pk;
      if (dp != 0.0)
        for (int j = 0; j < nv; ++j) v[j] += B[k * nv + j] * dp;
    }
    // converged when the impulses stop changing, relative to the largest one
    if (polish || change <= m.pgs_tolerance * pmax || change == 0.0) { ++it; break; }
    if (finish) {  // a classification not tried yet in this step: try it exactly (nv holds at most)
      const std::uint64_t now = classify();
      if (now != tried) {
        if (finish_friction<NV>(m, d, active, na_sites, na_sites)) { d.pgs_finished = 1; ++it; break; }
        tried = now;
      }
    }
    // speed test met: one plain sweep more, which brings a stuck site on its own (or parallel to others, a
    // branch and its reducer) to rest to rounding — true stick, no creep — where an over-relaxed sweep
    // leaves −(ω − 1) of the last correction
    polish = slow;
  }
  return it;
}

/// The part of a step sized by nv, after the tree dynamics: assemble M and F, factor M + hD and invert it,
/// solve the friction impulses, leave v⁺ in d.vfree and the site speeds at v⁺ in d.u. Plain loops over
/// column-major storage; NV > 0 fixes nv at compile time. Allocates nothing.
template <int NV>
inline Status step_core(const SimModel& m, SimData& d, const Eigen::MatrixXd& Mtree, const Eigen::VectorXd& nle) {
  const int nv = dim<NV>(m.nv), na = m.na, ns = m.n_sites;
  const double h = m.dt;
  double* M = d.M.data();
  double* F = d.F.data();
  const double* Mr = m.M_rotor.data();
  for (int t = 0; t < nv * nv; ++t) M[t] = Mr[t];
  for (int j = 0; j < nv; ++j) F[j] = 0.0;
  if (m.identity_map) {  // serial chain: no projection
    const double* Mt = Mtree.data();
    for (int c = 0; c < na; ++c)
      for (int r = 0; r < na; ++r) M[r + c * nv] += Mt[r + c * na];
    for (int i = 0; i < na; ++i) F[i] = -nle(i);
  } else {  // M_a = Lᵀ M L, b_a = Lᵀ nle
    d.ML.noalias() = Mtree.lazyProduct(m.L);
    d.M.topLeftCorner(na, na).noalias() += m.L.transpose().lazyProduct(d.ML);
    d.F.head(na).noalias() = -m.L.transpose().lazyProduct(nle);
  }
  for (int i = 0; i < na; ++i) F[i] += d.ext(i);
  if (m.slaved_motors()) {  // Kᵀ R_m⁻¹ C_m = G_mᵀ C_m
    const double* G = m.Gm.data();
    const int nm = m.nm;
    for (int j = 0; j < na; ++j) {
      double s = 0.0;
      for (int i = 0; i < nm; ++i) s += G[i + j * nm] * d.torque_motor(i);
      F[j] += s;
    }
  } else {
    for (int i = 0; i < na; ++i) {
      const double spring = m.stiffness_motor(i) * (d.q_motor(i) - m.ratio(i) * d.q(i));
      F[i] += m.ratio(i) * spring;
      F[na + i] = d.torque_motor(i) - spring;
    }
  }
  double* v = d.v.data();
  for (int i = 0; i < na; ++i) {
    v[i] = d.qd(i);
    if (m.drive == DriveKind::Elastic) v[na + i] = d.qd_motor(i);
  }

  // (M + hD) v⁺ = M v + h F + Gᵀ p. Cholesky factor L of M + hD (lower triangle of d.Mt), then
  // (M + hD)⁻¹ = L⁻ᵀ L⁻¹ (L⁻¹ in d.Linv): one inverse serves v_free and every column of B.
  double* L = d.Mt.data();
  double* Li = d.Linv.data();
  double* Mi = d.Minv.data();
  double* rd = d.Lrecip.data();  // reciprocal diagonal of L
  const double* D = m.D.data();
  for (int c = 0; c < nv; ++c)
    for (int r = c; r < nv; ++r) L[r + c * nv] = M[r + c * nv] + h * D[r + c * nv];
  if (d.stops_touched) {  // end stops, linearly implicit: (M + hD + Σ (h B_s + h² K_s) l_k l_kᵀ) v⁺ = … − h K_s δ_k l_k
    const double a = h * m.stop_damping + h * h * m.stop_stiffness;
    for (int k = 0; k < m.L.rows(); ++k) {
      const double dk = d.stop_depth(k);
      if (dk == 0.0) continue;
      for (int c = 0; c < na; ++c) {
        const double lc = m.L(k, c);
        if (lc == 0.0) continue;
        F[c] -= m.stop_stiffness * dk * lc;
        for (int r = c; r < na; ++r) L[r + c * nv] += a * m.L(k, r) * lc;
      }
    }
  }
  for (int j = 0; j < nv; ++j) {
    double diag = L[j + j * nv];
    for (int k = 0; k < j; ++k) diag -= L[j + k * nv] * L[j + k * nv];
    if (!(diag > 0.0)) return Status::InvalidModel;  // singular inertia
    const double ljj = std::sqrt(diag);
    L[j + j * nv] = ljj;
    rd[j] = 1.0 / ljj;
    for (int i = j + 1; i < nv; ++i) {
      double s = L[i + j * nv];
      for (int k = 0; k < j; ++k) s -= L[i + k * nv] * L[j + k * nv];
      L[i + j * nv] = s * rd[j];
    }
  }
  for (int j = 0; j < nv; ++j) {  // L⁻¹, column j, rows i ≥ j
    Li[j + j * nv] = rd[j];
    for (int i = j + 1; i < nv; ++i) {
      double s = 0.0;
      for (int k = j; k < i; ++k) s += L[i + k * nv] * Li[k + j * nv];
      Li[i + j * nv] = -s * rd[i];
    }
  }
  for (int j = 0; j < nv; ++j)  // (L⁻¹)ᵀ L⁻¹, symmetric
    for (int i = j; i < nv; ++i) {
      double s = 0.0;
      for (int k = i; k < nv; ++k) s += Li[k + i * nv] * Li[k + j * nv];
      Mi[i + j * nv] = Mi[j + i * nv] = s;
    }
  double* vf = d.vfree.data();
  double* rhs = d.rhs.data();
  for (int r = 0; r < nv; ++r) {
    double s = 0.0;
    for (int c = 0; c < nv; ++c) s += M[r + c * nv] * v[c];
    rhs[r] = s + h * F[r];
  }
  for (int r = 0; r < nv; ++r) {
    double s = 0.0;
    for (int c = 0; c < nv; ++c) s += Mi[r + c * nv] * rhs[c];
    vf[r] = s;
  }
  // site speeds at the step start: those found at the end of the last step while v is the same (bit for
  // bit), else summed afresh (first step, or a state set from outside)
  bool same_v = d.v_end_valid;
  for (int j = 0; j < nv && same_v; ++j) same_v = v[j] == d.v_end(j);
  if (same_v)
    for (int k = 0; k < ns; ++k) d.sdot(k) = d.u(k);
  else
    for (int k = 0; k < ns; ++k) d.sdot(k) = site_speed<NV>(m, k, v);
  friction_bounds(m, d);
  const bool finish = m.pgs_exact_finish && m.pgs_speed_tolerance > 0.0;
  bool any = false;
  for (int k = 0; k < ns; ++k) {
    d.lo(k) *= h; d.hi(k) *= h;
    any = any || d.lo(k) != 0.0 || d.hi(k) != 0.0;
    // warm start: with the exact finish, a site that slid at the end of the last step starts at its new
    // bound (it slides on unless the solve says otherwise); the others at their impulse clamped into the box
    const int st = finish ? d.site_state(k) : 0;
    d.p(k) = st == 1 ? d.lo(k) : st == 2 ? d.hi(k) : std::max(d.lo(k), std::min(d.hi(k), d.p(k)));
  }
  if (any) {
    // B = (M + hD)⁻¹ Gᵀ over the nonzero range of each g_k; W_kk = g_k B_k
    double* B = d.B.data();
    const double* Gt = m.Gt.data();
    for (int k = 0; k < ns; ++k) {
      double* bk = B + k * nv;
      const double* g = Gt + k * nv;
      for (int r = 0; r < nv; ++r) bk[r] = 0.0;
      for (int j = m.site_begin(k); j < m.site_end(k); ++j)
        for (int r = 0; r < nv; ++r) bk[r] += Mi[r + j * nv] * g[j];
      d.Wdiag(k) = site_speed<NV>(m, k, bk);
    }
    d.pgs_iterations = solve_friction<NV>(m, d);
    for (int k = 0; k < ns; ++k) d.site_state(k) = site_class(d.p(k), d.lo(k), d.hi(k));  // where each site ended
    // v⁺ = v_free + B p, summed afresh (not the running sum of the sweeps)
    for (int k = 0; k < ns; ++k) {
      const double pk = d.p(k);
      if (pk != 0.0)
        for (int r = 0; r < nv; ++r) vf[r] += B[k * nv + r] * pk;
    }
  } else {
    d.pgs_iterations = 0;  // no friction this step (p clamped to zero)
    d.site_state.setZero();
  }
  double diss = 0.0;
  for (int k = 0; k < ns; ++k) {
    d.u(k) = site_speed<NV>(m, k, vf);
    diss += d.u(k) * d.p(k);
  }
  d.dissipated -= diss;
  for (int j = 0; j < nv; ++j) d.v_end(j) = vf[j];
  d.v_end_valid = true;
  // viscous dissipation vᵀ D v over the step
  double visc = 0.0;
  for (int c = 0; c < nv; ++c) {
    double s = 0.0;
    for (int r = 0; r < nv; ++r) s += D[r + c * nv] * vf[r];
    visc += vf[c] * s;
  }
  d.dissipated += h * visc;
  // the step's own loss ½ Δvᵀ M Δv (M without hD and the stops' implicit terms: d.M is still the plain one;
  // v at the step start from d.qd / d.qd_motor: d.v is the friction solve's scratch by now)
  const auto v0 = [&](int r) { return r < na ? d.qd(r) : d.qd_motor(r - na); };
  double loss = 0.0;
  for (int c = 0; c < nv; ++c) {
    double s = 0.0;
    for (int r = 0; r < nv; ++r) s += M[r + c * nv] * (vf[r] - v0(r));
    loss += (vf[c] - v0(c)) * s;
  }
  if (m.drive == DriveKind::Elastic)   // the explicit capstan springs: their ΔV carries +½ h² (Δv_spring)ᵀ K_c … back
    for (int i = 0; i < na; ++i) {
      const double ds = vf[na + i] - m.ratio(i) * vf[i];
      loss -= h * h * m.stiffness_motor(i) * ds * ds;
    }
  d.numerical_loss += 0.5 * loss;
  return Status::Ok;
}

}  // namespace detail

/// Mass matrix and bias forces of the tree at (q_tree, v_tree): one pass (tree_dynamics.hpp) when the tree
/// allows it, else Pinocchio. Points Mtree / nle at the (both-triangle) mass matrix and the bias forces.
template <class V1, class V2>
inline void tree_dynamics(const SimModel& m, SimData& d, const V1& q, const V2& v, const Eigen::MatrixXd*& Mtree,
                          const Eigen::VectorXd*& nle) {
  if (m.tree.valid) {
    tree_mass_and_bias(m.tree, d.tree, q, v);
    Mtree = &d.tree.M;
    nle = &d.tree.nle;
  } else {
    pinocchio::crba(m.body.pin, d.body.pin, q);
    d.body.pin.M.triangularView<Eigen::StrictlyLower>() = d.body.pin.M.transpose().triangularView<Eigen::StrictlyLower>();
    pinocchio::nonLinearEffects(m.body.pin, d.body.pin, q, v);
    Mtree = &d.body.pin.M;
    nle = &d.body.pin.nle;
  }
}

/// Advance one step of m.dt. Inputs are those of control() plus the external joint torque.
template <class V1, class V2, class V3, class V4>
inline Status step(const SimModel& m, SimData& d, const V1& ref_q, const V2& ref_v, const V3& ff,
                   const V4& torque_ext) {
  const int na = m.na;
  const double h = m.dt;
  motor_state(m, d);
  if (d.step_count % m.control_decimation == 0) control(m, d, ref_q, ref_v, ff);
  for (int i = 0; i < na; ++i) d.ext(i) = torque_ext(i) - m.offset_joint(i);
  if (m.term_torque.cols() > 0) {
    const int last = static_cast<int>(m.term_torque.cols()) - 1;
    for (int i = 0; i < na; ++i) {   // linear interpolation in the joint's table, held beyond its ends
      const double x = (d.q(i) - m.term_lo(i)) / m.term_step(i);
      const int k = x <= 0.0 ? 0 : x >= last ? last - 1 : static_cast<int>(x);
      const double f = std::min(1.0, std::max(0.0, x - k));
      d.ext(i) -= (1.0 - f) * m.term_torque(i, k) + f * m.term_torque(i, k + 1);
    }
  }

  // Rigid body through the constraint map: M_a = Lᵀ M L, b_a = Lᵀ nle(q, v).
  const Eigen::MatrixXd* Mtree = nullptr;
  const Eigen::VectorXd* nle = nullptr;
  if (m.identity_map) {
    tree_dynamics(m, d, d.q, d.qd, Mtree, nle);
  } else {
    d.q_tree.noalias() = m.L.lazyProduct(d.q);
    d.q_tree += m.c;
    d.v_tree.noalias() = m.L.lazyProduct(d.qd);
    tree_dynamics(m, d, d.q_tree, d.v_tree, Mtree, nle);
  }
  d.stops_touched = 0;
  if (m.stop_lower.size()) {
    for (int k = 0; k < m.L.rows(); ++k) {
      const double qk = m.identity_map ? d.q(k) : d.q_tree(k);
      const double dk = qk > m.stop_upper(k) ? qk - m.stop_upper(k) : qk < m.stop_lower(k) ? qk - m.stop_lower(k) : 0.0;
      d.stop_depth(k) = dk;
      d.stops_touched += dk != 0.0;
    }
    if (d.stops_touched) d.stop_contact_time += h;
  }
  Status st;
  switch (m.nv) {  // fixed sizes for the small systems (loops unrolled), run-time size above
    case 1: st = detail::step_core<1>(m, d, *Mtree, *nle); break;
    case 2: st = detail::step_core<2>(m, d, *Mtree, *nle); break;
    case 3: st = detail::step_core<3>(m, d, *Mtree, *nle); break;
    case 4: st = detail::step_core<4>(m, d, *Mtree, *nle); break;
    case 5: st = detail::step_core<5>(m, d, *Mtree, *nle); break;
    case 6: st = detail::step_core<6>(m, d, *Mtree, *nle); break;
    case 7: st = detail::step_core<7>(m, d, *Mtree, *nle); break;
    case 8: st = detail::step_core<8>(m, d, *Mtree, *nle); break;
    default: st = detail::step_core<0>(m, d, *Mtree, *nle); break;
  }
  if (is_error(st)) return st;
  // work done by the motors / external torques over the step
  d.qd_motor_prev = d.qd_motor;
  for (int i = 0; i < na; ++i) {
    d.qd(i) = d.vfree(i);
    d.q(i) += h * d.qd(i);
    d.work_external += h * d.ext(i) * d.qd(i);
    if (m.drive == DriveKind::Elastic) {
      d.qd_motor(i) = d.vfree(na + i);
      d.q_motor(i) += h * d.qd_motor(i);
    }
  }
  if (m.stop_lower.size()) {  // the stops' energy, exactly: dissipated += −(work of the stop force) − ΔV_stop
    for (int k = 0; k < m.L.rows(); ++k) {
      double qk = m.c(k), vk = 0.0;
      for (int c = 0; c < na; ++c) {
        qk += m.L(k, c) * d.q(c);
        vk += m.L(k, c) * d.qd(c);
      }
      const double d0 = d.stop_depth(k);
      const double d1 = qk > m.stop_upper(k) ? qk - m.stop_upper(k) : qk < m.stop_lower(k) ? qk - m.stop_lower(k) : 0.0;
      const double f = d0 != 0.0 ? -m.stop_stiffness * (d0 + h * vk) - m.stop_damping * vk : 0.0;
      d.dissipated += -h * vk * f - 0.5 * m.stop_stiffness * (d1 * d1 - d0 * d0);
    }
  }
  motor_state(m, d);
  if (!all_finite(d.qd) || !all_finite(d.qd_motor) || !all_finite(d.q)) return Status::Diverged;
  for (int i = 0; i < m.nm; ++i) d.work_motor += h * d.torque_motor(i) * d.qd_motor(i);
  update_tensions(m, d);
  d.time += h;
  ++d.step_count;
  return Status::Ok;
}

/// Mechanical energy [J]: kinetic (links + rotors) + gravity + capstan springs + end-stop springs.
inline double mechanical_energy(const SimModel& m, SimData& d) {
  d.q_tree.noalias() = m.L * d.q;
  d.q_tree += m.c;
  d.v_tree.noalias() = m.L * d.qd;
  double e = pinocchio::computeKineticEnergy(m.body.pin, d.body.pin, d.q_tree, d.v_tree);
  e += pinocchio::computePotentialEnergy(m.body.pin, d.body.pin, d.q_tree);
  for (int k = 0; k < m.stop_lower.size(); ++k) {
    const double qk = d.q_tree(k);
    const double dk = qk > m.stop_upper(k) ? qk - m.stop_upper(k) : qk < m.stop_lower(k) ? qk - m.stop_lower(k) : 0.0;
    e += 0.5 * m.stop_stiffness * dk * dk;
  }
  for (int i = 0; i < m.nm; ++i) {
    e += 0.5 * m.rotor_inertia(i) * d.qd_motor(i) * d.qd_motor(i);
    if (m.drive == DriveKind::Elastic) {
      const double s = d.q_motor(i) - m.ratio(i) * d.q(i);
      e += 0.5 * m.stiffness_motor(i) * s * s;
    }
  }
  return e;
}

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

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
//
// The parts, one job each (this header includes them all, so every includer keeps working):
//   sim_noise.hpp    — the seeded random stream (Rng)
//   sim_model.hpp    — SimModel, SimData, finalize(), reset()
//   sim_control.hpp  — sensing and the controllers (motor_state, control)
//   sim_friction.hpp — friction sites, boxes, tensions, the PGS solve and its exact finish
//   sim_step.hpp     — tree dynamics, step(), mechanical_energy()
//   sim_run.hpp      — run() and SimLog
#pragma once

#include "tendyn/sim_noise.hpp"
#include "tendyn/sim_model.hpp"
#include "tendyn/sim_control.hpp"
#include "tendyn/sim_friction.hpp"
#include "tendyn/sim_step.hpp"
#include "tendyn/sim_run.hpp"

// tendyn — one step of the simulator (part of sim.hpp): the tree dynamics (one pass or Pinocchio), the part
// sized by nv (detail::step_core: assemble, factor, solve the friction, integrate), step() and the mechanical
// energy. step() allocates nothing.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/energy.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include "tendyn/sim_control.hpp"
#include "tendyn/sim_friction.hpp"
#include "tendyn/sim_model.hpp"

namespace tendyn {

namespace detail {

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
    // Through Eigen::Ref<const VectorXd>: the instantiation libpinocchio_default ships (declared extern by
    // Pinocchio's headers). Any other argument type instantiates crba's two passes over every joint type in each
    // translation unit that includes the simulator: ~60 s of compiler CPU (issue 39).
    pinocchio::crba(m.body.pin, d.body.pin, Eigen::Ref<const Eigen::VectorXd>(q));
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

}  // namespace tendyn

// tendyn — the simulator's friction solve (part of sim.hpp): the friction sites' speeds and force boxes, the
// cable tensions after a step, and the Moreau–Jean impulses: projected Gauss–Seidel in velocity space with its
// exact finish (detail::finish_friction, detail::solve_friction).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "tendyn/sim_model.hpp"

namespace tendyn {

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

}  // namespace detail

}  // namespace tendyn

// tendyn — statics of tendon transmissions with friction losses (S0 §II-C, §III; ERRATA S0).
//
// Loss law of a branch (S0 eqs. 11–12 with the motion sign restored, ERRATA):
//     Δτ = τ_up − τ_down = sgn(Ṡ) (a + b·|τ_drive|) + ν Ṡ
// where τ_up is the tension on the motor side of the branch, τ_down on the joint side, Ṡ the
// branch velocity relative to its link, τ_drive the tension on the side power comes from (the
// larger of |τ_up|, |τ_down|), a = τ_0 + bearing constants, b = β + bearing load terms.
// Friction opposing Ṡ makes the drop follow the direction of power flow by itself: when the
// joint back-drives the cable (τ Ṡ < 0) the tension rises toward the motor. With a = ν = 0 and
// b = 1 − e^{−μθ} one branch is a capstan wrap τ_out = τ_in e^{−μθ} (Euler–Eytelwein).
// For b < 1 the law is strictly monotone in the unknown tension, so both directions below have
// one solution in closed form, and they are exact inverses of each other while moving.
#pragma once

#include "tendyn/routing.hpp"

#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace tendyn {

// ---- elementary laws ------------------------------------------------------------------------

/// Inverse (back-driven) efficiency of a reducer, S0 eq. (10): η_i = (2η_d − 1)/η_d [-].
/// Valid when the dissipated power depends only on the output power. η_d ≤ 0.5 gives η_i ≤ 0:
/// the reducer is self-locking (see reducer_self_locking), not a negative efficiency.
inline double reducer_inverse_efficiency(double eta_d) { return (2.0 * eta_d - 1.0) / eta_d; }

/// True when a reducer of direct efficiency η_d cannot be back-driven (η_d ≤ 0.5).
inline bool reducer_self_locking(double eta_d) { return eta_d <= 0.5; }

/// Speed term h(n) of the bearing law, S0 eq. (8): h0 below n0, h1·n^(2/3) above [N·m].
/// @param speed  bearing angular speed [rad/s] (its magnitude is used)
inline double bearing_speed_term(double h0, double h1, double n0, double speed) {
  const double n = std::abs(speed);
  return n < n0 ? h0 : h1 * std::cbrt(n * n);
}

/// Friction torque of a radial ball bearing, S0 eq. (7) [N·m] (S0's α is static_coefficient, its
/// β dynamic_coefficient; both [m], torque per newton of radial load).
/// @param static_coefficient   break-away torque per radial load [m] (S0 α)
/// @param dynamic_coefficient  torque per radial load while turning [m] (S0 β)
/// @param load    radial load p on the bearing [N]
/// @param speed   angular speed n [rad/s]
/// @param applied external torque M_ext trying to turn the bearing [N·m]
/// @param stuck   set to true when the bearing does not turn (|M_ext| < static_coefficient · p at n = 0)
/// @return the torque the bearing opposes: M_ext when stuck; otherwise (dynamic_coefficient · p + h(n))
///         with the sign of the motion (of M_ext at break-away).
inline double bearing_friction_torque(double static_coefficient, double dynamic_coefficient, double h0,
                                      double h1, double n0, double load, double speed, double applied,
                                      bool* stuck) {
  if (speed == 0.0) {
    if (std::abs(applied) < static_coefficient * load) {
      if (stuck) *stuck = true;
      return applied;
    }
    if (stuck) *stuck = false;
    return std::copysign(dynamic_coefficient * load + h0, applied);
  }
  if (stuck) *stuck = false;
  return std::copysign(dynamic_coefficient * load + bearing_speed_term(h0, h1, n0, speed), speed);
}

/// Capstan (Euler–Eytelwein): tension leaving a wrap of angle θ [rad] with friction μ [-],
/// τ_out = τ_in e^{−μθ}.
inline double capstan_tension_out(double tension_in, double mu, double wrap) {
  return tension_in * std::exp(-mu * wrap);
}

/// The β of S0 eq. (11) equivalent to one capstan wrap: β = 1 − e^{−μθ} [-].
inline double capstan_beta(double mu, double wrap) { return 1.0 - std::exp(-mu * wrap); }

/// Friction of one branch, affine in the driving tension: f = a + b·|τ_drive| [N].
struct BranchFriction {
  double a = 0.0;  ///< constant part [N]
  double b = 0.0;  ///< tension-proportional part [-]
};

/// Branch friction of branch b of transmission i at branch speed sdot [m/s].
/// Sliding (sdot ≠ 0): τ_0 + β|τ| + Σ_bearings (dynamic_coefficient p + h(n))/r; at rest:
/// τ_0 + β|τ| + Σ static_coefficient p / r
/// (break-away). Bearing load of a pulley wrapped by θ: p = 2 sin(θ/2)(T_pre + |τ|) [N].
inline BranchFriction branch_friction(const TransmissionModel& m, int i, int b, double sdot) {
  BranchFriction f{m.tau0(i, b), m.beta(i, b)};
  const double count = m.bearing_count(i, b);
  if (count > 0.0) {
    const double r = m.bearing_radius(i, b);
    const double k = 2.0 * std::sin(0.5 * m.bearing_wrap(i, b));  // load per unit tension
    const bool moving = sdot != 0.0;
    const double coef = moving ? m.bearing_dynamic_coefficient(i, b) : m.bearing_static_coefficient(i, b);
    const double h = moving ? bearing_speed_term(m.bearing_h0(i, b), m.bearing_h1(i, b),
                                                 m.bearing_n0(i, b), sdot / r)
                            : 0.0;
    f.a += count * (coef * k * m.pretension(i) + h) / r;
    f.b += count * coef * k / r;
  }
  return f;
}

namespace detail {
/// The sign bit of s alone (+0.0 or −0.0), for flip.
inline double sign_bit(double s) { return std::copysign(0.0, s); }
/// y·sgn(s) given sign = sign_bit(s): y with its sign bit flipped where s is negative (s = ±0 counts by its sign
/// bit). Exact. On x86-64 one xorpd (a multiplication by ±1 would cost four cycles on the chain of the statics).
inline double flip(double y, double sign) {
#if defined(__AVX__) && (defined(__GNUC__) || defined(__clang__))
  __asm__("vxorpd %1, %0, %0" : "+x"(y) : "x"(sign));  // VEX form: no SSE/AVX transition in AVX code
  return y;
#elif defined(__SSE2__) && (defined(__GNUC__) || defined(__clang__))
  __asm__("xorpd %1, %0" : "+x"(y) : "x"(sign));
  return y;
#else
  return y * std::copysign(1.0, sign);
#endif
}
/// x > y ? a : b without a branch (an SSE2 compare mask: the choices of the statics follow random signs, and a
/// mispredicted branch costs more than the whole select; compilers turn a plain ?: on doubles into a jump).
inline double pick_gt(double x, double y, double a, double b) {
#if defined(__SSE2__)
  const __m128d mask = _mm_cmpgt_sd(_mm_set_sd(x), _mm_set_sd(y));
  return _mm_cvtsd_f64(_mm_or_pd(_mm_and_pd(mask, _mm_set_sd(a)), _mm_andnot_pd(mask, _mm_set_sd(b))));
#else
  return x > y ? a : b;
#endif
}
/// x, kept a scalar: an empty asm the compiler cannot see through, so it does not fuse this load with its neighbour
/// into one vector load (which cannot be served from two separate recent scalar stores: a store-forwarding stall).
inline double scalar(double x) {
#if defined(__SSE2__) && (defined(__GNUC__) || defined(__clang__))
  __asm__("" : "+x"(x));
#endif
  return x;
}
/// max by value (one maxsd; std::max returns a reference the compiler may keep in memory).
inline double larger(double a, double b) { return a < b ? b : a; }
/// branch_tension_upstream given κ = a + ν|Ṡ| and the reciprocals q₊ = 1/(1 + b), q₋ = 1/(1 − b): no division.
inline double branch_tension_upstream_q(double x, double sdot, double kappa, double b, double q_plus,
                                        double q_minus) {
  const double sign = sign_bit(sdot), z = flip(x, sign), c = z + kappa;  // in the frame of the motion
  return flip(larger(larger(c * q_plus, c * q_minus), c + b * std::abs(z)), sign);
}
}  // namespace detail

/// Motor-side tension y of a sliding branch given its joint-side tension x (feedforward step).
/// Solves y − s·b·max(|x|,|y|) = x + s·a + ν Ṡ, s = sgn(Ṡ) ≠ 0, b < 1 (S0 eq. 11, corrected).
/// In the frame of the motion (z = s x, y' = s y: the same law times s) it reads y' − b·max(|z|,|y'|) = c,
/// c = z + a + ν|Ṡ|. The left side is strictly increasing in y', and its three pieces give y'₁ = c/(1 + b)
/// (y' < −|z|), y'₂ = c + b|z| (|y'| ≤ |z|), y'₃ = c/(1 − b) (y' > |z|): the solution is the largest of the three
/// (each wrong piece overshoots on the far side of its own range). Taking the maximum gives the same value
/// as testing the ranges, without a branch (random signs would mispredict it); y = s y'.
inline double branch_tension_upstream(double x, double sdot, BranchFriction f, double nu) {
  return detail::branch_tension_upstream_q(x, sdot, f.a + nu * std::abs(sdot), f.b, 1.0 / (1.0 + f.b),
                                           1.0 / (1.0 - f.b));
}

/// Joint-side tension x of a sliding branch given its motor-side tension y (forward step).
/// Solves x + s·b·max(|x|,|y|) = y − s·a − ν Ṡ; exact inverse of branch_tension_upstream.
inline double branch_tension_downstream(double y, double sdot, BranchFriction f, double nu) {
  const double s = sdot > 0.0 ? 1.0 : -1.0;
  const double ay = std::abs(y), sb = s * f.b;
  const double c = y - s * f.a - nu * sdot;
  if (c < -ay * (1.0 - sb)) return c / (1.0 - sb);  // x < −|y|
  if (c <= ay * (1.0 + sb)) return c - sb * ay;     // |x| ≤ |y|
  return c / (1.0 + sb);                            // x > |y|
}

// ---- transmission statics with losses ---------------------------------------------------------

namespace detail {
/// True when every entry of v is finite (fixed N: one test on Σ (v_i − v_i), 0 unless an entry is inf or NaN).
template <int N, class V>
inline bool all_finite_n(const V& v) {
  if constexpr (N == 0) {
    return all_finite(v);
  } else {
    double z = 0.0;
#pragma GCC unroll 8
    for (int i = 0; i < N; ++i) z += v(i) - v(i);
    return z == 0.0;
  }
}

/// The pieces of the branch law y(x) of branch_tension_upstream as lines y = slope·x + gain·sgn(Ṡ)·κ, in the
/// order branch_upstream_piece numbers them: 0 y' = c/(1 + b), 1 y' = c/(1 − b), 2 y' = c + b z (z ≥ 0),
/// 3 y' = c − b z (z < 0), with c = z + κ, z = sgn(Ṡ) x, y = sgn(Ṡ) y' (b: the branch's β with its bearing terms).
inline double piece_slope(int piece, double b) {
  return piece == 0 ? 1.0 / (1.0 + b) : piece == 1 ? 1.0 / (1.0 - b) : piece == 2 ? 1.0 + b : 1.0 - b;
}
inline double piece_gain(int piece, double b) {
  return piece == 0 ? 1.0 / (1.0 + b) : piece == 1 ? 1.0 / (1.0 - b) : 1.0;
}

/// The table of the 2×2 block a, a + 1 (a differential pair: both cables end at joint a + 1, each climbs its
/// branch a + 1 to joint a) into slot `slot` of c.pair_table. Pattern p = piece_a + 4 piece_b + 16 [power at joint
/// a < 0] + 32 [power at joint a + 1 < 0]: the pieces of the two branch laws (branch_upstream_piece) and the
/// reducers' directions (S0 eqs. 9–10: factor η_d driving, η_d/(2η_d − 1) back-driven). In a pattern the joint
/// equations of the block are linear in the end tensions t_a, t_b:
///   τ_a = K_aa e_a (σ_a t_a + g_a s_a κ_a) + K_ba (σ_b t_b + g_b s_b κ_b),   τ_b = K_ab t_a + K_bb e_b t_b
/// (σ, g: piece_slope, piece_gain; s = sgn(Ṡ); κ = a + ν|Ṡ| the call's constant term). Column: the inverse of
/// [[K_aa e_a σ_a, K_ba σ_b], [K_ab, K_bb e_b]] (row-major), K_aa e_a g_a, K_ba g_b, and 1 (0: a singular pattern).
inline void take_pair_table(const TransmissionModel& m, TransmissionData::StaticsConstants& c, int a, int slot) {
  const int b = a + 1;
  const double Kaa = m.K(a, a), Kab = m.K(a, b), Kba = m.K(b, a), Kbb = m.K(b, b);
  const double beta_a = branch_friction(m, a, b, 1.0).b, beta_b = branch_friction(m, b, b, 1.0).b;  // sliding
  for (int p = 0; p < 64; ++p) {
    const int pa = p & 3, pb = (p >> 2) & 3;
    const double ea = (p >> 4) & 1 ? c.back_factor(a) : m.reducer_efficiency(a);
    const double eb = (p >> 5) & 1 ? c.back_factor(b) : m.reducer_efficiency(b);
    const double A00 = Kaa * ea * piece_slope(pa, beta_a), A01 = Kba * piece_slope(pb, beta_b);
    const double A10 = Kab, A11 = Kbb * eb;
    const double det = A00 * A11 - A01 * A10;
    const bool valid = std::isfinite(det) && std::abs(det) > 1e-12 * (std::abs(A00 * A11) + std::abs(A01 * A10));
    double* col = c.pair_table.data() + 8 * (64 * slot + p);
    col[0] = valid ? A11 / det : 0.0;
    col[1] = valid ? -A01 / det : 0.0;
    col[2] = valid ? -A10 / det : 0.0;
    col[3] = valid ? A00 / det : 0.0;
    col[4] = Kaa * ea * piece_gain(pa, beta_a);
    col[5] = Kba * piece_gain(pb, beta_b);
    col[6] = valid ? 1.0 : 0.0;
    col[7] = 0.0;
  }
}

/// Take the constants of the feedforward from model m into d.statics (no allocation; d was made for m.n).
inline void take_statics_constants(const TransmissionModel& m, TransmissionData& d) {
  auto& c = d.statics;
  for (int i = 0; i < m.n; ++i) {
    const double e = m.reducer_efficiency(i);
    c.gain_driving(i) = 1.0 / (e * m.reducer_ratio(i) * m.driven_radius(i));
    c.gain_backdriven(i) = reducer_self_locking(e) ? 0.0 : (2.0 * e - 1.0) * c.gain_driving(i);
  }
  c.bearings = false;
  for (int b = 0; b < m.n; ++b)
    for (int i = 0; i < m.n; ++i) {
      if (i < b && m.last_joint(i) < b) continue;  // no branch b on cable i (serial: i ≥ b)
      c.inv_one_plus_beta(i, b) = 1.0 / (1.0 + m.beta(i, b));
      c.inv_one_minus_beta(i, b) = 1.0 / (1.0 - m.beta(i, b));
      c.bearings = c.bearings || m.bearing_count(i, b) > 0.0;
    }
  if (!m.serial) {  // (K_Bᵀ)⁻¹ of each coupled block by Gauss–Jordan, in the preallocated workspace
    for (int i = 0; i < m.n; ++i) {
      const double e = m.reducer_efficiency(i);
      c.back_factor(i) = e / (2.0 * e - 1.0);  // e > 0.5: self-locking is refused outside serial routings
    }
    Eigen::MatrixXd& A = d.block_jacobian;
    Eigen::MatrixXd& X = c.block_inverse;
    for (int begin = 0; begin < m.n;) {
      const int end = m.block_end(begin);
      for (int r = begin; r <= end; ++r)
        for (int k = begin; k <= end; ++k) { A(r, k) = m.K(k, r); X(r, k) = r == k ? 1.0 : 0.0; }
      for (int col = begin; col <= end; ++col) {
        int p = col;
        for (int r = col + 1; r <= end; ++r)
          if (std::abs(A(r, col)) > std::abs(A(p, col))) p = r;
        for (int k = begin; k <= end; ++k) { std::swap(A(col, k), A(p, k)); std::swap(X(col, k), X(p, k)); }
        const double piv = A(col, col);  // nonzero: K is invertible (validated), so is each diagonal block
        for (int k = begin; k <= end; ++k) { A(col, k) /= piv; X(col, k) /= piv; }
        for (int r = begin; r <= end; ++r) {
          if (r == col) continue;
          const double f = A(r, col);
          for (int k = begin; k <= end; ++k) { A(r, k) -= f * A(col, k); X(r, k) -= f * X(col, k); }
        }
      }
      begin = end + 1;
    }
    c.pair_slot.setConstant(-1);  // the 2×2 blocks' tables of patterns (solve_pair_direct)
    int slot = 0;
    for (int a = 0; a < m.n; a = m.block_end(a) + 1)
      if (m.block_end(a) == a + 1) {
        take_pair_table(m, c, a, slot);
        c.pair_slot(a) = slot++;
      }
  }
  c.model = &m;
}

/// The recursion of motor_torque_feedforward for N transmissions (N = 0: m.n at run time), inputs checked.
/// Arranged for the chain of dependent operations (cable i waits for the tensions of the distal cables at
/// joint i): no division and no branch on a sign along it (the reciprocals of the reducer and branch
/// constants are taken once per model, TransmissionData::statics; the choices of piece are maxima with exact
/// sign flips), the tension that arrives last subtracted last; for a fixed N the inputs and tensions are kept
/// in local arrays (registers) and the outputs written once.
/// Bearings: some branch has bearings (their speed-dependent terms are taken in the call; without any, the
/// recursion has no call in it and stays in registers).
template <int N, bool Bearings, class V1, class V2>
inline Status feedforward_recursion(const TransmissionModel& m, TransmissionData& d, const V1& torque_joint,
                                    const V2& qd) {
  const int n = N > 0 ? N : m.n;
  constexpr int NF = N > 0 ? N : 1;
  double tj_l[NF], qd_l[NF];
  if constexpr (N > 0) {
#pragma GCC unroll 8
    for (int i = 0; i < N; ++i) {
      tj_l[i] = torque_joint(i);
      qd_l[i] = qd(i);
    }
    velocities_from_joint_n<N>(m, d, Eigen::Map<const Eigen::Matrix<double, NF, 1>>(qd_l));
  } else {
    velocities_from_joint_n<N>(m, d, qd);
  }
  const auto tau = [&](int i) { return N > 0 ? tj_l[i] : torque_joint(i); };
  const auto qdot = [&](int i) { return N > 0 ? qd_l[i] : qd(i); };
  // column-major, leading dimension n: K, the loss matrices, the constants and the (n, n) outputs
  const double *K = m.K.data(), *Sdot = d.Sdot.data(), *eta_d = m.reducer_efficiency.data();
  const double *beta = m.beta.data(), *tau0 = m.tau0.data(), *nu = m.nu.data(), *count = m.bearing_count.data();
  const double *gain = d.statics.gain_driving.data(), *gain_back = d.statics.gain_backdriven.data();
  const double *q_plus = d.statics.inv_one_plus_beta.data(), *q_minus = d.statics.inv_one_minus_beta.data();
  int *stuck = d.stuck.data(), *self_locked = d.self_locked.data();
  double* tension = d.tension.data();  // [i + b n], tension at joint b after branch b of cable i
  double Tl[NF * NF], tm[NF];
  double* T = N > 0 ? Tl : tension;  // the copy the recursion reads
  bool locked_any = false;
#pragma GCC unroll 8
  for (int i = n - 1; i >= 0; --i) {
    double own = tau(i);  // joint equilibrium, S0 eq. 4; the last tension to arrive (k = i+1) comes last
#pragma GCC unroll 8
    for (int k = n - 1; k > i; --k) own -= K[k + i * n] * T[k + i * n];
    // Reducer in the driven pulley, S0 eq. 9: pulley torque own / (η_d n) when the joint is driven (power
    // own·q̇ > 0), η_i own / n, η_i = (2η_d − 1)/η_d, when it back-drives (power < 0; nothing when
    // self-locking), own / n at rest; the tension is that over r_d. With g = 1/(η_d n r_d): own·g driven,
    // own·(2η_d − 1)g back-driven. Both gains are ≥ 0 and g_driven ≥ g_back, so for q̇ > 0 the tension is the
    // larger of own·g_driven and own·g_back, for q̇ < 0 the smaller (the sign of own picks the case); at
    // rest (q̇ = 0) both are own·η_d g. (The sign of the power is that of own times that of q̇.)
    const double e = eta_d[i], v = qdot(i);
    double g_drive = gain[i], g_back = gain_back[i];
    if (v == 0.0) g_drive = g_back = e * g_drive;  // at rest: own / n
    const double sign = sign_bit(v), u = flip(own, sign);  // in the frame of the joint motion
    double t = flip(larger(u * g_drive, u * g_back), sign);
    const bool locked = reducer_self_locking(e) & (own * v < 0.0);  // & : no branch on the sign
    self_locked[i] = locked;
    locked_any = locked_any | locked;
    T[i + i * n] = t;
    if constexpr (N > 0) tension[i + i * n] = t;
#pragma GCC unroll 8
    for (int b = i; b >= 0; --b) {  // climb to the motor, S0 eq. 6
      const int ib = i + b * n;
      const double sdot = Sdot[ib];
      if (sdot == 0.0) {  // stuck: static friction passes the tension unchanged
        stuck[ib] = 1;
      } else {
        stuck[ib] = 0;
        if (Bearings && count[ib] > 0.0)  // speed-dependent bearing terms (S0 eqs. 7–8)
          t = branch_tension_upstream(t, sdot, branch_friction(m, i, b, sdot), nu[ib]);
        else
          t = branch_tension_upstream_q(t, sdot, tau0[ib] + nu[ib] * std::abs(sdot), beta[ib], q_plus[ib],
                                        q_minus[ib]);
      }
      if (b > 0) {
        T[i + (b - 1) * n] = t;
        if constexpr (N > 0) tension[i + (b - 1) * n] = t;
      }
    }
    if constexpr (N > 0) {
      tm[i] = t;
    } else {
      d.tension_motor(i) = t;
      d.torque_motor(i) = m.motor_radius(i) * t;
      d.torque_joint(i) = torque_joint(i);
    }
  }
  if constexpr (N > 0) {
    for (int i = 0; i < N; ++i) {
      d.tension_motor(i) = tm[i];
      d.torque_motor(i) = m.motor_radius(i) * tm[i];
      d.torque_joint(i) = tj_l[i];
    }
  }
  return locked_any ? Status::SelfLocked : Status::Ok;
}

/// One branch climbed toward the motor with the slope of the law: y = branch_tension_upstream_q(x, …) and
/// *slope = dy/dx (in the frame of the motion y' = s y, z = s x, so dy/dx = dy'/dz: 1/(1 + b), 1/(1 − b) or
/// 1 + b sgn(z) on the piece that gives the largest value).
inline double branch_upstream_slope(double x, double sdot, double kappa, double b, double q_plus,
                                    double q_minus, double* slope) {
  const double sign = sign_bit(sdot), z = flip(x, sign), c = z + kappa;
  const double y1 = c * q_plus, y2 = c * q_minus, y3 = c + b * std::abs(z);
  const double y12 = larger(y1, y2), y = larger(y12, y3);
  // selects, not branches (the piece follows random signs)
  const double s12 = pick_gt(y2, y1, q_minus, q_plus), s3 = 1.0 + flip(b, sign_bit(z));
  *slope = pick_gt(y3, y12, s3, s12);
  return flip(y, sign);
}

/// Tensions of cable i from its end (the last joint it wraps, tension t) toward the motor, branch by branch down
/// to branch `down_to` (0: to the motor), with the slopes ∂tension[i, b]/∂t when Slopes (S0 eq. 6 along every
/// branch; a branch at rest passes the tension unchanged). Writes d.tension(i, ·), d.slope(i, ·) (Slopes),
/// d.stuck(i, ·), and d.tension_motor(i) when it reaches the motor.
template <bool Slopes>
inline void climb_cable(const TransmissionModel& m, TransmissionData& d, int i, double t, int down_to = 0) {
  const int last = m.last_joint(i);
  double sl = 1.0;
  d.tension(i, last) = t;
  if (Slopes) d.slope(i, last) = 1.0;
  for (int b = last; b >= down_to; --b) {
    const double sdot = d.Sdot(i, b);
    if (sdot == 0.0) {
      d.stuck(i, b) = 1;
    } else {
      d.stuck(i, b) = 0;
      double g = 1.0;
      if (d.statics.bearings && m.bearing_count(i, b) > 0.0) {  // speed-dependent bearing terms (S0 eqs. 7–8)
        const BranchFriction f = branch_friction(m, i, b, sdot);
        t = branch_upstream_slope(t, sdot, f.a + m.nu(i, b) * std::abs(sdot), f.b, 1.0 / (1.0 + f.b),
                                  1.0 / (1.0 - f.b), &g);
      } else if (Slopes) {
        t = branch_upstream_slope(t, sdot, m.tau0(i, b) + m.nu(i, b) * std::abs(sdot), m.beta(i, b),
                                  d.statics.inv_one_plus_beta(i, b), d.statics.inv_one_minus_beta(i, b), &g);
      } else {
        t = branch_tension_upstream_q(t, sdot, m.tau0(i, b) + m.nu(i, b) * std::abs(sdot), m.beta(i, b),
                                      d.statics.inv_one_plus_beta(i, b), d.statics.inv_one_minus_beta(i, b));
      }
      sl *= g;
    }
    if (b > 0) {
      d.tension(i, b - 1) = t;
      if (Slopes) d.slope(i, b - 1) = sl;
    }
  }
  if (down_to == 0) d.tension_motor(i) = t;
}

/// Reducer factor e of the torque K_ii e t cable i applies at its driven joint, S0 eqs. 9–10: η_d when the
/// pulley drives the joint (power > 0), back = η_d/(2η_d − 1) when the joint back-drives it (power < 0), 1 at
/// rest. Selects, not branches.
inline double reducer_factor(double eta, double back, double power) {
  return pick_gt(0.0, power, back, pick_gt(power, 0.0, eta, 1.0));
}

/// One branch (i, b) climbed with its slope, the constants of the call: branch_upstream_slope with the bearing
/// terms when the branch has bearings; a branch at rest passes t with slope 1 (stuck).
inline double climb_branch(const TransmissionModel& m, const TransmissionData& d, int i, int b, double t,
                           double* slope) {
  const double sdot = d.Sdot(i, b);
  if (sdot == 0.0) { *slope = 1.0; return t; }
  if (d.statics.bearings && m.bearing_count(i, b) > 0.0) {  // speed-dependent bearing terms (S0 eqs. 7–8)
    const BranchFriction f = branch_friction(m, i, b, sdot);
    return branch_upstream_slope(t, sdot, f.a + m.nu(i, b) * std::abs(sdot), f.b, 1.0 / (1.0 + f.b),
                                 1.0 / (1.0 - f.b), slope);
  }
  return branch_upstream_slope(t, sdot, m.tau0(i, b) + m.nu(i, b) * std::abs(sdot), m.beta(i, b),
                               d.statics.inv_one_plus_beta(i, b), d.statics.inv_one_minus_beta(i, b), slope);
}

/// The constants of branch b of cable i in a call (they do not depend on the tension), as climb_branch takes them:
/// Ṡ [m/s], κ = a + ν|Ṡ| [N], b [-] and its reciprocals 1/(1 ± b).
struct PairLaw { double sdot, kappa, beta, q_plus, q_minus; };
template <bool Bearings>
inline PairLaw pair_law(const TransmissionModel& m, const TransmissionData& d, int i, int b) {
  const double sdot = d.Sdot(i, b);
  if (Bearings && m.bearing_count(i, b) > 0.0) {
    const BranchFriction f = branch_friction(m, i, b, sdot);
    return PairLaw{sdot, f.a + m.nu(i, b) * std::abs(sdot), f.b, 1.0 / (1.0 + f.b), 1.0 / (1.0 - f.b)};
  }
  return PairLaw{sdot, m.tau0(i, b) + m.nu(i, b) * std::abs(sdot), m.beta(i, b), d.statics.inv_one_plus_beta(i, b),
                 d.statics.inv_one_minus_beta(i, b)};
}

/// A 2×2 block (a differential pair: cables a and a+1, joints a and a+1, both cables end at joint a+1) solved by
/// the Newton iteration of feedforward_general written out for two unknowns, in registers: the same operations
/// in the same order (lossless start, residual and Jacobian, Gaussian elimination with partial pivoting as
/// selects, the same stopping test), so the same numbers, without the run-time loops, the workspace matrices and
/// the pivot branch. Each cable climbs one branch (a+1) inside the block. Writes the block's tensions, stuck
/// flags and d.block_iterations; returns false (NotConverged) after 30 steps, InvalidModel on a zero pivot.
/// Bearings: d.statics.bearings (without, the laws take no call and the iteration keeps its values in registers).
/// Out of line: solve_pair_direct's fallback, off the path of the calls that take the table.
template <bool Bearings>
[[gnu::noinline]] Status solve_pair(const TransmissionModel& m, TransmissionData& d, int a, const double* known) {
  const int b = a + 1;
  const double Kaa = m.K(a, a), Kab = m.K(a, b), Kba = m.K(b, a), Kbb = m.K(b, b);
  const double qa = scalar(d.qd(a)), qb = scalar(d.qd(b));  // scalar: stored one by one just before
  const double eta_a = m.reducer_efficiency(a), eta_b = m.reducer_efficiency(b);
  const double back_a = d.statics.back_factor(a), back_b = d.statics.back_factor(b);
  const double ka = scalar(known[a]), kb = scalar(known[b]);
  const double scale = std::max(std::max(0.0, std::abs(ka)), std::abs(kb));
  const auto& X = d.statics.block_inverse;
  double ta = 0.0 + X(a, a) * ka + X(a, b) * kb;  // lossless start (K_Bᵀ)⁻¹ τ_B
  double tb = 0.0 + X(b, a) * ka + X(b, b) * kb;
  double Taa = 0.0, Tba = 0.0;
  const PairLaw la = pair_law<Bearings>(m, d, a, b), lb = pair_law<Bearings>(m, d, b, b);
  const auto climb = [](const PairLaw& l, double t, double* slope) {
    if (l.sdot == 0.0) { *slope = 1.0; return t; }  // at rest: passes the tension (stuck)
    return branch_upstream_slope(t, l.sdot, l.kappa, l.beta, l.q_plus, l.q_minus, slope);
  };
  Status status = Status::NotConverged;
  for (int it = 0; it < 30; ++it) {
    double sa, sb;
    Taa = climb(la, ta, &sa);  // tensions at joint a
    Tba = climb(lb, tb, &sb);
    // row a: cable a on its driven joint (reducer factor), cable b crossing it; row b: a crossing, b driven
    const double ea = reducer_factor(eta_a, back_a, Kaa * Taa * qa);
    const double eb = reducer_factor(eta_b, back_b, Kbb * tb * qb);
    const double xaa = Kaa * ea * Taa, xba = Kba * 1.0 * Tba, xab = Kab * 1.0 * ta, xbb = Kbb * eb * tb;
    const double ra = ka - xaa - xba, rb = kb - xab - xbb;
    const double mag_a = std::max(std::max(scale, std::abs(xaa)), std::abs(xba));
    const double mag = std::max(std::max(mag_a, std::abs(xab)), std::abs(xbb));
    const double worst_r = std::max(std::max(0.0, std::abs(ra)), std::abs(rb));
    if (it > 0 && worst_r <= 1e-13 * mag) { status = Status::Ok; break; }
    double J00 = Kaa * ea * sa, J01 = Kba * 1.0 * sb, J10 = Kab * 1.0 * 1.0, J11 = Kbb * eb * 1.0;
    double r0 = ra, r1 = rb;
    const double a10 = std::abs(J10), a00 = std::abs(J00);  // partial pivoting (swap when |J10| > |J00|), as selects
    const double P00 = pick_gt(a10, a00, J10, J00), P01 = pick_gt(a10, a00, J11, J01);
    const double P10 = pick_gt(a10, a00, J00, J10), P11 = pick_gt(a10, a00, J01, J11);
    const double p0 = pick_gt(a10, a00, r1, r0), p1 = pick_gt(a10, a00, r0, r1);
    if (P00 == 0.0) return Status::InvalidModel;
    const double f = P10 / P00;
    const double Q11 = P11 - f * P01, q1 = p1 - f * p0;
    if (Q11 == 0.0) return Status::InvalidModel;
    const double x1 = q1 / Q11;
    const double x0 = (p0 - P01 * x1) / P00;
    ta += x0;
    tb += x1;
    ++d.block_iterations;
  }
  d.tension(a, b) = ta;
  d.tension(b, b) = tb;
  d.tension(a, a) = Taa;
  d.tension(b, a) = Tba;
  d.stuck(a, b) = d.Sdot(a, b) == 0.0;
  d.stuck(b, b) = d.Sdot(b, b) == 0.0;
  return status;
}

/// branch_upstream_slope's law y(x) with, instead of the slope, the piece it takes (numbered as piece_slope:
/// 0 y' = c/(1 + b), 1 y' = c/(1 − b), 2 y' = c + b z for z ≥ 0, 3 y' = c − b z for z < 0; c = z + κ, z = sgn(Ṡ) x),
/// with the same choice on a tie.
inline double branch_upstream_piece(double x, double sdot, double kappa, double b, double q_plus, double q_minus,
                                    int* piece) {
  const double sign = sign_bit(sdot), z = flip(x, sign), c = z + kappa;
  const double y1 = c * q_plus, y2 = c * q_minus, y3 = c + b * std::abs(z);
  const double y12 = larger(y1, y2), y = larger(y12, y3);
  // arithmetic, not ?: (which compilers turn into a jump on a random sign)
  const int p12 = y2 > y1, p3 = 2 + std::signbit(z), third = y3 > y12;
  *piece = p12 + third * (p3 - p12);
  return flip(y, sign);
}

/// A 2×2 block (a differential pair, as solve_pair) solved directly: the pattern (take_pair_table: the pieces of
/// the two branch laws inside the block and the directions of power at its two driven joints) is read at the
/// lossless start (K_Bᵀ)⁻¹τ_B, the block's equations of that pattern are solved with its inverse from the table
/// (no division), and the solution is checked to have the same pattern. Then it is the solution of the
/// piecewise-linear equations (to rounding: within 1e-12 relative of the Newton iteration's, not bit for bit).
/// Otherwise — a wrong pattern at the lossless start, a branch at rest, no power at a driven joint (undecided
/// factor), a singular pattern — the Newton iteration solve_pair solves the block (out of line) and
/// d.pair_fallbacks counts it. force ≥ 0 imposes pattern `force` (tests: a wrong pattern must fall back).
template <bool Bearings>
[[gnu::always_inline]] inline Status solve_pair_direct(const TransmissionModel& m, TransmissionData& d, int a,
                                                       const double* known, double* tension_a, double* tension_b,
                                                       int force = -1) {
  const int b = a + 1, slot = d.statics.pair_slot(a);
  const PairLaw la = pair_law<Bearings>(m, d, a, b), lb = pair_law<Bearings>(m, d, b, b);
  const auto fallback = [&] {
    ++d.pair_fallbacks;
    const Status st = solve_pair<Bearings>(m, d, a, known);
    *tension_a = d.tension(a, a);
    *tension_b = d.tension(b, a);
    return st;
  };
  if ((slot < 0) | (la.sdot == 0.0) | (lb.sdot == 0.0)) return fallback();  // no table, or a branch at rest (stuck)
  const double Kaa = m.K(a, a), Kbb = m.K(b, b);
  const double qa = scalar(d.qd(a)), qb = scalar(d.qd(b));  // scalar: stored one by one just before
  const double ka = scalar(known[a]), kb = scalar(known[b]);
  const auto& X = d.statics.block_inverse;
  const double ta0 = X(a, a) * ka + X(a, b) * kb, tb0 = X(b, a) * ka + X(b, b) * kb;  // lossless start
  int pa0, pb0;
  const double Taa0 = branch_upstream_piece(ta0, la.sdot, la.kappa, la.beta, la.q_plus, la.q_minus, &pa0);
  branch_upstream_piece(tb0, lb.sdot, lb.kappa, lb.beta, lb.q_plus, lb.q_minus, &pb0);
  const int guess = pa0 | pb0 << 2 | (Kaa * Taa0 * qa < 0.0) << 4 | (Kbb * tb0 * qb < 0.0) << 5;
  const int pattern = force >= 0 ? force : guess;
  const double* e = d.statics.pair_table.data() + 8 * (64 * slot + pattern);
  // the pattern's equations: constant terms sgn(Ṡ) κ of the two laws moved to the right of joint a's
  const double ra = ka - e[4] * flip(la.kappa, sign_bit(la.sdot)) - e[5] * flip(lb.kappa, sign_bit(lb.sdot));
  const double ta = e[0] * ra + e[1] * kb, tb = e[2] * ra + e[3] * kb;
  int pa, pb;  // the pattern of the solution
  const double Taa = branch_upstream_piece(ta, la.sdot, la.kappa, la.beta, la.q_plus, la.q_minus, &pa);
  const double Tba = branch_upstream_piece(tb, lb.sdot, lb.kappa, lb.beta, lb.q_plus, lb.q_minus, &pb);
  const double power_a = Kaa * Taa * qa, power_b = Kbb * tb * qb;
  const int found = pa | pb << 2 | (power_a < 0.0) << 4 | (power_b < 0.0) << 5;
  // no power at a driven joint with K ≠ 0: the reducer's factor is 1 there (reducer_factor), in no pattern
  const bool undecided = ((power_a == 0.0) & (Kaa != 0.0)) | ((power_b == 0.0) & (Kbb != 0.0));
  if ((found != pattern) | undecided | (e[6] == 0.0)) return fallback();
  d.tension(a, b) = ta;
  d.tension(b, b) = tb;
  d.tension(a, a) = Taa;
  d.tension(b, a) = Tba;
  d.stuck(a, b) = 0;
  d.stuck(b, b) = 0;
  *tension_a = Taa;
  *tension_b = Tba;
  return Status::Ok;
}

/// The climb of cable i from the tension t at joint `from` (after branch from + 1) to its motor, branches from … 0
/// (S0 eq. 6), without slopes. Writes d.tension(i, from − 1 … 0), d.stuck(i, from … 0), d.tension_motor(i).
/// Column-major (n, n) arrays read through raw pointers (entry [i, b] at i + b n). Bearings: some branch of the
/// model has bearings (d.statics.bearings); without, the loop has no call in it and is inlined into the caller.
template <bool Bearings>
inline void climb_rest(const TransmissionModel& m, TransmissionData& d, int i, double t, int from) {
  const int n = m.n;
  const double *Sdot = d.Sdot.data(), *tau0 = m.tau0.data(), *nu = m.nu.data(), *beta = m.beta.data();
  const double *q_plus = d.statics.inv_one_plus_beta.data(), *q_minus = d.statics.inv_one_minus_beta.data();
  const double* count = m.bearing_count.data();
  double* tension = d.tension.data();
  int* stuck = d.stuck.data();
  for (int b = from; b >= 0; --b) {
    const int ib = i + b * n;
    const double sdot = Sdot[ib];
    if (sdot == 0.0) {
      stuck[ib] = 1;
    } else {
      stuck[ib] = 0;
      if (Bearings && count[ib] > 0.0) {
        t = branch_tension_upstream(t, sdot, branch_friction(m, i, b, sdot), nu[ib]);
      } else {
        t = branch_tension_upstream_q(t, sdot, tau0[ib] + nu[ib] * std::abs(sdot), beta[ib], q_plus[ib], q_minus[ib]);
      }
    }
    if (b > 0) tension[ib - n] = t;
  }
  d.tension_motor(i) = t;
}

/// climb_rest for the two cables a, a + 1 of a pair at once, from their tensions ta, tb at joint `from`: the same
/// law (branch_tension_upstream_q) in the two lanes of an SSE2 register, the branch constants of the two cables
/// being neighbours in the column-major arrays; a branch where either cable is at rest or has bearings takes
/// the scalar laws. Writes what climb_rest writes for both cables.
template <bool Bearings>
inline void climb_rest_pair(const TransmissionModel& m, TransmissionData& d, int a, double ta, double tb, int from) {
#if defined(__SSE2__)
  const int n = m.n;
  const double *Sdot = d.Sdot.data(), *tau0 = m.tau0.data(), *nu = m.nu.data(), *beta = m.beta.data();
  const double *q_plus = d.statics.inv_one_plus_beta.data(), *q_minus = d.statics.inv_one_minus_beta.data();
  const double* count = m.bearing_count.data();
  double* tension = d.tension.data();
  int* stuck = d.stuck.data();
  const __m128d sign_mask = _mm_set1_pd(-0.0), zero = _mm_setzero_pd();
  __m128d t = _mm_set_pd(tb, ta);
  for (int b = from; b >= 0; --b) {
    const int ib = a + b * n;
    const __m128d sdot = _mm_loadu_pd(Sdot + ib);
    const bool scalar_branch = _mm_movemask_pd(_mm_cmpeq_pd(sdot, zero)) != 0 ||
                               (Bearings && (count[ib] > 0.0 || count[ib + 1] > 0.0));
    if (scalar_branch) {  // rare: a cable at rest here, or bearings
      double tt[2];
      _mm_storeu_pd(tt, t);
      for (int l = 0; l < 2; ++l) {
        const double sd = Sdot[ib + l];
        stuck[ib + l] = sd == 0.0;
        if (sd == 0.0) continue;
        tt[l] = Bearings && count[ib + l] > 0.0
                    ? branch_tension_upstream(tt[l], sd, branch_friction(m, a + l, b, sd), nu[ib + l])
                    : branch_tension_upstream_q(tt[l], sd, tau0[ib + l] + nu[ib + l] * std::abs(sd), beta[ib + l],
                                                q_plus[ib + l], q_minus[ib + l]);
      }
      t = _mm_loadu_pd(tt);
    } else {
      stuck[ib] = 0;
      stuck[ib + 1] = 0;
      const __m128d sign = _mm_and_pd(sdot, sign_mask);
      const __m128d kappa = _mm_add_pd(_mm_loadu_pd(tau0 + ib), _mm_mul_pd(_mm_loadu_pd(nu + ib),
                                                                           _mm_andnot_pd(sign_mask, sdot)));
      const __m128d z = _mm_xor_pd(t, sign), c = _mm_add_pd(z, kappa);
      const __m128d y1 = _mm_mul_pd(c, _mm_loadu_pd(q_plus + ib)), y2 = _mm_mul_pd(c, _mm_loadu_pd(q_minus + ib));
      const __m128d y3 = _mm_add_pd(c, _mm_mul_pd(_mm_loadu_pd(beta + ib), _mm_andnot_pd(sign_mask, z)));
      t = _mm_xor_pd(_mm_max_pd(_mm_max_pd(y1, y2), y3), sign);
    }
    if (b > 0) _mm_storeu_pd(tension + ib - n, t);
  }
  double tt[2];
  _mm_storeu_pd(tt, t);
  d.tension_motor(a) = tt[0];
  d.tension_motor(a + 1) = tt[1];
#else
  climb_rest<Bearings>(m, d, a, ta, from);
  climb_rest<Bearings>(m, d, a + 1, tb, from);
#endif
}

/// Feedforward of a general routing (not serial), run-time n. Blocks of K from the distal one; the later
/// blocks' cables are known by then, their torques at this block's joints subtracted once (block_residual
/// keeps τ_j minus them). A 1×1 block (its cable ends at its own joint) is S0's closed form: the reducer, then
/// the climb. A larger block's joint equations τ_j = Σ_i K_ij tension[i, j] hold the end tensions t_i of its
/// cables; each tension is a monotone piecewise-linear function of t_i (the branch laws), so a Newton
/// iteration on the pieces, from the lossless tensions, ends exactly once it has the right pieces (checked on the residual,
/// 1e-13 relative). The iteration climbs only the branches between the block's joints (the tensions its
/// equations read); once it ends, each cable climbs the rest of the way to its motor. Status NotConverged
/// after 30 steps. Pairs: a 2×2 block takes solve_pair_direct (its pattern's linear solve from a table, checked;
/// the same iteration written out, solve_pair, when the check fails), within 1e-12 relative of the iteration;
/// false: the run-time loops for every block, kept as the reference the tests compare it with.
template <bool Pairs, bool Bearings, class V1, class V2>
inline Status feedforward_general_b(const TransmissionModel& m, TransmissionData& d, const V1& torque_joint,
                                    const V2& qd) {
  const int n = m.n;
  // column-major (n, n) arrays through raw pointers (entry [i, b] at i + b n); restrict: the outputs are
  // distinct buffers of d, none aliases the model's or the inputs (the same sums, in the same order, as
  // velocities_from_joint_n)
  const double* __restrict K = m.K.data();
  const int* __restrict last_joint = m.last_joint.data();
  const double* __restrict motor_radius = m.motor_radius.data();
  double* __restrict qdl = d.qd.data();
  double* __restrict Sdot = d.Sdot.data();
  double* __restrict qd_motor = d.qd_motor.data();
  for (int i = 0; i < n; ++i) qdl[i] = qd(i);
  for (int i = 0; i < n; ++i) {  // branch velocities Ṡ_b = Σ_{l≥b} K_il q̇_l from the driven joint (routing.hpp)
    double s = 0.0;
    for (int b = last_joint[i]; b >= 0; --b) {
      s += K[i + b * n] * qdl[b];
      Sdot[i + b * n] = s;
    }
    qd_motor[i] = s / motor_radius[i];
  }
  Status status = Status::Ok;
  d.block_iterations = 0;
  d.pair_fallbacks = 0;
  double* known = d.block_step.data();  // τ_j minus the later blocks' cables, per joint of the block
  const double* tension = d.tension.data();
  for (int end = n - 1; end >= 0;) {
    const int begin = m.block_begin(end);
    for (int j = begin; j <= end; ++j) {
      double r = torque_joint(j);
      const double *Kj = K + j * n, *Tj = tension + j * n;
      for (int k = n - 1; k > end; --k) {
        // one scalar load per tension: the climbs have just stored them one by one, and a vector load across two
        // such stores cannot take them from the store buffer (it waits for them to retire, on the chain)
        r -= Kj[k] * scalar(Tj[k]);
      }
      known[j] = r;
    }
    if (begin == end) {  // S0's recursion for one cable: reducer (eqs. 9–10), then the climb (eq. 6)
      const int i = begin;
      // t = own / (K_ii e): the gains 1/(η_d K_ii) and 1/(K_ii back) taken once per model (no division here)
      const double own = known[i], power = own * d.qd(i), g_drive = d.statics.gain_driving(i);
      const double g = pick_gt(power, 0.0, g_drive,
                               pick_gt(0.0, power, d.statics.gain_backdriven(i), g_drive * m.reducer_efficiency(i)));
      const double t = own * g;
      d.tension(i, m.last_joint(i)) = t;
      climb_rest<Bearings>(m, d, i, t, m.last_joint(i));
      end = begin - 1;
      continue;
    }
    if (Pairs && end == begin + 1) {
      double ta, tb;  // the pair's tensions at joint `begin`
      const Status sp = solve_pair_direct<Bearings>(m, d, begin, known, &ta, &tb);
      if (sp == Status::InvalidModel) return sp;
      if (sp != Status::Ok) status = worst(status, sp);
      climb_rest_pair<Bearings>(m, d, begin, ta, tb, begin);  // on to the motors from joint `begin`
      end = begin - 1;
      continue;
    }
    double scale = 0.0;
    for (int j = begin; j <= end; ++j) scale = std::max(scale, std::abs(known[j]));
    bool done = false;  // the unknowns t_i are the block cables' end tensions, kept in tension(i, last_joint(i))
    for (int i = begin; i <= end; ++i) {  // start from the lossless tensions (K_Bᵀ)⁻¹ τ_B
      double t0 = 0.0;
      for (int j = begin; j <= end; ++j) t0 += d.statics.block_inverse(i, j) * known[j];
      d.tension(i, m.last_joint(i)) = t0;
    }
    for (int it = 0; it < 30; ++it) {
      for (int i = begin; i <= end; ++i) climb_cable<true>(m, d, i, d.tension(i, m.last_joint(i)), begin + 1);
      double worst_r = 0.0, mag = scale;
      for (int j = begin; j <= end; ++j) {
        double r = known[j];
        for (int k = begin; k <= end; ++k) {
          double jac = 0.0;
          if (m.last_joint(k) >= j) {
            const double kk = m.K(k, j), tk = d.tension(k, j);
            const double e = j == k ? reducer_factor(m.reducer_efficiency(k), d.statics.back_factor(k), kk * tk * d.qd(j))
                                    : 1.0;
            r -= kk * e * tk;
            mag = std::max(mag, std::abs(kk * e * tk));
            jac = kk * e * d.slope(k, j);
          }
          d.block_jacobian(j, k) = jac;
        }
        d.block_residual(j) = r;
        worst_r = std::max(worst_r, std::abs(r));
      }
      if (it > 0 && worst_r <= 1e-13 * mag) { done = true; break; }
      // Gaussian elimination with partial pivoting on the block (rows j, columns k, begin … end).
      for (int c = begin; c <= end; ++c) {
        int p = c;
        for (int r = c + 1; r <= end; ++r)
          if (std::abs(d.block_jacobian(r, c)) > std::abs(d.block_jacobian(p, c))) p = r;
        if (p != c) {
          for (int k = begin; k <= end; ++k) std::swap(d.block_jacobian(c, k), d.block_jacobian(p, k));
          std::swap(d.block_residual(c), d.block_residual(p));
        }
        const double piv = d.block_jacobian(c, c);
        if (piv == 0.0) return Status::InvalidModel;
        for (int r = c + 1; r <= end; ++r) {
          const double f = d.block_jacobian(r, c) / piv;
          for (int k = c; k <= end; ++k) d.block_jacobian(r, k) -= f * d.block_jacobian(c, k);
          d.block_residual(r) -= f * d.block_residual(c);
        }
      }
      for (int c = end; c >= begin; --c) {
        double x = d.block_residual(c);
        for (int k = c + 1; k <= end; ++k) x -= d.block_jacobian(c, k) * d.block_residual(k);
        d.block_residual(c) = x / d.block_jacobian(c, c);
      }
      for (int i = begin; i <= end; ++i) d.tension(i, m.last_joint(i)) += d.block_residual(i);
      ++d.block_iterations;
    }
    if (!done) status = worst(status, Status::NotConverged);
    for (int i = begin; i <= end; ++i) climb_cable<false>(m, d, i, d.tension(i, m.last_joint(i)));  // to the motor
    end = begin - 1;
  }
  for (int i = 0; i < n; ++i) {
    d.self_locked(i) = 0;
    d.torque_motor(i) = m.motor_radius(i) * d.tension_motor(i);
    d.torque_joint(i) = torque_joint(i);
  }
  return status;
}

/// feedforward_general_b with Bearings = d.statics.bearings (taken once per call, not per branch).
template <bool Pairs = true, class V1, class V2>
inline Status feedforward_general(const TransmissionModel& m, TransmissionData& d, const V1& torque_joint,
                                  const V2& qd) {
  return d.statics.bearings ? feedforward_general_b<Pairs, true>(m, d, torque_joint, qd)
                            : feedforward_general_b<Pairs, false>(m, d, torque_joint, qd);
}

/// motor_torque_feedforward for N transmissions (N = 0: m.n at run time); sizes already checked.
template <int N, class V1, class V2>
inline Status motor_torque_feedforward_n(const TransmissionModel& m, TransmissionData& d, const V1& torque_joint,
                                         const V2& qd) {
  if (!all_finite_n<N>(torque_joint)) return Status::NonFiniteInput;
  if (!all_finite_n<N>(qd)) return Status::NonFiniteInput;
  if (d.statics.model != &m) take_statics_constants(m, d);
  if (N == 0 && !m.serial) return feedforward_general(m, d, torque_joint, qd);
  return d.statics.bearings ? feedforward_recursion<N, true>(m, d, torque_joint, qd)
                            : feedforward_recursion<N, false>(m, d, torque_joint, qd);
}
}  // namespace detail

/// Feedforward (a): joint torques wanted + current joint velocity → motor torques to command.
///
/// Newton–Euler-like recursion from the distal joint (S0 Fig. 4, eqs. 4, 6, 9–12 corrected):
/// the torque left for transmission j at its joint is τ_J,j minus what the distal cables crossing
/// joint j already apply; the reducer (S0 eq. 9) maps it to the driven pulley (÷ η_d n when the
/// joint is driven, × η_i / n when it back-drives the cable); the tension then climbs branch by
/// branch to the motor. A branch at rest (Ṡ = 0) is stuck: static friction balances any
/// difference, so it passes the tension unchanged (static friction is not compensated, S0 §III).
///
/// @param torque_joint  τ_J [N·m], (n)
/// @param qd          joint velocity [rad/s], (n)
/// Writes data.qd, qd_motor, Sdot, tension, tension_motor, torque_motor, torque_joint, stuck,
/// self_locked; takes the model's constants into data.statics at the first call with that model object
/// (reciprocals: nothing is divided per call after that). Returns SelfLocked when a self-locking reducer holds a back-driving load (the
/// motor is then asked for nothing at that pulley), an error on bad input.
template <class V1, class V2>
inline Status motor_torque_feedforward(const TransmissionModel& m, TransmissionData& d,
                                       const V1& torque_joint, const V2& qd) {
  if (torque_joint.size() != m.n) return Status::SizeMismatch;
  if (qd.size() != m.n) return all_finite(torque_joint) ? Status::SizeMismatch : Status::NonFiniteInput;
  return dispatch_routing(m, [&](auto N) {
    return detail::motor_torque_feedforward_n<decltype(N)::value>(m, d, torque_joint, qd);
  });
}

/// Forward (b): motor torques + current joint velocity → joint torques delivered.
///
/// Each cable is followed from its motor to its joint, losing tension branch by branch; the
/// reducer multiplies by η_d n when it drives the joint and by n / η_i when the joint back-drives
/// it. A branch at rest passes nothing until its drive exceeds static friction (stuck case); past
/// break-away it passes the drive minus static friction, in the drive's direction.
///
/// @param torque_motor  C_m [N·m], (n)
/// @param qd          joint velocity [rad/s], (n)
template <class V1, class V2>
inline Status joint_torque_forward(const TransmissionModel& m, TransmissionData& d,
                                   const V1& torque_motor, const V2& qd) {
  if (torque_motor.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(torque_motor)) return Status::NonFiniteInput;
  const Status sv = velocities_from_joint(m, d, qd);
  if (is_error(sv)) return sv;
  Status status = Status::Ok;
  for (int i = 0; i < m.n; ++i) {
    d.torque_motor(i) = torque_motor(i);
    double t = torque_motor(i) / m.motor_radius(i);
    d.tension_motor(i) = t;
    for (int b = 0; b <= m.last_joint(i); ++b) {
      const double sdot = d.Sdot(i, b);
      const BranchFriction f = branch_friction(m, i, b, sdot);
      if (sdot != 0.0) {
        d.stuck(i, b) = 0;
        t = branch_tension_downstream(t, sdot, f, m.nu(i, b));
      } else {  // impending motion in the direction of the drive
        const double breakaway = f.a + f.b * std::abs(t);
        d.stuck(i, b) = std::abs(t) <= breakaway;
        t = d.stuck(i, b) ? 0.0 : t - std::copysign(breakaway, t);
      }
      d.tension(i, b) = t;
    }
  }
  for (int j = 0; j < m.n; ++j) {
    const double pulley = m.driven_radius(j) * d.tension(j, j);
    const double ratio = m.reducer_ratio(j), eta_d = m.reducer_efficiency(j);
    const double power = pulley * qd(j);
    double own = eta_d * ratio * pulley;  // driving, or at rest with motion impending from the motor
    d.self_locked(j) = 0;
    if (power < 0.0) {
      if (reducer_self_locking(eta_d)) {
        own = ratio * pulley;  // the reducer holds whatever the joint pushes; report the lossless value
        d.self_locked(j) = 1;
        status = worst(status, Status::SelfLocked);
      } else {
        own = ratio * pulley / reducer_inverse_efficiency(eta_d);
      }
    }
    double s = own;
    for (int k = 0; k < m.n; ++k)  // every other cable that wraps joint j (serial: k > j)
      if (k != j && (k > j || m.last_joint(k) >= j)) s += m.K(k, j) * d.tension(k, j);
    d.torque_joint(j) = s;
  }
  return status;
}

}  // namespace tendyn

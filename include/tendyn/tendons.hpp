// tendyn — N+1 tendon routing: m = n + 1 tendons share n joints (issue 19; docs/device-file.md, "N+1 routings").
//
// Routing: a joint motion q̇ changes the tendon lengths by ℓ̇ = K q̇, K (m, n) [m], row i = the signed pulley radii of
// tendon i at the joints it wraps (the same K as the square routing of routing.hpp, S0 eqs. 1–2 corrected: ERRATA).
// Tendons only pull: tensions t ≥ 0 [N] give the joint torques τ = Kᵀ t [N·m] (virtual work: tᵀℓ̇ = τᵀq̇, S0 eq. 5
// with one tendon per motor) and the motor torques C_m = R_m t [N·m]; motor i turns at q̇_m,i = ℓ̇_i / r_m,i.
//
// With Kᵀ (n, m) of full row rank n, every solution of Kᵀ t = τ is
//     t = P τ + λ h,   P = pinv(Kᵀ) = K (KᵀK)⁻¹ (m, n) [1/m]  (minimum-norm tensions),
// h (m,) the null vector of Kᵀ (Kᵀ h = 0: an internal tension that loads no joint), scaled so max h = 1.
// Tension closure: h > 0 on every tendon — then a large enough λ keeps every tendon taut for any τ.
// The least λ that serves a whole box |τ_j| ≤ τ_max,j (lossless) is
//     λ_box = max_i (t_min,i + Σ_j |P_ij| τ_max,j) / h_i     (t is linear in τ: the worst vertex, in closed form).
//
// Losses along each tendon (S0 eq. 12, tension-independent branch friction; ERRATA: the motion sign restored): branch
// b of tendon i lies between joint b − 1 and joint b (branch 0 from the motor pulley to joint 0) and slides at
// Ṡ_ib = Σ_{l ≥ b} K_il q̇_l (routing.hpp's branch velocities). Climbing it toward the motor the tension rises by
// Δ_ib = sgn(Ṡ_ib) τ0_ib + ν_ib Ṡ_ib (nothing at Ṡ = 0: a branch at rest passes the tension, static friction is not
// compensated). The tension of tendon i at joint j is then T_ij = e_i + c_ij, e_i its tension at its last joint and
// c_ij = Σ_{b = j+1 … last_i} Δ_ib; at the motor T_i = e_i + Σ_{b = 0 … last_i} Δ_ib. The joint equilibrium
// τ_j = Σ_i K_ij T_ij (S0 eq. 4) is linear in e: Kᵀ e = τ − d, d_j = Σ_i K_ij c_ij, so
//     e = P (τ − d) + λ h,   λ = max_i (t_min,i − (P(τ − d))_i − min_j c_ij) / h_i
// (min over every point of the tendon, its end and the motor included), so every tension along every tendon is
// ≥ its floor and one touches it. Exact for S0 eq. 12.
// The tension-proportional loss of S0 eq. 11 (β ∈ [0, 1), ERRATA: motion sign restored): Δ_ib = sgn(Ṡ)(τ0 +
// β max(|T_up|, |T_down|)) + ν Ṡ, climbed exactly by losses.hpp's branch_upstream_slope (one of four lines in the
// tension, all of positive slope). The climbs then depend on e, and the n joint equations with the floors form a
// piecewise-linear system in the m end tensions: each tendon's floor is an end tension E_i (its floor at every point
// carried down with branch_tension_downstream, the exact inverse), one tendon a sits on its floor (e_a = E_a), and
// Newton on the active pieces (tendon_newton_beta: the pattern fixed, the linear system solved, the pattern verified
// by the climb, a damped step when it changed) with an active set on a (tendon_active_set_beta) and a continuation in
// β (tendon_solve_beta: s β, the step in s halved when a stage fails). Status::NotConverged (a flag; the tensions
// of the last solved stage climbed with the full β) when no stage reaches s = 1: measured, it happened only where a search
// (every tendon on its floor, end tensions E_a + 0 … 1e3 N) found no tensions that keep every tendon ≥ its floor —
// the losses break the tension closure (the internal-tension mode of the loss pattern slackens a tendon), e.g. 61 of 800 random cases at β ≤ 0.1 on the finger and generated
// devices, 0 of 800 at β ≤ 0.02. Bearings and reducer efficiencies are not modelled on N+1 tendons (the loader
// refuses them).
// Model / Data / Status as compensator.hpp: make_* allocate at setup; tendon_feedforward, tendon_joint_torque and
// tendon_velocity neither allocate nor throw.
#pragma once

#include "tendyn/losses.hpp"
#include "tendyn/status.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include <Eigen/Core>
#include <Eigen/LU>
#include <Eigen/SVD>

namespace tendyn {

/// An N+1 tendon routing, read-only once built by make_tendon_model.
struct TendonModel {
  int n = 0;                             ///< joints
  int m = 0;                             ///< tendons (n + 1)
  Eigen::MatrixXd K;                     ///< (m, n) [m]: ℓ̇ = K q̇
  Eigen::VectorXd motor_radius;          ///< (m,) [m]
  Eigen::VectorXd tension_min;           ///< (m,) [N]: floor of each tension in the feedforward
  Eigen::VectorXd null_vector;           ///< (m,) h [-]: Kᵀ h = 0, max h = 1, h > 0 (tension closure)
  Eigen::MatrixXd tension_from_torque;   ///< (m, n) P [1/m]: minimum-norm tensions t = P τ
  double condition = 0.0;                ///< σ_max / σ_min of Kᵀ [-]
  Eigen::VectorXi last_joint;            ///< (m,) 0-based last joint each tendon wraps (its end)
  Eigen::MatrixXd tau0;                  ///< (m, n) [N] Coulomb loss of branch b of tendon i (S0 eq. 12), 0 past last
  Eigen::MatrixXd nu;                    ///< (m, n) [N·s/m] viscous loss of branch b of tendon i, 0 past last
  Eigen::MatrixXd beta;                  ///< (m, n) [-] tension-proportional loss (S0 eq. 11), in [0, 1), 0 past last
  bool has_beta = false;                 ///< some β > 0: the feedforward iterates
};

/// Outputs of tendon_feedforward (sized once by make_tendon_data).
struct TendonData {
  Eigen::VectorXd tension;        ///< (m,) [N]: at the motor (what the motor pulls; = the end tension lossless)
  Eigen::VectorXd tension_end;    ///< (m,) [N]: at the tendon's last joint
  Eigen::MatrixXd tension_joint;  ///< (m, n) [N]: [i, j] at joint j (0 past the tendon's last joint)
  Eigen::MatrixXd Sdot;           ///< (m, n) [m/s]: branch velocities Ṡ_ib (0 past the last joint)
  Eigen::VectorXd motor_torque;   ///< (m,) [N·m]: C_m = R_m t
  double internal_tension = 0.0;  ///< λ [N]: the scale of h added to the minimum-norm tensions
  Eigen::VectorXd rhs;            ///< (n,) work: τ − d
  Eigen::VectorXd lowest;         ///< (m,) work: min_j c_ij
  Eigen::VectorXd e_prev;         ///< (m,) work: the end tensions before the last Newton step (β)
  Eigen::VectorXd floor_end;      ///< (m,) work [N]: E_i, the least end tension keeping tendon i ≥ its floor (β)
  Eigen::MatrixXd slope;          ///< (m, n) work: ∂T_ij/∂e_i on the active pieces (β)
  Eigen::VectorXd slope_motor;    ///< (m,) work: ∂T_i/∂e_i at the motor (β)
  Eigen::VectorXd resid;          ///< (m,) work: the residual of the β system (n joint torques [N·m], floor [N])
  Eigen::VectorXd step;           ///< (m,) work: the Newton step (β)
  Eigen::MatrixXd jacobian;       ///< (m, m) work: the Jacobian of the active pattern (β)
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;  ///< sized once: factorises the Jacobian without allocating
  Eigen::VectorXd e_good;         ///< (m,) work: the end tensions of the last solved continuation stage (β)
  double beta_scale = 1.0;        ///< work: the continuation's scale of β (1 when done)
  int iterations = 0;             ///< Newton steps of the last call (0 without β)
};

/// Build the model (setup time; allocates). Returns "" or the first problem, naming the tendon 0-based
/// ("tendon 2: ...") like the core's other validation messages; `out` is unchanged on a problem.
/// last_joint (m,), tau0 and nu (m, n): the branches of each tendon (S0 eq. 12); empty: lossless, last_joint = the
/// last nonzero entry of each row of K.
/// Svd (the decomposition of Kᵀ, JacobiSVD by default) is a template parameter so that only a translation unit that
/// builds a tendon model compiles it: its instantiation is ~5 s of compiler CPU, paid otherwise by every file that
/// includes this header (the simulator's among them) whether it builds a model or not (issue 39).
template <class Svd = Eigen::JacobiSVD<Eigen::MatrixXd>>
inline std::string make_tendon_model(const Eigen::MatrixXd& K, const Eigen::VectorXd& motor_radius,
                                     const Eigen::VectorXd& tension_min, TendonModel& out,
                                     const Eigen::VectorXi& last_joint = Eigen::VectorXi(),
                                     const Eigen::MatrixXd& tau0 = Eigen::MatrixXd(),
                                     const Eigen::MatrixXd& nu = Eigen::MatrixXd(),
                                     const Eigen::MatrixXd& beta = Eigen::MatrixXd()) {
  const int m = static_cast<int>(K.rows()), n = static_cast<int>(K.cols());
  if (n < 1 || m != n + 1)
    return "K must be (n + 1, n) with n >= 1 (got (" + std::to_string(m) + ", " + std::to_string(n) + "))";
  if (motor_radius.size() != m || tension_min.size() != m)
    return "motor_radius and tension_min must have one entry per tendon (" + std::to_string(m) + ")";
  if (!K.allFinite()) return "K: must be finite";
  for (int i = 0; i < m; ++i) {
    if (!(std::isfinite(motor_radius[i]) && motor_radius[i] > 0.0))
      return "tendon " + std::to_string(i) + ": motor_radius must be > 0";
    if (!(std::isfinite(tension_min[i]) && tension_min[i] >= 0.0))
      return "tendon " + std::to_string(i) + ": tension_min must be >= 0";
  }
  Eigen::VectorXi last(m);
  for (int i = 0; i < m; ++i) {
    int l = n - 1;
    while (l > 0 && K(i, l) == 0.0) --l;
    last[i] = l;
  }
  if (last_joint.size() != 0) {
    if (last_joint.size() != m) return "last_joint must have one entry per tendon (" + std::to_string(m) + ")";
    for (int i = 0; i < m; ++i) {
      if (last_joint[i] < last[i] || last_joint[i] >= n)
        return "tendon " + std::to_string(i) + ": last_joint must be in [" + std::to_string(last[i]) + ", " +
               std::to_string(n - 1) + "] (the last joint its row of K reaches)";
      last[i] = last_joint[i];
    }
  }
  Eigen::MatrixXd t0 = Eigen::MatrixXd::Zero(m, n), v = Eigen::MatrixXd::Zero(m, n), be = Eigen::MatrixXd::Zero(m, n);
  for (auto [src, dst, name] :
       {std::tuple{&tau0, &t0, "tau0"}, std::tuple{&nu, &v, "nu"}, std::tuple{&beta, &be, "beta"}}) {
    if (src->size() == 0) continue;
    if (src->rows() != m || src->cols() != n)
      return std::string(name) + " must be (m, n) = (" + std::to_string(m) + ", " + std::to_string(n) + ")";
    for (int i = 0; i < m; ++i)
      for (int b = 0; b < n; ++b) {
        const double x = (*src)(i, b);
        if (!(std::isfinite(x) && x >= 0.0))
          return std::string(name) + "[" + std::to_string(i) + "," + std::to_string(b) + "]: must be finite and >= 0";
        if (dst == &be && !(x < 1.0))
          return std::string(name) + "[" + std::to_string(i) + "," + std::to_string(b) + "]: must be < 1";
        if (b > last[i] && x != 0.0)
          return std::string(name) + "[" + std::to_string(i) + "," + std::to_string(b) + "]: must be 0 past the " +
                 "tendon's last joint";
        (*dst)(i, b) = x;
      }
  }
  const Eigen::MatrixXd Kt = K.transpose();  // (n, m)
  Svd svd(Kt, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd s = svd.singularValues();  // n values, descending
  if (!(s[0] > 0.0) || s[n - 1] <= 1e-12 * s[0])
    return "K has rank < " + std::to_string(n) + ": the tendons do not reach every joint direction";
  Eigen::VectorXd h = svd.matrixV().col(m - 1);  // the null vector of Kᵀ (full row rank: one)
  if (h.sum() < 0.0) h = -h;
  h /= h.cwiseAbs().maxCoeff();
  for (int i = 0; i < m; ++i)
    if (!(h[i] > 1e-9))
      return "tendon " + std::to_string(i) + ": no tension closure (the internal tension h = null vector of Kᵀ is " +
             "not > 0 on this tendon, so it cannot be kept taut)";
  TendonModel t;
  t.n = n;
  t.m = m;
  t.K = K;
  t.motor_radius = motor_radius;
  t.tension_min = tension_min;
  t.null_vector = h;
  // pinv(Kᵀ) = V S⁻¹ Uᵀ (the first n columns of V)
  t.tension_from_torque = svd.matrixV().leftCols(n) * s.cwiseInverse().asDiagonal() * svd.matrixU().transpose();
  t.condition = s[0] / s[n - 1];
  t.last_joint = last;
  t.tau0 = t0;
  t.nu = v;
  t.beta = be;
  t.has_beta = (be.array() > 0.0).any();
  out = std::move(t);
  return "";
}

inline TendonData make_tendon_data(const TendonModel& model) {
  TendonData d;
  d.tension = Eigen::VectorXd::Zero(model.m);
  d.tension_end = Eigen::VectorXd::Zero(model.m);
  d.tension_joint = Eigen::MatrixXd::Zero(model.m, model.n);
  d.Sdot = Eigen::MatrixXd::Zero(model.m, model.n);
  d.motor_torque = Eigen::VectorXd::Zero(model.m);
  d.rhs = Eigen::VectorXd::Zero(model.n);
  d.lowest = Eigen::VectorXd::Zero(model.m);
  d.e_prev = Eigen::VectorXd::Zero(model.m);
  d.floor_end = Eigen::VectorXd::Zero(model.m);
  d.e_good = Eigen::VectorXd::Zero(model.m);
  d.slope = Eigen::MatrixXd::Zero(model.m, model.n);
  d.slope_motor = Eigen::VectorXd::Zero(model.m);
  d.resid = Eigen::VectorXd::Zero(model.m);
  d.step = Eigen::VectorXd::Zero(model.m);
  d.jacobian = Eigen::MatrixXd::Identity(model.m, model.m);
  d.lu = Eigen::PartialPivLU<Eigen::MatrixXd>(model.m);
  return d;
}

/// Least internal tension λ [N] that keeps every tension ≥ its floor for every τ in the box |τ_j| ≤ tau_max_j.
inline double tendon_minimum_pretension(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau_max) {
  double lam = -INFINITY;
  for (int i = 0; i < model.m; ++i) {
    double need = model.tension_min[i];
    for (int j = 0; j < model.n; ++j) need += std::abs(model.tension_from_torque(i, j)) * std::abs(tau_max[j]);
    lam = std::max(lam, need / model.null_vector[i]);
  }
  return lam;
}

namespace detail {
/// The climb of every tendon from its end with e = 0 and β ignored (exact for S0 eq. 12): tension_joint holds
/// c_ij = T_ij − e_i, tension the motor's c, Sdot the branch velocities, rhs = τ − d, lowest = min_j c_ij.
template <class Qd>
inline void tendon_climb_lossless_beta(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau, Qd qd,
                                       TendonData& data) {
  const int m = model.m, n = model.n;
  data.rhs = tau;
  for (int i = 0; i < m; ++i) {
    const int last = model.last_joint[i];
    double sdot = 0.0, c = 0.0, low = 0.0;
    for (int b = n - 1; b > last; --b) {
      data.Sdot(i, b) = 0.0;
      data.tension_joint(i, b) = 0.0;
    }
    for (int b = last; b >= 0; --b) {
      data.tension_joint(i, b) = c;  // at joint b: the branches after it climbed
      data.rhs[b] -= model.K(i, b) * c;
      low = std::min(low, c);
      sdot += model.K(i, b) * qd(b);
      data.Sdot(i, b) = sdot;
      if (sdot != 0.0) c += (sdot > 0.0 ? model.tau0(i, b) : -model.tau0(i, b)) + model.nu(i, b) * sdot;
    }
    data.tension[i] = c;  // at the motor
    data.lowest[i] = std::min(low, c);
  }
}

/// Tendon i climbed from its end tension e with the branch laws of S0 eqs. 11–12 (losses.hpp's
/// branch_upstream_slope, the piece that holds): writes tension_joint(i, ·) (0 past the end), tension[i] (motor)
/// and slope(i, ·) = ∂T_ij/∂e, slope_motor[i] = ∂T_i/∂e (products of 1/(1 ± β), 1 ± β: > 0).
inline void tendon_climb_beta(const TendonModel& model, TendonData& data, int i, double e) {
  const double scale = data.beta_scale;
  const int last = model.last_joint[i];
  double x = e, g = 1.0;
  for (int b = last; b >= 0; --b) {
    data.tension_joint(i, b) = x;
    data.slope(i, b) = g;
    const double sdot = data.Sdot(i, b);
    if (sdot == 0.0) continue;  // at rest: passes the tension (static friction not compensated)
    const double be = scale * model.beta(i, b);
    double s = 1.0;
    x = branch_upstream_slope(x, sdot, model.tau0(i, b) + model.nu(i, b) * std::abs(sdot), be, 1.0 / (1.0 + be),
                              1.0 / (1.0 - be), &s);
    g *= s;
  }
  data.tension[i] = x;
  data.slope_motor[i] = g;
}

/// The least end tension of tendon i that keeps every point of it (its end, each pulley, the motor) at or above
/// its floor: each point's floor carried down to the end with losses.hpp's branch_tension_downstream (the exact
/// inverse of the climb, monotone), the largest of them. O(n²) per tendon.
inline double tendon_floor_end(const TendonModel& model, const TendonData& data, int i) {
  const int last = model.last_joint[i];
  double need = model.tension_min[i];  // the end itself
  for (int p = -1; p < last; ++p) {    // p = −1: the motor; else joint p; descend branches p + 1 … last
    double x = model.tension_min[i];
    for (int b = p + 1; b <= last; ++b) {
      const double sdot = data.Sdot(i, b);
      if (sdot != 0.0)
        x = branch_tension_downstream(x, sdot, BranchFriction{model.tau0(i, b), data.beta_scale * model.beta(i, b)},
                                      model.nu(i, b));
    }
    need = std::max(need, x);
  }
  return need;
}

/// Residual of the β system at the end tensions data.tension_end (climbs every tendon): r_j = Σ_i K_ij T_ij − τ_j
/// (S0 eq. 4) for j < n, r_n = (e_a − E_a)/h_a (tendon a on its floor). Returns Σ r².
inline double tendon_beta_residual(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                                   TendonData& data, int a) {
  const int m = model.m, n = model.n;
  for (int i = 0; i < m; ++i) tendon_climb_beta(model, data, i, data.tension_end[i]);
  const double g = (data.tension_end[a] - data.floor_end[a]) / model.null_vector[a];
  double sq = g * g;
  for (int j = 0; j < n; ++j) {
    double r = -tau[j];
    for (int i = 0; i < m; ++i) r += model.K(i, j) * data.tension_joint(i, j);
    data.resid[j] = r;
    sq += r * r;
  }
  data.resid[n] = g;
  return sq;
}

/// Newton on the active pieces for the tendon a on its floor, from data.tension_end: with the pieces of every
/// branch fixed (the pattern) the m equations are linear in e; solve, climb again, and the pattern is verified by
/// the residual (≈ 0, to rounding, when it held). A step that changes the pattern is damped (halved until Σ r²
/// decreases, Armijo 1e-4: the Newton direction descends Σ r² on every piece). Counts steps in data.iterations.
inline bool tendon_newton_beta(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                               TendonData& data, int a) {
  const int m = model.m, n = model.n;
  constexpr int kMaxIterations = 40;
  double sq = tendon_beta_residual(model, tau, data, a);
  for (int it = 0; it <= kMaxIterations; ++it) {
    double scale_t = 0.0, scale_e = 1.0;  // the rounding of the terms of each equation
    for (int j = 0; j < n; ++j) {
      double s = std::abs(tau[j]);
      for (int i = 0; i < m; ++i) s += std::abs(model.K(i, j) * data.tension_joint(i, j));
      scale_t = std::max(scale_t, s);
    }
    for (int i = 0; i < m; ++i) scale_e = std::max(scale_e, std::abs(data.tension_end[i]));
    bool done = std::abs(data.resid[n]) <= 1e-13 * scale_e;
    for (int j = 0; j < n && done; ++j) done = std::abs(data.resid[j]) <= 1e-14 * scale_t;
    if (done) return true;
    if (it == kMaxIterations) break;
    ++data.iterations;
    // the Jacobian of the pattern: ∂r_j/∂e_i = K_ij ∂T_ij/∂e_i, ∂r_n/∂e_a = 1/h_a
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < m; ++i) data.jacobian(j, i) = model.K(i, j) * data.slope(i, j);
    data.jacobian.row(n).setZero();
    data.jacobian(n, a) = 1.0 / model.null_vector[a];
    data.lu.compute(data.jacobian);
    data.step.noalias() = data.lu.solve(data.resid);
    if (!data.step.allFinite()) return false;
    data.e_prev = data.tension_end;
    double alpha = 1.0, best = INFINITY, best_alpha = 1.0;
    for (int k = 0; k < 40; ++k, alpha *= 0.5) {
      data.tension_end = data.e_prev - alpha * data.step;
      const double trial = tendon_beta_residual(model, tau, data, a);
      if (trial <= (1.0 - 1e-4 * alpha) * sq) { best = trial; best_alpha = alpha; break; }
      if (trial < best) { best = trial; best_alpha = alpha; }
    }
    if (!(best < sq)) return false;  // no decrease along the Newton direction
    data.tension_end = data.e_prev - best_alpha * data.step;
    sq = tendon_beta_residual(model, tau, data, a);
  }
  return false;
}

/// The floors e_i ≥ E_i (tendon_floor_end) with the least internal tension at the β scale data.beta_scale: along
/// the solution curve of the n joint equations every e_i grows with the internal tension, so the answer has one
/// tendon a on its floor and the others at or above theirs. Active set on a: solve (tendon_newton_beta), and while
/// some tendon is below its floor make the lowest one (in units of h) the active one and solve again (each switch
/// raises the internal tension; at most m + 1 solves). *a: in, the first guess; out, the tendon on its floor.
inline bool tendon_active_set_beta(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                                   TendonData& data, int* a) {
  const int m = model.m;
  for (int i = 0; i < m; ++i) data.floor_end[i] = tendon_floor_end(model, data, i);
  for (int round = 0; round <= m; ++round) {
    if (!tendon_newton_beta(model, tau, data, *a)) return false;
    double low = 0.0;
    int next = *a;
    for (int i = 0; i < m; ++i) {
      const double g = (data.tension_end[i] - data.floor_end[i]) / model.null_vector[i];
      if (g < low) { low = g; next = i; }
    }
    if (!(low < -1e-12 * std::max(1.0, data.tension_end.cwiseAbs().maxCoeff()))) return true;
    *a = next;
  }
  return false;
}

/// The β system (S0 eq. 11: each branch law is one of four lines in its tension, losses.hpp's pieces) solved as a
/// piecewise-linear one, by continuation in β: from the exact solution without β (τ0 and ν only), β is scaled by
/// s = 1 (one stage when Newton converges from there, the usual case) and, when a stage fails, the step in s is
/// halved from the last solved stage (at most kMaxStages stages): every stage starts near its solution, inside
/// the patterns where the internal tension still loads every tendon.
inline Status tendon_solve_beta(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                                TendonData& data, int a) {
  constexpr int kMaxStages = 24;
  data.iterations = 0;
  double done = 0.0, step = 1.0;
  data.e_good = data.tension_end;
  int a_good = a;
  for (int stage = 0; stage < kMaxStages; ++stage) {
    const double target = std::min(1.0, done + step);
    data.beta_scale = target;
    int act = a_good;
    data.tension_end = data.e_good;
    if (tendon_active_set_beta(model, tau, data, &act)) {
      done = target;
      data.e_good = data.tension_end;
      a_good = act;
      if (done >= 1.0) return Status::Ok;
      step *= 2.0;
    } else {
      step *= 0.5;
    }
  }
  data.beta_scale = 1.0;  // leave the tensions of the best stage climbed with the full β
  data.tension_end = data.e_good;
  for (int i = 0; i < model.m; ++i) tendon_climb_beta(model, data, i, data.tension_end[i]);
  return Status::NotConverged;
}

template <class Qd>
inline Status tendon_feedforward_impl(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau, Qd qd,
                                      TendonData& data) {
  const int m = model.m;
  tendon_climb_lossless_beta(model, tau, qd, data);
  data.tension_end.noalias() = model.tension_from_torque * data.rhs;
  double lam = -INFINITY;
  int active = 0;
  for (int i = 0; i < m; ++i) {
    const double l = (model.tension_min[i] - data.tension_end[i] - data.lowest[i]) / model.null_vector[i];
    if (l > lam) { lam = l; active = i; }
  }
  data.tension_end += lam * model.null_vector;
  data.iterations = 0;
  Status status = Status::Ok;
  if (model.has_beta) {
    status = tendon_solve_beta(model, tau, data, active);  // leaves tension_joint, tension at the final end tensions
    // λ: the component of the end tensions along h (P's columns are ⟂ h; = the λ above without β)
    data.internal_tension = model.null_vector.dot(data.tension_end) / model.null_vector.squaredNorm();
  } else {
    for (int i = 0; i < m; ++i) {
      const double e = data.tension_end[i];
      for (int b = 0; b <= model.last_joint[i]; ++b) data.tension_joint(i, b) += e;
      data.tension[i] += e;
    }
    data.internal_tension = lam;
  }
  data.motor_torque = model.motor_radius.cwiseProduct(data.tension);
  return status;
}

inline bool tendon_data_fits(const TendonModel& model, const TendonData& data) {
  return data.tension.size() == model.m && data.tension_end.size() == model.m && data.lowest.size() == model.m &&
         data.motor_torque.size() == model.m && data.tension_joint.rows() == model.m &&
         data.tension_joint.cols() == model.n && data.Sdot.rows() == model.m && data.Sdot.cols() == model.n &&
         data.rhs.size() == model.n && data.e_prev.size() == model.m && data.e_good.size() == model.m && data.floor_end.size() == model.m &&
         data.slope.rows() == model.m && data.slope.cols() == model.n && data.slope_motor.size() == model.m &&
         data.resid.size() == model.m && data.step.size() == model.m && data.jacobian.rows() == model.m &&
         data.jacobian.cols() == model.m;
}
}  // namespace detail

/// Joint torques τ (n,) [N·m] and velocities q̇ (n,) [rad/s] → tensions along every tendon ≥ its floor (S0 eq. 12
/// losses) and motor torques (m,) [N·m]. q̇ = 0: the lossless feedforward. No allocation.
inline Status tendon_feedforward(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                                 const Eigen::Ref<const Eigen::VectorXd>& qd, TendonData& data) {
  if (tau.size() != model.n || qd.size() != model.n || !detail::tendon_data_fits(model, data))
    return Status::SizeMismatch;
  if (!tau.allFinite() || !qd.allFinite()) return Status::NonFiniteInput;
  return detail::tendon_feedforward_impl(model, tau, [&](int b) { return qd[b]; }, data);
}

/// The lossless feedforward (every branch at rest, q̇ = 0). No allocation.
inline Status tendon_feedforward(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                                 TendonData& data) {
  if (tau.size() != model.n || !detail::tendon_data_fits(model, data)) return Status::SizeMismatch;
  if (!tau.allFinite()) return Status::NonFiniteInput;
  return detail::tendon_feedforward_impl(model, tau, [](int) { return 0.0; }, data);
}

/// Tensions t (m,) [N] → joint torques τ = Kᵀ t (n,) [N·m]. No allocation.
inline Status tendon_joint_torque(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tension,
                                  Eigen::Ref<Eigen::VectorXd> tau) {
  if (tension.size() != model.m || tau.size() != model.n) return Status::SizeMismatch;
  if (!tension.allFinite()) return Status::NonFiniteInput;
  tau.noalias() = model.K.transpose() * tension;
  return Status::Ok;
}

/// Joint velocities q̇ (n,) [rad/s] → tendon velocities ℓ̇ = K q̇ (m,) [m/s]. No allocation.
inline Status tendon_velocity(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& qd,
                              Eigen::Ref<Eigen::VectorXd> tendon_speed) {
  if (qd.size() != model.n || tendon_speed.size() != model.m) return Status::SizeMismatch;
  if (!qd.allFinite()) return Status::NonFiniteInput;
  tendon_speed.noalias() = model.K * qd;
  return Status::Ok;
}

}  // namespace tendyn

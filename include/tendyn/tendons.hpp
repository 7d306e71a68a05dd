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
// ≥ its floor and one touches it. Exact for S0 eq. 12; the tension-proportional β of eq. 11, bearings and reducer
// efficiencies are not modelled on N+1 tendons (the loader refuses them).
// Model / Data / Status as compensator.hpp: make_* allocate at setup; tendon_feedforward, tendon_joint_torque and
// tendon_velocity neither allocate nor throw.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include <Eigen/Core>
#include <Eigen/SVD>

#include "tendyn/status.hpp"

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
};

/// Build the model (setup time; allocates). Returns "" or the first problem, naming the tendon 0-based
/// ("tendon 2: ...") like the core's other validation messages; `out` is unchanged on a problem.
/// last_joint (m,), tau0 and nu (m, n): the branches of each tendon (S0 eq. 12); empty: lossless, last_joint = the
/// last nonzero entry of each row of K.
inline std::string make_tendon_model(const Eigen::MatrixXd& K, const Eigen::VectorXd& motor_radius,
                                     const Eigen::VectorXd& tension_min, TendonModel& out,
                                     const Eigen::VectorXi& last_joint = Eigen::VectorXi(),
                                     const Eigen::MatrixXd& tau0 = Eigen::MatrixXd(),
                                     const Eigen::MatrixXd& nu = Eigen::MatrixXd()) {
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
  Eigen::MatrixXd t0 = Eigen::MatrixXd::Zero(m, n), v = Eigen::MatrixXd::Zero(m, n);
  for (auto [src, dst, name] : {std::tuple{&tau0, &t0, "tau0"}, std::tuple{&nu, &v, "nu"}}) {
    if (src->size() == 0) continue;
    if (src->rows() != m || src->cols() != n)
      return std::string(name) + " must be (m, n) = (" + std::to_string(m) + ", " + std::to_string(n) + ")";
    for (int i = 0; i < m; ++i)
      for (int b = 0; b < n; ++b) {
        const double x = (*src)(i, b);
        if (!(std::isfinite(x) && x >= 0.0))
          return std::string(name) + "[" + std::to_string(i) + "," + std::to_string(b) + "]: must be finite and >= 0";
        if (b > last[i] && x != 0.0)
          return std::string(name) + "[" + std::to_string(i) + "," + std::to_string(b) + "]: must be 0 past the " +
                 "tendon's last joint";
        (*dst)(i, b) = x;
      }
  }
  const Eigen::MatrixXd Kt = K.transpose();  // (n, m)
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Kt, Eigen::ComputeFullU | Eigen::ComputeFullV);
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
template <class Qd>
inline Status tendon_feedforward_impl(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau, Qd qd,
                                      TendonData& data) {
  const int m = model.m, n = model.n;
  // climb each tendon from its end with e = 0: tension_joint holds c_ij, tension the motor's Σ Δ
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
  data.tension_end.noalias() = model.tension_from_torque * data.rhs;
  double lam = -INFINITY;
  for (int i = 0; i < m; ++i)
    lam = std::max(lam, (model.tension_min[i] - data.tension_end[i] - data.lowest[i]) / model.null_vector[i]);
  data.tension_end += lam * model.null_vector;
  for (int i = 0; i < m; ++i) {
    const double e = data.tension_end[i];
    for (int b = 0; b <= model.last_joint[i]; ++b) data.tension_joint(i, b) += e;
    data.tension[i] += e;
  }
  data.motor_torque = model.motor_radius.cwiseProduct(data.tension);
  data.internal_tension = lam;
  return Status::Ok;
}

inline bool tendon_data_fits(const TendonModel& model, const TendonData& data) {
  return data.tension.size() == model.m && data.tension_end.size() == model.m && data.lowest.size() == model.m &&
         data.motor_torque.size() == model.m && data.tension_joint.rows() == model.m &&
         data.tension_joint.cols() == model.n && data.Sdot.rows() == model.m && data.Sdot.cols() == model.n &&
         data.rhs.size() == model.n;
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

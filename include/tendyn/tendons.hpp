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
// The feedforward keeps every tension at or above its floor t_min,i [N] with the least internal tension:
//     λ = max_i (t_min,i − (P τ)_i) / h_i,
// so one tendon sits exactly on its floor. The least λ that serves a whole box |τ_j| ≤ τ_max,j is
//     λ_box = max_i (t_min,i + Σ_j |P_ij| τ_max,j) / h_i     (t is linear in τ: the worst vertex, in closed form).
// The calls are lossless (branch losses along N+1 tendons are not modelled yet; the device file's friction is
// checked and kept). Model / Data / Status as compensator.hpp: make_* allocate at setup, tendon_feedforward,
// tendon_joint_torque and tendon_velocity neither allocate nor throw.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>

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
};

/// Outputs of tendon_feedforward (sized once by make_tendon_data).
struct TendonData {
  Eigen::VectorXd tension;        ///< (m,) [N]
  Eigen::VectorXd motor_torque;   ///< (m,) [N·m]: C_m = R_m t
  double internal_tension = 0.0;  ///< λ [N]: the scale of h added to the minimum-norm tensions
};

/// Build the model (setup time; allocates). Returns "" or the first problem, naming the tendon 0-based
/// ("tendon 2: ...") like the core's other validation messages; `out` is unchanged on a problem.
inline std::string make_tendon_model(const Eigen::MatrixXd& K, const Eigen::VectorXd& motor_radius,
                                     const Eigen::VectorXd& tension_min, TendonModel& out) {
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
  out = std::move(t);
  return "";
}

inline TendonData make_tendon_data(const TendonModel& model) {
  TendonData d;
  d.tension = Eigen::VectorXd::Zero(model.m);
  d.motor_torque = Eigen::VectorXd::Zero(model.m);
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

/// Joint torques τ (n,) [N·m] → tensions t ≥ t_min (m,) [N] and motor torques (m,) [N·m]. No allocation.
inline Status tendon_feedforward(const TendonModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau,
                                 TendonData& data) {
  if (tau.size() != model.n || data.tension.size() != model.m || data.motor_torque.size() != model.m)
    return Status::SizeMismatch;
  if (!tau.allFinite()) return Status::NonFiniteInput;
  data.tension.noalias() = model.tension_from_torque * tau;
  double lam = -INFINITY;
  for (int i = 0; i < model.m; ++i)
    lam = std::max(lam, (model.tension_min[i] - data.tension[i]) / model.null_vector[i]);
  data.tension += lam * model.null_vector;
  data.motor_torque = model.motor_radius.cwiseProduct(data.tension);
  data.internal_tension = lam;
  return Status::Ok;
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

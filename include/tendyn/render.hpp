// tendyn — haptic rendering on the compensator: god-object proxy, S0 eq. (23) (C10).
//
//   F_d = (K_st + K_d s)(X_god − X̂) + F_fr + F_T,  τ_wanted = J(q̂)ᵀ F_d, motor torques by the compensator
// (gravity + transmission losses), X̂ from the motor encoders through the transmission and the direct
// kinematics (compensator_sense). The scene is a set of half-spaces (planes, solid on the side n·x < offset)
// and at most one solid sphere. The god object (proxy) X_god follows X̂ in free space and stays on the
// surface in contact: each cycle it moves from where it was toward X̂, stops at the first surface it meets,
// then slides on the tangent planes of the active constraints (one plane: projection; two: their line;
// three: it stays), a few sub-steps per cycle so it follows the curved sphere.
// Terms:
//   * K_st (X_god − X̂): wall stiffness [N/m];
//   * K_d s (X_god − X̂): with the proxy sliding on the tangent plane, d/dt (X_god − X̂) = −(n·Ẋ̂) n, so the
//     damping acts along the contact normal only [N·s/m] (Ẋ̂ = J q̂̇ from the filtered encoder velocity);
//   * F_fr, Coulomb surface friction on the proxy: a stick anchor on the surface pulls the proxy back with
//     K_st (anchor − X_god) projected on the tangent plane, saturated at μ |F_n| (slip: the anchor is dragged);
//   * F_T, texture: a grating along `texture_direction`, F_T = a_T |F_n| sin(2π X_god·e / λ) n.
// Every term is zero out of contact. Model / Data convention, no allocation, Status codes, compute time.
#pragma once

#include "tendyn/compensator.hpp"

#include <chrono>
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tendyn {

/// Immutable scene and rendering gains.
struct RenderModel {
  static constexpr int max_planes = 8;
  int n_planes = 0;                                          ///< planes in use (≤ max_planes)
  Eigen::Matrix<double, 3, max_planes> plane_normal = Eigen::Matrix<double, 3, max_planes>::Zero();  ///< unit, out of the solid
  Eigen::Matrix<double, max_planes, 1> plane_offset = Eigen::Matrix<double, max_planes, 1>::Zero();  ///< solid where n·x < offset [m]
  bool sphere = false;                                       ///< a solid sphere in the scene
  Eigen::Vector3d sphere_center = Eigen::Vector3d::Zero();   ///< [m]
  double sphere_radius = 0.0;                                ///< [m]
  double stiffness = 1000.0;       ///< K_st [N/m]
  double damping = 0.0;            ///< K_d [N·s/m]
  double surface_friction = 0.0;   ///< μ [-], Coulomb friction on the proxy
  double texture_amplitude = 0.0;  ///< a_T [-], fraction of the normal force
  double texture_period = 0.01;    ///< λ [m]
  Eigen::Vector3d texture_direction = Eigen::Vector3d::UnitX();  ///< e, unit
  int substeps = 4;                ///< proxy sub-steps per cycle (curved surfaces)

  /// Add the half-space n·x ≥ offset as free space (setup). Returns false when full or n is not unit.
  bool add_plane(const Eigen::Vector3d& normal, double offset) {
    if (n_planes >= max_planes || std::abs(normal.norm() - 1.0) > 1e-9 || !std::isfinite(offset)) return false;
    plane_normal.col(n_planes) = normal;
    plane_offset(n_planes) = offset;
    ++n_planes;
    return true;
  }
  Status validate() const {
    if (n_planes < 0 || n_planes > max_planes || !(stiffness >= 0.0) || !(damping >= 0.0) ||
        !(surface_friction >= 0.0) || !std::isfinite(texture_amplitude) || !(texture_period > 0.0) ||
        (sphere && !(sphere_radius > 0.0)) || substeps < 1)
      return Status::InvalidModel;
    return Status::Ok;
  }
};

/// Preallocated state and outputs of the renderer.
struct RenderData {
  Eigen::Vector3d x_hat = Eigen::Vector3d::Zero();     ///< X̂ [m]
  Eigen::Vector3d xd_hat = Eigen::Vector3d::Zero();    ///< Ẋ̂ [m/s]
  Eigen::Vector3d x_god = Eigen::Vector3d::Zero();     ///< proxy [m]
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();    ///< friction stick point [m]
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();    ///< contact normal (out of the solid)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();     ///< F_d [N]
  Eigen::Vector3d force_friction = Eigen::Vector3d::Zero();  ///< F_fr [N]
  Eigen::Vector3d force_texture = Eigen::Vector3d::Zero();   ///< F_T [N]
  bool in_contact = false;
  bool started = false;
  int active = 0;                                      ///< number of active constraints
  Eigen::Matrix3d constraint = Eigen::Matrix3d::Zero();///< their normals (columns)
  double compute_time = 0.0;                           ///< last cycle, renderer + compensator [s]
  void reset() { started = false; in_contact = false; }
};

namespace detail {

/// Normals of the surfaces the proxy p lies on that the goal g would enter (free space: n·x ≥ offset).
inline int active_constraints(const RenderModel& r, const Eigen::Vector3d& p, const Eigen::Vector3d& g,
                              Eigen::Matrix3d& out) {
  constexpr double eps = 1e-9;
  int k = 0;
  for (int i = 0; i < r.n_planes && k < 3; ++i) {
    const Eigen::Vector3d n = r.plane_normal.col(i);
    if (n.dot(p) - r.plane_offset(i) <= eps && n.dot(g - p) < 0.0) out.col(k++) = n;
  }
  if (r.sphere && k < 3) {
    const Eigen::Vector3d rel = p - r.sphere_center;
    const double dist = rel.norm();
    if (dist > 0.0 && dist - r.sphere_radius <= eps * (1.0 + r.sphere_radius)) {
      const Eigen::Vector3d n = rel / dist;
      if (n.dot(g - p) < 0.0) out.col(k++) = n;
    }
  }
  return k;
}

/// Closest point to g on the intersection of the active tangent planes through p (lowest rank that holds).
inline Eigen::Vector3d constrained_goal(const Eigen::Vector3d& p, const Eigen::Vector3d& g, const Eigen::Matrix3d& c,
                                       int k) {
  if (k == 0) return g;
  const Eigen::Vector3d dg = g - p;
  for (int a = 0; a < k; ++a) {  // one plane, if it satisfies the others
    const Eigen::Vector3d n = c.col(a);
    const Eigen::Vector3d cand = dg - n * n.dot(dg);
    bool ok = true;
    for (int b = 0; b < k; ++b) ok = ok && (b == a || c.col(b).dot(cand) >= -1e-12);
    if (ok) return p + cand;
  }
  for (int a = 0; a < k; ++a)  // the line of two planes
    for (int b = a + 1; b < k; ++b) {
      Eigen::Vector3d u = c.col(a).cross(c.col(b));
      const double un = u.norm();
      if (un < 1e-12) continue;
      u /= un;
      const Eigen::Vector3d cand = u * u.dot(dg);
      bool ok = true;
      for (int e = 0; e < k; ++e) ok = ok && (e == a || e == b || c.col(e).dot(cand) >= -1e-12);
      if (ok) return p + cand;
    }
  return p;
}

/// First entry t ∈ (0, 1] of the segment p → p + s(dir) into a solid; 2 when none.
inline double first_hit(const RenderModel& r, const Eigen::Vector3d& p, const Eigen::Vector3d& dir) {
  double t = 2.0;
  for (int i = 0; i < r.n_planes; ++i) {
    const Eigen::Vector3d n = r.plane_normal.col(i);
    const double side = n.dot(p) - r.plane_offset(i), rate = n.dot(dir);
    if (rate < 0.0 && side >= -1e-12) {
      const double ti = std::max(0.0, side / -rate);
      if (ti <= 1.0 && ti < t) t = ti;
    }
  }
  if (r.sphere) {
    const Eigen::Vector3d rel = p - r.sphere_center;
    const double a = dir.squaredNorm(), b = 2.0 * rel.dot(dir), c = rel.squaredNorm() - r.sphere_radius * r.sphere_radius;
    const double disc = b * b - 4.0 * a * c;
    if (a > 0.0 && disc > 0.0 && c >= -1e-12 * (1.0 + r.sphere_radius)) {
      const double t1 = (-b - std::sqrt(disc)) / (2.0 * a);
      if (t1 > 1e-12 && t1 <= 1.0 && t1 < t) t = t1;
    }
  }
  return t;
}

}  // namespace detail

/// Advance the proxy toward X̂ = data.x_hat (god-object update, no forces). Allocates nothing.
inline void render_proxy(const RenderModel& r, RenderData& d) {
  if (!d.started) {
    d.x_god = d.x_hat;
    d.anchor = d.x_hat;
    d.started = true;
  }
  Eigen::Vector3d p = d.x_god;
  const Eigen::Vector3d g = d.x_hat;
  d.active = 0;
  for (int it = 0; it < r.substeps; ++it) {
    const int k = detail::active_constraints(r, p, g, d.constraint);
    d.active = k;
    const Eigen::Vector3d target = detail::constrained_goal(p, g, d.constraint, k);
    const Eigen::Vector3d dir = target - p;
    const double t = detail::first_hit(r, p, dir);
    if (t <= 1.0) {
      p += t * dir;   // stopped on a surface: constrain and go on
      continue;
    }
    p = target;
    if (k == 0) break;  // reached X̂ in free space
  }
  d.x_god = p;
  d.active = detail::active_constraints(r, p, g, d.constraint);
}

/// Forces of eq. (23) from the proxy and X̂, Ẋ̂ (call render_proxy first). Writes data.force and its parts.
inline void render_force(const RenderModel& r, RenderData& d) {
  const Eigen::Vector3d e = d.x_god - d.x_hat;
  const double depth = e.norm();
  d.in_contact = d.active > 0 && depth > 0.0;
  d.force_friction.setZero();
  d.force_texture.setZero();
  if (!d.in_contact) {
    d.force.setZero();
    d.normal.setZero();
    d.anchor = d.x_god;
    return;
  }
  d.normal = e / depth;
  const double vn = d.normal.dot(d.xd_hat);
  const Eigen::Vector3d spring = r.stiffness * e;
  const double fn = r.stiffness * depth;
  Eigen::Vector3d damp = -r.damping * vn * d.normal;  // K_d s (X_god − X̂) along the normal
  if (damp.dot(d.normal) < -fn) damp = -fn * d.normal;  // never pull the hand into the wall
  if (r.surface_friction > 0.0) {
    Eigen::Vector3d pull = r.stiffness * (d.anchor - d.x_god);
    pull -= d.normal * d.normal.dot(pull);
    const double limit = r.surface_friction * fn, mag = pull.norm();
    if (mag > limit) {
      pull *= limit / mag;  // slip: the anchor is dragged behind the proxy
      d.anchor = d.x_god + pull / r.stiffness;
    }
    d.force_friction = pull;
  } else {
    d.anchor = d.x_god;
  }
  if (r.texture_amplitude != 0.0)
    d.force_texture = r.texture_amplitude * fn *
                      std::sin(6.283185307179586 * d.x_god.dot(r.texture_direction) / r.texture_period) * d.normal;
  d.force = spring + damp + d.force_friction + d.force_texture;
}

/// One rendering cycle: encoders → X̂ → proxy → F_d → τ = Jᵀ F_d → motor torques with gravity and losses
/// (compensator_command; the motor torques are in cdata.torque_motor). Compute time in rdata.compute_time.
/// @param q_motor  motor encoder positions (n) [rad]
template <class V>
inline Status render_cycle(const RenderModel& r, RenderData& d, const CompensatorModel& cm, CompensatorData& cd,
                           const V& q_motor) {
  const auto t0 = std::chrono::steady_clock::now();
  Status s = compensator_sense(cm, cd, q_motor);
  if (!is_error(s)) {
    d.x_hat = cd.chain.ee_position;
    d.xd_hat.noalias() = cd.chain.ee_jacobian_active * cd.qd;
    render_proxy(r, d);
    render_force(r, d);
    cd.torque_joint_wanted.noalias() = cd.chain.ee_jacobian_active.transpose() * d.force;
    s = compensator_command(cm, cd, cd.torque_joint_wanted);
  }
  d.compute_time = detail::seconds_since(t0);
  cd.compute_time = d.compute_time;
  return s;
}

}  // namespace tendyn

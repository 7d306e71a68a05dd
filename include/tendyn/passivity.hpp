// tendyn — time-domain passivity at the motor ports of the compensator (Hannaford & Ryu's passivity
// observer and passivity controller, applied to friction compensation).
//
// The port: motor i, where the compensator adds the torque τ_add,i = k w_i C_f,i (its friction part) plus the
// controller's own τ_pc,i on top of the lossless torques C₀ (compensator.hpp step 6). Friction compensation
// is meant to return to the device what its transmission dissipates, no more: the device stays passive toward
// the hand as long as the energy the compensator injects does not exceed the energy the physical friction
// dissipates. The observer cannot trust the compensator's own friction model for that (k > 1 or a friction
// over-estimated 2.4× is exactly what it must catch), so it counts against a separate, certified lower bound
// of each motor's dissipation, D_i(Δq) = c_i |Δq| + b_i Δq² / T (Coulomb c_i [N·m], viscous b_i [N·m·s/rad],
// motor side, from an identification with a margin: tendyn.control.passivity).
//
// Observer (one per motor, position-based, exact for a zero-order hold): the torque commanded in the last
// period acted over the displacement Δq_m,i measured since, so
//     E_i ← E_i + τ_add,i(n−1) Δq_m,i(n) − D_i(Δq_m,i(n)),          E_i ≥ −reserve
// is the energy the compensator injected beyond the certified dissipation [J] (> 0: the port is active).
// Controller: when E_i > 0 a damping α_i = min(E_i / (T v̂_i²), α_max) adds τ_pc,i = −α_i v̂_i (v̂_i the filtered
// motor velocity) for the next period, which the observer counts when the next displacement is read. The
// reserve [J] caps the dissipation the observer banks (without a cap a long dissipative stretch would license
// a later burst of energy, i.e. a limit cycle after a quiet start); α_max bounds the damping so that the
// sampled damper stays stable on the rotor alone (α_max T / J_rotor ≤ 1 by default).
// Model / Data convention, no allocation, no exception, Status codes.
#pragma once

#include "tendyn/routing.hpp"
#include "tendyn/status.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Core>

namespace tendyn {

/// Settings of the passivity observer and controller (all motor side).
struct PassivityModel {
  bool enabled = false;                  ///< observer + controller on (off: the compensator is unchanged)
  Eigen::VectorXd dissipation_coulomb;   ///< c_i [N·m], certified lower bound of motor i's Coulomb friction
  Eigen::VectorXd dissipation_viscous;   ///< b_i [N·m·s/rad], certified lower bound of its viscous friction
  double reserve = 0.0;                  ///< most dissipated energy the observer banks per motor [J]
  double damping_max = 0.0;              ///< α_max [N·m·s/rad], bound of the controller's damping

  /// Empty when usable for `n` motors (or disabled), otherwise the first problem naming the field.
  std::string first_issue(int n) const {
    if (!enabled) return std::string();
    if (dissipation_coulomb.size() != n || dissipation_viscous.size() != n)
      return "passivity.dissipation_coulomb / dissipation_viscous: " + std::to_string(n) + " values each expected";
    for (int i = 0; i < n; ++i) {
      if (!(dissipation_coulomb(i) >= 0.0 && dissipation_coulomb(i) <= 1e6))
        return "passivity.dissipation_coulomb[" + std::to_string(i) + "] = " + format_double(dissipation_coulomb(i)) +
               ": must be in [0, 1e6] [N·m] (the schema's bound on a motor's Coulomb friction)";
      if (!(dissipation_viscous(i) >= 0.0 && dissipation_viscous(i) <= 1e6))
        return "passivity.dissipation_viscous[" + std::to_string(i) + "] = " + format_double(dissipation_viscous(i)) +
               ": must be in [0, 1e6] [N·m·s/rad] (the schema's bound on a motor's viscous friction)";
    }
    if (!(reserve >= 0.0 && std::isfinite(reserve)))
      return "passivity.reserve = " + format_double(reserve) + ": must be finite and >= 0 [J]";
    if (!(damping_max > 0.0 && std::isfinite(damping_max)))
      return "passivity.damping_max = " + format_double(damping_max) + ": must be finite and > 0 [N·m·s/rad]";
    return std::string();
  }
};

/// State and outputs of the observer and controller (preallocated for n motors).
struct PassivityData {
  Eigen::VectorXd energy;            ///< E_i [J]: injected beyond the certified dissipation (> 0: active)
  Eigen::VectorXd torque_added_prev; ///< τ_add,i commanded in the last period (friction part + τ_pc) [N·m]
  Eigen::VectorXd damping;           ///< α_i of this cycle [N·m·s/rad]
  Eigen::VectorXd torque;            ///< τ_pc,i of this cycle [N·m]
  Eigen::VectorXd energy_injected;   ///< Σ τ_add Δq since reset [J] (what the compensator gave the device)
  Eigen::VectorXd energy_budget;     ///< Σ D_i(Δq) since reset [J] (certified dissipation)

  explicit PassivityData(int n = 0)
      : energy(Eigen::VectorXd::Zero(n)), torque_added_prev(Eigen::VectorXd::Zero(n)),
        damping(Eigen::VectorXd::Zero(n)), torque(Eigen::VectorXd::Zero(n)),
        energy_injected(Eigen::VectorXd::Zero(n)), energy_budget(Eigen::VectorXd::Zero(n)) {}

  void reset() {
    energy.setZero();
    torque_added_prev.setZero();
    damping.setZero();
    torque.setZero();
    energy_injected.setZero();
    energy_budget.setZero();
  }
};

/// Observer update for motor i with the displacement Δq [rad] of the last period T [s]; returns E_i [J].
inline double passivity_observe(const PassivityModel& m, PassivityData& d, int i, double step, double period) {
  const double injected = d.torque_added_prev(i) * step;
  const double budget = m.dissipation_coulomb(i) * std::abs(step) + m.dissipation_viscous(i) * step * step / period;
  d.energy_injected(i) += injected;
  d.energy_budget(i) += budget;
  d.energy(i) = std::max(d.energy(i) + injected - budget, -m.reserve);
  return d.energy(i);
}

/// Controller for motor i: the damping torque τ_pc,i [N·m] that dissipates E_i over the next period at the
/// velocity estimate v̂ [rad/s] (0 when the port is passive). Records α_i and τ_pc,i.
inline double passivity_control(const PassivityModel& m, PassivityData& d, int i, double velocity, double period) {
  const double e = d.energy(i);
  double alpha = 0.0;
  if (e > 0.0) {
    const double v2 = velocity * velocity;
    alpha = v2 > 0.0 ? std::min(e / (period * v2), m.damping_max) : m.damping_max;
  }
  d.damping(i) = alpha;
  d.torque(i) = -alpha * velocity;
  return d.torque(i);
}

}  // namespace tendyn

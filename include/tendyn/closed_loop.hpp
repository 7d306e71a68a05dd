// tendyn — closed-loop simulation of an identified inverse dynamic model (IDIM-IV and DIDIM, issue 30).
//
// The instruments of IDIM-IV and the output of DIDIM (python/tendyn/ident/closed_loop.py) come from the
// identified model driven by the logged reference through the log's controller. The model is the
// identification regressor's: τ_a = Y(q_a, q̇_a, q̈_a) X with the columns of regressor.hpp, i.e.
//
//   τ_a = Lᵀ (M_tree(q_t) L q̈_a + nle_tree(q_t, L q̇_a))                      q_t = L q_a + c  (S2 eq. 12)
//       + IA ∘ q̈_a + FV ∘ q̇_a + FS ∘ sgn(q̇_a) + OFFSET
//       + Gᵀ (IAm ∘ G q̈_a + FVm ∘ G q̇_a + FSm ∘ sgn(G q̇_a))
//
// with M_tree, nle_tree from the links' ten parameters each (tree_dynamics.hpp, linear in them, so any
// regrouped base-parameter vector simulates). Forward dynamics q̈_a = A⁻¹ (τ − b), A = Lᵀ M_tree L + diag(IA)
// + Gᵀ diag(IAm) G, b the rest at q̈ = 0 — the same model the regressor gives (checked against the Python
// loop that builds A and b from regressor calls, tests/python/test_ident_closed_loop.py).
//
// The controller, once per step of dt (the log's sample time), a decentralised PID per joint or per motor
// as the twin runs it: y = q_a (joint space) or G (q_a − offsets) (motor space), v̂ += α ((y − y_prev)/dt − v̂)
// (α = 1 − exp(−2π f_c dt), 1 without a filter), I += e dt with e = r − y, u = gain ∘ (kp e + kd (ff v_r − v̂)
// + ki I), τ = u (joint) or Gᵀ u (motor). Between two updates `substeps` steps of h = dt/substeps with the
// acceleration held over each: q += (q̇ + q̈ h/2) h, q̇ += q̈ h (semi-implicit, exact for a held q̈).
// Setup-level work (allocates per run; not a real-time call).
#pragma once

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "tendyn/regressor.hpp"
#include "tendyn/status.hpp"
#include "tendyn/tree_dynamics.hpp"

namespace tendyn {

/// The loop's controller (see the header comment); vectors of the reference's size (n_a or n_m).
struct LoopPID {
  Eigen::VectorXd kp, kd, ki, gain;   ///< gains [N·m/rad, N·m·s/rad, N·m/(rad·s)] and output scale
  bool motor = false;                 ///< false: joint space; true: motor space (y = G (q − offsets), τ = Gᵀ u)
  double velocity_cutoff_hz = 0.0;    ///< first-order filter of the differenced position (0: none)
  bool velocity_feedforward = true;   ///< kd (v_r − v̂) (true) or −kd v̂ (false)
};

namespace detail {

inline void closed_loop_run(const TreeDynamicsModel& tree0, const Eigen::MatrixXd& L, const Eigen::VectorXd& c,
                            const Eigen::MatrixXd& G, const Eigen::Ref<const RowMatrixXd>& X, Eigen::Index r,
                            const LoopPID& pid, const Eigen::Ref<const RowMatrixXd>& ref_q,
                            const Eigen::Ref<const RowMatrixXd>& ref_qd, const Eigen::VectorXd& q0,
                            const Eigen::VectorXd& offsets, double dt, int substeps, Eigen::Ref<RowMatrixXd> Q,
                            Eigen::Ref<RowMatrixXd> QD, Eigen::Ref<RowMatrixXd> QDD, Eigen::Ref<RowMatrixXd> TAU) {
  const Eigen::Index nt = L.rows(), na = L.cols(), nm = G.rows(), n = ref_q.rows(), nr = ref_q.cols();
  const Eigen::Index p_in = 10 * nt;
  TreeDynamicsModel tree = tree0;
  for (int j = 0; j < tree.n; ++j) tree.set_parameters(j, X.data() + r * X.outerStride() + 10 * j);
  TreeDynamicsData td(tree);
  Eigen::VectorXd IA(na), FV(na), FS(na), OFF(na), IAm(nm), FVm(nm), FSm(nm);
  for (Eigen::Index j = 0; j < na; ++j) {
    IA[j] = X(r, p_in + 4 * j);
    FV[j] = X(r, p_in + 4 * j + 1);
    FS[j] = X(r, p_in + 4 * j + 2);
    OFF[j] = X(r, p_in + 4 * j + 3);
  }
  for (Eigen::Index i = 0; i < nm; ++i) {
    IAm[i] = X(r, p_in + 4 * na + 3 * i);
    FVm[i] = X(r, p_in + 4 * na + 3 * i + 1);
    FSm[i] = X(r, p_in + 4 * na + 3 * i + 2);
  }
  const bool serial = nt == na && L.isIdentity(0.0) && c.isZero(0.0);
  // the constant part of A: Gᵀ diag(IAm) G + diag(IA)
  Eigen::MatrixXd A0 = G.transpose() * IAm.asDiagonal() * G;
  A0.diagonal() += IA;
  const double alpha = pid.velocity_cutoff_hz > 0.0 ? 1.0 - std::exp(-2.0 * M_PI * pid.velocity_cutoff_hz * dt) : 1.0;
  const double vff = pid.velocity_feedforward ? 1.0 : 0.0;
  const int S = std::max(substeps, 1);
  const double h = dt / S;
  Eigen::VectorXd q = q0, qd = Eigen::VectorXd::Zero(na), qdd(na), tau(na), u(nr), e(nr), y(nr), y_prev(nr);
  Eigen::VectorXd v_est = Eigen::VectorXd::Zero(nr), integ = Eigen::VectorXd::Zero(nr);
  Eigen::VectorXd qt(nt), vt(nt), b(na), vm(nm);
  Eigen::MatrixXd A(na, na);
  Eigen::PartialPivLU<Eigen::MatrixXd> lu(na);
  auto measure = [&](Eigen::VectorXd& out) {
    if (pid.motor)
      out.noalias() = G * (q - offsets);
    else
      out = q;
  };
  measure(y_prev);
  for (Eigen::Index k = 0; k < n; ++k) {
    measure(y);
    v_est += alpha * ((y - y_prev) / dt - v_est);
    y_prev = y;
    e = ref_q.row(k).transpose() - y;
    integ += e * dt;
    u = pid.gain.cwiseProduct(pid.kp.cwiseProduct(e) +
                              pid.kd.cwiseProduct(vff * ref_qd.row(k).transpose() - v_est) + pid.ki.cwiseProduct(integ));
    if (pid.motor)
      tau.noalias() = G.transpose() * u;
    else
      tau = u;
    const Eigen::Index row = r * n + k;
    Q.row(row) = q.transpose();
    QD.row(row) = qd.transpose();
    TAU.row(row) = tau.transpose();
    for (int s = 0; s < S; ++s) {
      if (serial) {
        tree_mass_and_bias(tree, td, q, qd);
        A = td.M + A0;
        b = td.nle;
      } else {
        qt.noalias() = L * q + c;
        vt.noalias() = L * qd;
        tree_mass_and_bias(tree, td, qt, vt);
        A.noalias() = L.transpose() * td.M * L;
        A += A0;
        b.noalias() = L.transpose() * td.nle;
      }
      for (Eigen::Index j = 0; j < na; ++j) b[j] += FV[j] * qd[j] + FS[j] * sign0(qd[j]) + OFF[j];
      if (nm > 0) {
        vm.noalias() = G * qd;
        for (Eigen::Index i = 0; i < nm; ++i) {
          const double fm = FVm[i] * vm[i] + FSm[i] * sign0(vm[i]);
          b.noalias() += G.row(i).transpose() * fm;
        }
      }
      if (na == 1) {
        qdd[0] = (tau[0] - b[0]) / A(0, 0);
      } else {
        lu.compute(A);
        qdd = lu.solve(tau - b);
      }
      if (s == 0) QDD.row(row) = qdd.transpose();
      q += (qd + 0.5 * h * qdd) * h;
      qd += qdd * h;
    }
  }
}

}  // namespace detail

/// Simulate the model of each parameter row of X in closed loop (header comment).
/// @param tree     the tree's kinematics (TreeDynamicsModel(pin), valid); its parameters are replaced per run
/// @param L, c     (n_tree, n_a), (n_tree) active-to-tree map q_t = L q_a + c
/// @param G        (n_m, n_a) motor-from-joint position matrix
/// @param X        (p, regressor_columns) parameter vectors in the regressor's column order, one run each
/// @param pid      the controller (vectors of ref_q's columns)
/// @param ref_q, ref_qd  (n, n_ref) reference positions [rad or m] and velocities, one row per step
/// @param q0       (n_a) initial active positions (at rest) [rad or m]
/// @param offsets  (n_a) joint offsets of the motor-space measurement G (q − offsets)
/// @param dt       controller period = step [s] (> 0); substeps ≥ 1 integration steps per period
/// @param Q, QD, QDD, TAU  (p n, n_a) outputs, run-major rows (run r, step k at row r n + k): positions,
///                  velocities, accelerations, the controller's joint torques [N·m or N]
/// @param threads  worker threads over the runs (≥ 1)
inline Status closed_loop_simulate(const TreeDynamicsModel& tree, const Eigen::MatrixXd& L, const Eigen::VectorXd& c,
                                   const Eigen::MatrixXd& G, const Eigen::Ref<const RowMatrixXd>& X,
                                   const LoopPID& pid, const Eigen::Ref<const RowMatrixXd>& ref_q,
                                   const Eigen::Ref<const RowMatrixXd>& ref_qd, const Eigen::VectorXd& q0,
                                   const Eigen::VectorXd& offsets, double dt, int substeps,
                                   Eigen::Ref<RowMatrixXd> Q, Eigen::Ref<RowMatrixXd> QD, Eigen::Ref<RowMatrixXd> QDD,
                                   Eigen::Ref<RowMatrixXd> TAU, int threads = 1) {
  if (!tree.valid) return Status::InvalidModel;
  const Eigen::Index nt = L.rows(), na = L.cols(), nm = G.rows(), n = ref_q.rows(), nr = ref_q.cols();
  const Eigen::Index p = X.rows();
  if (nt != tree.n || c.size() != nt || G.cols() != na || X.cols() != 10 * nt + 4 * na + 3 * nm)
    return Status::SizeMismatch;
  if (ref_qd.rows() != n || ref_qd.cols() != nr || q0.size() != na || offsets.size() != na) return Status::SizeMismatch;
  if (nr != (pid.motor ? nm : na) || pid.kp.size() != nr || pid.kd.size() != nr || pid.ki.size() != nr ||
      pid.gain.size() != nr)
    return Status::SizeMismatch;
  for (auto* M : {&Q, &QD, &QDD, &TAU})
    if (M->rows() != p * n || M->cols() != na) return Status::SizeMismatch;
  if (!(dt > 0.0) || !std::isfinite(dt) || threads < 1) return Status::InvalidModel;
  if (!all_finite(X) || !all_finite(ref_q) || !all_finite(ref_qd) || !all_finite(q0)) return Status::NonFiniteInput;
  const Eigen::Index T = std::max<Eigen::Index>(1, std::min<Eigen::Index>(threads, p));
  auto work = [&](Eigen::Index r0, Eigen::Index r1) {
    for (Eigen::Index r = r0; r < r1; ++r)
      detail::closed_loop_run(tree, L, c, G, X, r, pid, ref_q, ref_qd, q0, offsets, dt, substeps, Q, QD, QDD, TAU);
  };
  if (T == 1) {
    work(0, p);
    return Status::Ok;
  }
  std::vector<std::thread> pool;
  for (Eigen::Index t = 0; t < T; ++t) pool.emplace_back(work, p * t / T, p * (t + 1) / T);
  for (auto& th : pool) th.join();
  return Status::Ok;
}

}  // namespace tendyn

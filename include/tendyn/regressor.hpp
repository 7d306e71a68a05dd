// tendyn — dynamic-identification regressor over whole sample arrays (inverse dynamic model, IDIM).
//
// The joint-torque regressor of Pinocchio (computeJointTorqueRegressor's columns: 10 standard parameters per link,
// Pinocchio's order M MX MY MZ XX XY YY XZ YZ ZZ, about the link frame origin) evaluated at every sample of
// a trajectory in C++, projected on the active coordinates of a closed-loop tree (S2 eq. 12:
// Γ_m = [I Lᵀ] Γ_ar = Lᵀ Γ_tree with q_tree = L q_a + c), completed by the drive columns, and — optionally —
// low-pass filtered and decimated in the same pass ("parallel filtering", Gautier 1997) so that the full-rate
// observation matrix is never held in memory.
//
// Columns of one row block (active joint j, one sample):
//   [0, 10 n_tree)                    inertial, link by link in Pinocchio's order
//   10 n_tree + 4 j + {0,1,2,3}        joint-side IA_j, FV_j, FS_j, OFFSET_j:  q̈_j, q̇_j, sign(q̇_j), 1 on row j
//   10 n_tree + 4 n_a + 3 i + {0,1,2}  motor-side IA, FV, FS of motor i:  Gᵀ e_i · (G_i q̈, G_i q̇, sign(G_i q̇))
// with G (n_m × n_a) the motor-from-joint position matrix q_m = G q_a (gear ratios and coupling; cable
// routing gives G = R_m⁻¹ K). The Python side keeps the identifiable subset and names it (Khalil's order).
//
// Rows are joint-major: row j · n_out + k is active joint j at output sample k (S2 eq. 3 stacks Y the same way).
//
// The parallel filter is a symmetric (zero-phase) FIR of odd length 2h + 1; output sample k is centred on
// input sample h + k · K (K the decimation factor), so every output uses a full window — no edge transient.
// This is setup-time work (allocates); it is not a real-time call.
#pragma once

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include <Eigen/Core>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/regressor.hpp>  // bodyRegressor

#include "tendyn/rigid_body.hpp"
#include "tendyn/status.hpp"

namespace tendyn {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Number of output samples of a centred FIR of length n_taps decimated by K over n input samples.
inline Eigen::Index decimated_length(Eigen::Index n, Eigen::Index n_taps, Eigen::Index K) {
  const Eigen::Index h = (n_taps - 1) / 2;
  if (K < 1 || n_taps < 1 || n < n_taps) return 0;
  return (n - 1 - 2 * h) / K + 1;
}

/// Number of columns of the identification regressor.
inline Eigen::Index regressor_columns(const RigidBodyModel& m, Eigen::Index n_active, Eigen::Index n_motors) {
  return 10 * (m.pin.njoints - 1) + 4 * n_active + 3 * n_motors;
}

inline double sign0(double x) { return (x > 0.0) - (x < 0.0); }

/// Parallel filter + decimation of every column of X (n × k, one row per sample) by the same FIR:
/// out(k_out, :) = Σ_t taps[t] X(h + k_out K + t − h, :).
/// @param taps  symmetric FIR, odd length 2h + 1 ([1] and K = 1: a copy)
/// @param K     decimation factor ≥ 1
/// @param X     (n, k) samples × signals
/// @param out   (decimated_length(n, taps, K), k), written
inline Status fir_decimate(const Eigen::Ref<const Eigen::VectorXd>& taps, Eigen::Index K,
                           const Eigen::Ref<const RowMatrixXd>& X, Eigen::Ref<RowMatrixXd> out) {
  const Eigen::Index nt = taps.size();
  if (K < 1 || nt % 2 == 0) return Status::InvalidModel;
  const Eigen::Index no = decimated_length(X.rows(), nt, K);
  if (out.rows() != no || out.cols() != X.cols()) return Status::SizeMismatch;
  if (!all_finite(taps)) return Status::NonFiniteInput;
  out.setZero();
  for (Eigen::Index k = 0; k < no; ++k)
    for (Eigen::Index t = 0; t < nt; ++t) out.row(k) += taps[t] * X.row(k * K + t);
  return Status::Ok;
}

namespace detail {

/// Pinocchio's joint-torque regressor at (q, v, a) into data.jointTorqueRegressor (nv × 10 (njoints − 1), the
/// columns of computeJointTorqueRegressor), from the algorithms libpinocchio_default ships compiled (forward
/// kinematics, joint Jacobians: declared extern by Pinocchio's headers). computeJointTorqueRegressor itself is
/// declared inline, so every build instantiated its passes for every joint type (~40 s of compiler CPU; issue 39).
/// Body i's regressor B_i (6 × 10, its frame, at its velocity and its acceleration with gravity's,
/// a_i − ⁱX_o g) acts on joint j ≤ i of its support through the power of j's world-frame motion subspace:
/// rows of j, columns of i = S_o,jᵀ (ᵒX_i* B_i) = S_jᵀ (ʲX_i* B_i), Pinocchio's backward pass. Mimic joints are not
/// supported (as by Pinocchio's).
inline void joint_torque_regressor(const pinocchio::Model& model, pinocchio::Data& data, const Eigen::VectorXd& q,
                                   const Eigen::VectorXd& v, const Eigen::VectorXd& a) {
  pinocchio::forwardKinematics(model, data, q, v, a);
  pinocchio::computeJointJacobians(model, data);  // data.J: world-frame motion subspaces at data.oMi
  data.jointTorqueRegressor.setZero();
  Eigen::Matrix<double, 6, 10> body, world;
  for (pinocchio::JointIndex i = 1; i < static_cast<pinocchio::JointIndex>(model.njoints); ++i) {
    pinocchio::bodyRegressor(data.v[i], data.a[i] - data.oMi[i].actInv(model.gravity), body);
    world.noalias() = data.oMi[i].toDualActionMatrix() * body;
    for (pinocchio::JointIndex j = i; j > 0; j = model.parents[j])
      data.jointTorqueRegressor.block(model.idx_vs[j], 10 * static_cast<Eigen::Index>(i - 1), model.nvs[j], 10)
          .noalias() = data.J.middleCols(model.idx_vs[j], model.nvs[j]).transpose() * world;
  }
}

/// Outputs [k_begin, k_end) of identification_regressor (sizes checked by the caller, rows zeroed): the input
/// samples whose windows reach them, with `d` as workspace. Ranges of outputs are independent, so threads
/// each take one (the few input samples shared by two neighbouring ranges are computed by both).
inline void regressor_outputs(const RigidBodyModel& m, RigidBodyData& d, const Eigen::MatrixXd& L,
                              const Eigen::VectorXd& c, const Eigen::MatrixXd& G,
                              const Eigen::Ref<const RowMatrixXd>& Q, const Eigen::Ref<const RowMatrixXd>& V,
                              const Eigen::Ref<const RowMatrixXd>& A, const Eigen::Ref<const Eigen::VectorXd>& taps,
                              Eigen::Index K, Eigen::Index no, Eigen::Index k_begin, Eigen::Index k_end,
                              Eigen::Ref<RowMatrixXd> out) {
  const Eigen::Index nt = m.pin.nv, na = L.cols(), nm = G.rows(), ntaps = taps.size();
  const Eigen::Index p = regressor_columns(m, na, nm), p_in = 10 * (m.pin.njoints - 1);
  const Eigen::MatrixXd Gt = G.transpose();
  // A serial chain has L = I, c = 0: skip the projection (a dense n×n by n×10n product per sample).
  const bool serial = nt == na && L.isIdentity(0.0) && c.isZero(0.0);
  // Row j of Lᵀ Y_tree can only be nonzero from the first link supported by a tree joint r with
  // L(r, j) ≠ 0 (Pinocchio numbers descendants after their ancestors): accumulate from there on.
  Eigen::VectorXi first(na);
  for (Eigen::Index j = 0; j < na; ++j) {
    Eigen::Index r = 0;
    while (r < nt && L(r, j) == 0.0) ++r;
    first[j] = static_cast<int>(10 * r);
  }
  Eigen::VectorXd q(nt), v(nt), a(nt), qm_d(nm), qm_dd(nm);
  RowMatrixXd Ya(na, p);  // row-major: each row is added whole into the outputs
  Ya.setZero();
  const Eigen::Index s_end = (k_end - 1) * K + ntaps;  // input samples that reach an output of the range
  for (Eigen::Index s = k_begin * K; s < s_end; ++s) {
    const auto qa = Q.row(s).transpose();
    const auto va = V.row(s).transpose();
    const auto aa = A.row(s).transpose();
    if (serial) {
      q = qa; v = va; a = aa;
    } else {
      q.noalias() = L * qa + c;
      v.noalias() = L * va;
      a.noalias() = L * aa;
    }
    joint_torque_regressor(m.pin, d.pin, q, v, a);
    if (serial)
      Ya.leftCols(p_in) = d.pin.jointTorqueRegressor;
    else
      Ya.leftCols(p_in).noalias() = L.transpose() * d.pin.jointTorqueRegressor;
    for (Eigen::Index j = 0; j < na; ++j) {
      Ya(j, p_in + 4 * j + 0) = aa[j];
      Ya(j, p_in + 4 * j + 1) = va[j];
      Ya(j, p_in + 4 * j + 2) = sign0(va[j]);
      Ya(j, p_in + 4 * j + 3) = 1.0;
    }
    qm_d.noalias() = G * va;
    qm_dd.noalias() = G * aa;
    for (Eigen::Index i = 0; i < nm; ++i) {
      const Eigen::Index col = p_in + 4 * na + 3 * i;
      Ya.col(col + 0) = Gt.col(i) * qm_dd[i];
      Ya.col(col + 1) = Gt.col(i) * qm_d[i];
      Ya.col(col + 2) = Gt.col(i) * sign0(qm_d[i]);
    }
    // outputs k of the range whose window [k K, k K + ntaps) contains s
    Eigen::Index k_lo = s >= ntaps ? (s - ntaps) / K + 1 : 0;
    while (k_lo * K + ntaps <= s) ++k_lo;
    k_lo = std::max(k_lo, k_begin);
    for (Eigen::Index k = k_lo; k < k_end && k * K <= s; ++k) {
      const double w = taps[s - k * K];
      if (w == 0.0) continue;
      for (Eigen::Index j = 0; j < na; ++j) {
        auto o = out.row(j * no + k);
        const Eigen::Index f = first[j];
        o.segment(f, p_in - f).noalias() += w * Ya.row(j).segment(f, p_in - f);
        o.segment(p_in + 4 * j, 4).noalias() += w * Ya.row(j).segment(p_in + 4 * j, 4);
        o.tail(3 * nm).noalias() += w * Ya.row(j).tail(3 * nm);
      }
    }
  }
}

}  // namespace detail

/// Identification regressor over all samples, optionally filtered and decimated in the same pass.
/// @param m, d   rigid-body tree and its data (d is used as workspace)
/// @param L      (n_tree, n_a) ∂q_tree/∂q_a (identity for a serial chain)
/// @param c      (n_tree,) constant offsets of the constraints [rad or m]
/// @param G      (n_m, n_a) motor-from-joint position matrix q_m = G q_a [rad/rad]
/// @param Q, V, A  (n, n_a) active positions [rad], velocities [rad/s], accelerations [rad/s²], one row per sample
/// @param taps   symmetric FIR of odd length (the parallel filter); [1] for none
/// @param K      decimation factor ≥ 1
/// @param out    (n_a · n_out, regressor_columns), joint-major rows, written
/// @param threads  worker threads (≥ 1; 1 runs in the caller's thread with `d`, more each get their own data)
inline Status identification_regressor(const RigidBodyModel& m, RigidBodyData& d, const Eigen::MatrixXd& L,
                                       const Eigen::VectorXd& c, const Eigen::MatrixXd& G,
                                       const Eigen::Ref<const RowMatrixXd>& Q, const Eigen::Ref<const RowMatrixXd>& V,
                                       const Eigen::Ref<const RowMatrixXd>& A,
                                       const Eigen::Ref<const Eigen::VectorXd>& taps, Eigen::Index K,
                                       Eigen::Ref<RowMatrixXd> out, int threads = 1) {
  const Eigen::Index nt = m.pin.nv, na = L.cols(), nm = G.rows(), n = Q.rows();
  const Eigen::Index ntaps = taps.size();
  if (L.rows() != nt || c.size() != nt || G.cols() != na) return Status::SizeMismatch;
  if (Q.cols() != na || V.cols() != na || A.cols() != na || V.rows() != n || A.rows() != n)
    return Status::SizeMismatch;
  if (K < 1 || ntaps % 2 == 0 || threads < 1) return Status::InvalidModel;
  const Eigen::Index no = decimated_length(n, ntaps, K);
  const Eigen::Index p = regressor_columns(m, na, nm);
  if (out.rows() != na * no || out.cols() != p) return Status::SizeMismatch;
  if (!all_finite(Q) || !all_finite(V) || !all_finite(A) || !all_finite(taps)) return Status::NonFiniteInput;
  out.setZero();
  if (no == 0) return Status::Ok;
  // below a few hundred outputs per thread the start-up of a thread and its Pinocchio data costs more
  const Eigen::Index T = std::max<Eigen::Index>(1, std::min<Eigen::Index>(threads, no / 256));
  if (T == 1) {
    detail::regressor_outputs(m, d, L, c, G, Q, V, A, taps, K, no, 0, no, out);
    return Status::Ok;
  }
  std::vector<std::thread> pool;
  for (Eigen::Index t = 0; t < T; ++t) {
    const Eigen::Index k0 = no * t / T, k1 = no * (t + 1) / T;
    pool.emplace_back([&, k0, k1] {
      RigidBodyData local(m);
      detail::regressor_outputs(m, local, L, c, G, Q, V, A, taps, K, no, k0, k1, out);
    });
  }
  for (auto& th : pool) th.join();
  return Status::Ok;
}

}  // namespace tendyn

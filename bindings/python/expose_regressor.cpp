#include "common.hpp"
#include "tendyn/closed_loop.hpp"
#include "tendyn/regressor.hpp"

namespace tendyn::py {

void expose_regressor(nb::module_& m) {
  using RowRef = nb::DRef<const RowMatrixXd>;
  m.def("decimated_length", &decimated_length, nb::arg("n"), nb::arg("n_taps"), nb::arg("K"),
        "Output samples of a centred FIR of n_taps taps decimated by K over n input samples.");
  m.def("regressor_columns", &regressor_columns, nb::arg("model"), nb::arg("n_active"), nb::arg("n_motors"));
  m.def(
      "fir_decimate",
      [](const Eigen::VectorXd& taps, Eigen::Index K, RowRef X) {
        RowMatrixXd out(decimated_length(X.rows(), taps.size(), K), X.cols());
        check(fir_decimate(taps, K, X, out), "fir_decimate");
        return out;
      },
      nb::arg("taps"), nb::arg("K"), nb::arg("X"),
      "Filter every column of X (n, k) by the symmetric FIR taps and keep every K-th output, centred windows "
      "only: (decimated_length(n, len(taps), K), k).");
  m.def(
      "identification_regressor",
      [](const RigidBodyModel& mo, RigidBodyData& d, const Eigen::MatrixXd& L, const Eigen::VectorXd& c,
         const Eigen::MatrixXd& G, RowRef Q, RowRef V, RowRef A, const Eigen::VectorXd& taps, Eigen::Index K,
         int threads) {
        const Eigen::Index no = decimated_length(Q.rows(), taps.size(), K);
        RowMatrixXd out(L.cols() * no, regressor_columns(mo, L.cols(), G.rows()));
        Status s;
        {
          nb::gil_scoped_release release;
          s = identification_regressor(mo, d, L, c, G, Q, V, A, taps, K, out, threads);
        }
        check(s, "identification_regressor");   // raise with the GIL held
        return out;
      },
      nb::arg("model"), nb::arg("data"), nb::arg("L"), nb::arg("c"), nb::arg("G"), nb::arg("Q"), nb::arg("V"),
      nb::arg("A"), nb::arg("taps"), nb::arg("K"), nb::arg("threads") = 1,
      "Identification regressor of all samples (rows joint-major), filtered by taps and decimated by K, on "
      "`threads` threads (each its own Pinocchio data); see include/tendyn/regressor.hpp for the column layout.");
  m.def(
      "closed_loop_simulate",
      [](const RigidBodyModel& mo, const Eigen::MatrixXd& L, const Eigen::VectorXd& c, const Eigen::MatrixXd& G,
         RowRef X, const Eigen::VectorXd& kp, const Eigen::VectorXd& kd, const Eigen::VectorXd& ki,
         const Eigen::VectorXd& gain, bool motor, double velocity_cutoff_hz, bool velocity_feedforward,
         RowRef ref_q, RowRef ref_qd, const Eigen::VectorXd& q0, const Eigen::VectorXd& offsets, double dt,
         int substeps, int threads) {
        const TreeDynamicsModel tree(mo.pin);
        if (!tree.valid)
          throw nb::value_error("closed_loop_simulate: the tree has a joint other than one-DOF revolute/prismatic");
        LoopPID pid{kp, kd, ki, gain, motor, velocity_cutoff_hz, velocity_feedforward};
        const Eigen::Index rows = X.rows() * ref_q.rows(), na = L.cols();
        RowMatrixXd Q(rows, na), QD(rows, na), QDD(rows, na), TAU(rows, na);
        Status s;
        {
          nb::gil_scoped_release release;
          s = closed_loop_simulate(tree, L, c, G, X, pid, ref_q, ref_qd, q0, offsets, dt, substeps, Q, QD, QDD, TAU,
                                   threads);
        }
        check(s, "closed_loop_simulate");
        return nb::make_tuple(Q, QD, QDD, TAU);
      },
      nb::arg("model"), nb::arg("L"), nb::arg("c"), nb::arg("G"), nb::arg("X"), nb::arg("kp"), nb::arg("kd"),
      nb::arg("ki"), nb::arg("gain"), nb::arg("motor"), nb::arg("velocity_cutoff_hz"),
      nb::arg("velocity_feedforward"), nb::arg("ref_q"), nb::arg("ref_qd"), nb::arg("q0"), nb::arg("offsets"),
      nb::arg("dt"), nb::arg("substeps") = 1, nb::arg("threads") = 1,
      "Closed-loop simulation of the regressor's model for each row of X (regressor column order) under a PID per "
      "joint or motor: (Q, QD, QDD, TAU), each (p n, n_a), run-major; see include/tendyn/closed_loop.hpp.");
}

}  // namespace tendyn::py

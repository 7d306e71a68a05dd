#include "common.hpp"
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
}

}  // namespace tendyn::py

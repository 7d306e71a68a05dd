// Bindings of include/tendyn/tendons.hpp: N+1 tendon routings (m = n + 1 tendons on n joints).
#include <string>

#include "common.hpp"
#include "tendyn/tendons.hpp"

namespace tendyn::py {

void expose_tendons(nb::module_& m) {
  using M = TendonModel;
  using D = TendonData;
  nb::class_<M>(m, "TendonModel",
                "An N+1 tendon routing (include/tendyn/tendons.hpp), read-only once built.\n\n"
                "TendonModel(K, motor_radius, tension_min, last_joint=[], tau0=[], nu=[]): K (n + 1, n) [m] (tendon\n"
                "velocities = K qd), motor radii (m,) [m], tension floors (m,) [N]; optionally the 0-based last joint\n"
                "of each tendon and the branch losses tau0 [N], nu [N s/m] (m, n) of S0 eq. 12 (and beta [-], eq. 11).\n"
                "Raises ValueError\n"
                "naming the tendon (0-based) when K is rank deficient or has no tension closure (no h > 0, K^T h = 0).")
      .def(
          "__init__",
          [](M* self, const Eigen::MatrixXd& K, const Eigen::VectorXd& motor_radius, const Eigen::VectorXd& tension_min,
             const Eigen::VectorXi& last_joint, const Eigen::MatrixXd& tau0, const Eigen::MatrixXd& nu,
             const Eigen::MatrixXd& beta) {
            M model;
            const std::string issue =
                make_tendon_model(K, motor_radius, tension_min, model, last_joint, tau0, nu, beta);
            if (!issue.empty()) throw nb::value_error(("TendonModel: " + issue).c_str());
            new (self) M(std::move(model));
          },
          nb::arg("K"), nb::arg("motor_radius"), nb::arg("tension_min"), nb::arg("last_joint") = Eigen::VectorXi(),
          nb::arg("tau0") = Eigen::MatrixXd(), nb::arg("nu") = Eigen::MatrixXd(), nb::arg("beta") = Eigen::MatrixXd())
      .def_ro("n", &M::n)
      .def_ro("m", &M::m)
      .def_ro("K", &M::K)
      .def_ro("motor_radius", &M::motor_radius)
      .def_ro("tension_min", &M::tension_min)
      .def_ro("null_vector", &M::null_vector, "h (m,) [-]: K^T h = 0, max h = 1, h > 0")
      .def_ro("tension_from_torque", &M::tension_from_torque, "P = pinv(K^T) (m, n) [1/m]")
      .def_ro("condition", &M::condition, "sigma_max / sigma_min of K^T [-]")
      .def_ro("last_joint", &M::last_joint)
      .def_ro("tau0", &M::tau0)
      .def_ro("nu", &M::nu)
      .def_ro("beta", &M::beta, "(m, n) [-] tension-proportional loss of each branch (S0 eq. 11)")
      .def(
          "minimum_pretension",
          [](const M& mo, const Eigen::VectorXd& tau_max) {
            if (tau_max.size() != mo.n) throw nb::value_error("minimum_pretension: tau_max must have n entries");
            return tendon_minimum_pretension(mo, tau_max);
          },
          nb::arg("tau_max"),
          "Least internal tension lambda [N] (scale of h) keeping every tension >= its floor over |tau_j| <= tau_max_j.");
  nb::class_<D>(m, "TendonData")
      .def(nb::init<>())
      .def("__init__", [](D* self, const M& mo) { new (self) D(make_tendon_data(mo)); }, nb::arg("model"))
      .def_ro("tension", &D::tension)
      .def_ro("tension_end", &D::tension_end)
      .def_ro("tension_joint", &D::tension_joint)
      .def_ro("Sdot", &D::Sdot)
      .def_ro("motor_torque", &D::motor_torque)
      .def_ro("internal_tension", &D::internal_tension)
      .def_ro("iterations", &D::iterations, "Newton steps of the last feedforward (beta > 0; 0 without)");
  m.def(
      "tendon_feedforward",
      [](const M& mo, const VecRef& tau, D& d, nb::object qd) {
        if (qd.is_none()) return check(tendon_feedforward(mo, tau, d), "tendon_feedforward");
        const Eigen::VectorXd v = nb::cast<Eigen::VectorXd>(qd);
        return check(tendon_feedforward(mo, tau, v, d), "tendon_feedforward");
      },
      nb::arg("model"), nb::arg("tau"), nb::arg("data"), nb::arg("qd") = nb::none(),
      "Joint torques tau (n,) [N m] (and joint velocities qd [rad/s]: S0 eq. 12 branch losses) -> data.tension (m,)\n"
      "[N] at the motors, data.tension_joint (m, n), data.tension_end, every one >= its floor; data.motor_torque\n"
      "(m,) [N m]. No allocation in the core call.");
  m.def(
      "tendon_joint_torque",
      [](const M& mo, const VecRef& tension) {
        Eigen::VectorXd tau(mo.n);
        check(tendon_joint_torque(mo, tension, tau), "tendon_joint_torque");
        return tau;
      },
      nb::arg("model"), nb::arg("tension"), "Tensions (m,) [N] -> joint torques K^T t (n,) [N m].");
  m.def(
      "tendon_velocity",
      [](const M& mo, const VecRef& qd) {
        Eigen::VectorXd v(mo.m);
        check(tendon_velocity(mo, qd, v), "tendon_velocity");
        return v;
      },
      nb::arg("model"), nb::arg("qd"), "Joint velocities (n,) [rad/s] -> tendon velocities K qd (m,) [m/s].");
}

}  // namespace tendyn::py

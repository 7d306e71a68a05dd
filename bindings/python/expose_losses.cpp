#include "common.hpp"
#include "tendyn/losses.hpp"

namespace tendyn::py {

void expose_losses(nb::module_& m) {
  using M = TransmissionModel;
  using D = TransmissionData;
  m.def("reducer_inverse_efficiency", &reducer_inverse_efficiency, nb::arg("eta_d"),
        "S0 eq. 10: eta_i = (2 eta_d - 1) / eta_d.");
  m.def("reducer_self_locking", &reducer_self_locking, nb::arg("eta_d"));
  m.def("bearing_speed_term", &bearing_speed_term, nb::arg("h0"), nb::arg("h1"), nb::arg("n0"),
        nb::arg("speed"), "S0 eq. 8 [N m]; speed [rad/s].");
  m.def(
      "bearing_friction_torque",
      [](double static_coefficient, double dynamic_coefficient, double h0, double h1, double n0, double load,
         double speed, double applied) {
        bool stuck = false;
        const double t = bearing_friction_torque(static_coefficient, dynamic_coefficient, h0, h1, n0, load,
                                                 speed, applied, &stuck);
        return nb::make_tuple(t, stuck);
      },
      nb::arg("static_coefficient"), nb::arg("dynamic_coefficient"), nb::arg("h0"), nb::arg("h1"), nb::arg("n0"),
      nb::arg("load"), nb::arg("speed"), nb::arg("applied"),
      "S0 eq. 7: returns (opposing torque [N m], stuck). Coefficients [m] (S0 alpha, beta), load [N], "
      "speed [rad/s], applied [N m].");
  m.def("capstan_tension_out", &capstan_tension_out, nb::arg("tension_in"), nb::arg("mu"), nb::arg("wrap"));
  m.def("capstan_beta", &capstan_beta, nb::arg("mu"), nb::arg("wrap"));
  nb::class_<BranchFriction>(m, "BranchFriction")
      .def(nb::init<>())
      .def_rw("a", &BranchFriction::a)
      .def_rw("b", &BranchFriction::b);
  m.def("branch_friction", &branch_friction, nb::arg("model"), nb::arg("transmission"),
        nb::arg("branch"), nb::arg("sdot"));
  m.def("branch_tension_upstream", &branch_tension_upstream, nb::arg("x"), nb::arg("sdot"),
        nb::arg("friction"), nb::arg("nu"));
  m.def("branch_tension_downstream", &branch_tension_downstream, nb::arg("y"), nb::arg("sdot"),
        nb::arg("friction"), nb::arg("nu"));
  m.def("motor_torque_feedforward",
        [](const M& mo, D& d, VecRef tj, VecRef qd) {
          return check(motor_torque_feedforward(mo, d, tj, qd), "motor_torque_feedforward");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_joint"), nb::arg("qd"));
  m.def("joint_torque_forward",
        [](const M& mo, D& d, VecRef tm, VecRef qd) {
          return check(joint_torque_forward(mo, d, tm, qd), "joint_torque_forward");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_motor"), nb::arg("qd"));
}

}  // namespace tendyn::py

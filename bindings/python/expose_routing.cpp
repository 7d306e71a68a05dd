#include "common.hpp"
#include "tendyn/routing.hpp"

namespace tendyn::py {

void expose_routing(nb::module_& m) {
  using M = TransmissionModel;
  using D = TransmissionData;
  nb::class_<M>(m, "TransmissionModel",
                "n tendon transmissions on an n-joint chain (routing + loss parameters).")
      .def(nb::init<const Eigen::VectorXd&, const Eigen::MatrixXd&, const Eigen::VectorXd&,
                    const Eigen::VectorXd&>(),
           nb::arg("motor_radius"), nb::arg("idle"), nb::arg("driven_radius"),
           nb::arg("reducer_ratio"),
           "motor_radius [m] (n); idle [m] (n, n) signed idle radii in the strict lower part; "
           "driven_radius [m] (n); reducer_ratio [-] (n).")
      .def_ro("n", &M::n)
      .def_rw("motor_radius", &M::motor_radius)
      .def_rw("K", &M::K)
      .def_rw("driven_radius", &M::driven_radius)
      .def_rw("reducer_ratio", &M::reducer_ratio)
      .def_rw("reducer_efficiency", &M::reducer_efficiency)
      .def_rw("pretension", &M::pretension)
      .def_rw("tau0", &M::tau0)
      .def_rw("nu", &M::nu)
      .def_rw("beta", &M::beta)
      .def_rw("bearing_count", &M::bearing_count)
      .def_rw("bearing_radius", &M::bearing_radius)
      .def_rw("bearing_wrap", &M::bearing_wrap)
      .def_rw("bearing_alpha", &M::bearing_alpha)
      .def_rw("bearing_beta", &M::bearing_beta)
      .def_rw("bearing_h0", &M::bearing_h0)
      .def_rw("bearing_h1", &M::bearing_h1)
      .def_rw("bearing_n0", &M::bearing_n0)
      .def_ro("joint_from_motor_position", &M::joint_from_motor_position)
      .def_ro("motor_from_joint_position", &M::motor_from_joint_position)
      .def_ro("motor_from_joint_torque", &M::motor_from_joint_torque)
      .def_ro("joint_from_motor_torque", &M::joint_from_motor_torque)
      .def("update_matrices", &M::update_matrices)
      .def("validate", &M::validate);

  nb::class_<D>(m, "TransmissionData", "Preallocated workspace and outputs of the transmission calls.")
      .def(nb::init<const M&>(), nb::arg("model"))
      .def_ro("q", &D::q)
      .def_ro("qdot", &D::qdot)
      .def_ro("q_motor", &D::q_motor)
      .def_ro("qdot_motor", &D::qdot_motor)
      .def_ro("S", &D::S)
      .def_ro("Sdot", &D::Sdot)
      .def_ro("tension", &D::tension)
      .def_ro("tension_motor", &D::tension_motor)
      .def_ro("torque_motor", &D::torque_motor)
      .def_ro("torque_joint", &D::torque_joint)
      .def_ro("stuck", &D::stuck)
      .def_ro("self_locked", &D::self_locked);

  m.def("joint_from_motor",
        [](const M& mo, D& d, VecRef q_motor) { return check(joint_from_motor(mo, d, q_motor), "joint_from_motor"); },
        nb::arg("model"), nb::arg("data"), nb::arg("q_motor"));
  m.def("motor_from_joint",
        [](const M& mo, D& d, VecRef q) { return check(motor_from_joint(mo, d, q), "motor_from_joint"); },
        nb::arg("model"), nb::arg("data"), nb::arg("q"));
  m.def("branch_displacements", &branch_displacements, nb::arg("model"), nb::arg("data"));
  m.def("velocities_from_joint",
        [](const M& mo, D& d, VecRef qdot) { return check(velocities_from_joint(mo, d, qdot), "velocities_from_joint"); },
        nb::arg("model"), nb::arg("data"), nb::arg("qdot"));
  m.def("motor_torque_lossless",
        [](const M& mo, D& d, VecRef tj) { return check(motor_torque_lossless(mo, d, tj), "motor_torque_lossless"); },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_joint"));
  m.def("joint_torque_lossless",
        [](const M& mo, D& d, VecRef tm) { return check(joint_torque_lossless(mo, d, tm), "joint_torque_lossless"); },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_motor"));
}

}  // namespace tendyn::py

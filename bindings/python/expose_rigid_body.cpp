#include <nanobind/stl/string.h>

#include "common.hpp"
#include "tendyn/rigid_body.hpp"

namespace tendyn::py {

void expose_rigid_body(nb::module_& m) {
  using M = RigidBodyModel;
  using D = RigidBodyData;
  nb::class_<M>(m, "RigidBodyModel", "Rigid-body chain (Pinocchio model built in C++).")
      .def(nb::init<>())
      .def("set_gravity", &M::set_gravity, nb::arg("gravity"))
      .def("add_joint", &M::add_joint, nb::arg("parent"), nb::arg("placement"), nb::arg("axis"),
           nb::arg("prismatic"), nb::arg("mass"), nb::arg("com"), nb::arg("inertia"), nb::arg("name"))
      .def_prop_ro("nq", &M::nq);
  nb::class_<D>(m, "RigidBodyData")
      .def(nb::init<const M&>(), nb::arg("model"))
      .def_ro("gravity_torque", &D::gravity_torque);
  m.def("gravity_torque",
        [](const M& mo, D& d, VecRef q) { return check(gravity_torque(mo, d, q), "gravity_torque"); },
        nb::arg("model"), nb::arg("data"), nb::arg("q"));
}

}  // namespace tendyn::py

#include "common.hpp"

namespace tendyn::py {

void expose_status(nb::module_& m) {
  nb::enum_<Status>(m, "Status", "Result code of a real-time call (negative = error).")
      .value("Ok", Status::Ok)
      .value("SelfLocked", Status::SelfLocked)
      .value("NotConverged", Status::NotConverged)
      .value("NonFiniteInput", Status::NonFiniteInput)
      .value("SizeMismatch", Status::SizeMismatch)
      .value("InvalidModel", Status::InvalidModel)
      .value("Diverged", Status::Diverged);
  m.def("status_message", &status_message, nb::arg("status"));
  nb::exception<SimulationDiverged>(m, "SimulationDiverged", PyExc_ValueError);
}

}  // namespace tendyn::py

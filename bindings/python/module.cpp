// tendyn._core: a thin 1:1 mirror of the C++ real-time core (include/tendyn).
#include "common.hpp"

namespace tendyn::py {
void expose_regressor(nb::module_& m);  // expose_regressor.cpp
}

NB_MODULE(_core, m) {
  m.doc() = "tendyn real-time core (C++17, header-only) bound with nanobind";
  tendyn::py::expose_status(m);
  tendyn::py::expose_routing(m);
  tendyn::py::expose_losses(m);
  tendyn::py::expose_rigid_body(m);
  tendyn::py::expose_sim(m);
  tendyn::py::expose_tendon_bench(m);
  tendyn::py::expose_compensator(m);
  tendyn::py::expose_tendons(m);
  tendyn::py::expose_regressor(m);
}

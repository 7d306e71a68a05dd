// Shared helpers of the Python bindings: the throwing variant of the core's status codes.
#pragma once

#include <stdexcept>
#include <string>

#include <nanobind/nanobind.h>
#include <nanobind/eigen/dense.h>

#include "tendyn/status.hpp"

namespace tendyn::py {

namespace nb = nanobind;
using VecRef = Eigen::Ref<const Eigen::VectorXd>;

/// Status::Diverged as its own Python exception (tendyn._core.SimulationDiverged, a ValueError): a diverged
/// run is a computed result that failed, not bad input, and callers tell the two apart by type, not by text.
struct SimulationDiverged : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Raise SimulationDiverged or ValueError on an error status; pass flags (Ok, SelfLocked) through to Python.
inline Status check(Status s, const char* where) {
  const std::string msg = std::string(where) + ": " + status_message(s);
  if (s == Status::Diverged) throw SimulationDiverged(msg);
  if (is_error(s)) throw nb::value_error(msg.c_str());
  return s;
}

void expose_status(nb::module_& m);
void expose_routing(nb::module_& m);
void expose_losses(nb::module_& m);
void expose_rigid_body(nb::module_& m);
void expose_sim(nb::module_& m);
void expose_tendon_bench(nb::module_& m);
void expose_compensator(nb::module_& m);
void expose_tendons(nb::module_& m);

}  // namespace tendyn::py

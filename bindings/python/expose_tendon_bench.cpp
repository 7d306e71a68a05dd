// Bindings of include/tendyn/tendon_bench.hpp: the McGill 2N tendon bench (one channel).
#include <cstdint>
#include <string>

#include <nanobind/ndarray.h>

#include "common.hpp"
#include "tendyn/tendon_bench.hpp"

namespace tendyn::py {

namespace {
using Arr = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using ConstArr = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

void check_len(const Arr& a, std::size_t n, const char* name) {
  if (a.shape(0) != n)
    throw nb::value_error((std::string("tendon_bench_run: ") + name + " must have the length of u").c_str());
}
}  // namespace

void expose_tendon_bench(nb::module_& m) {
  using M = TendonBenchModel;
  using D = TendonBenchData;
  nb::class_<M>(m, "TendonBenchModel",
                "One 2N tendon channel of the McGill bench (S1), channel-equivalent values in rim units [SI].")
      .def(nb::init<>())
      .def_rw("ratio", &M::ratio, "r [-] pulley ratio (informational)")
      .def_rw("k1", &M::k1, "[N/m] proximal stiffness of the channel (each tendon k1/2)")
      .def_rw("k2", &M::k2, "[N/m] distal stiffness of the channel (each tendon k2/2)")
      .def_rw("mass_motor", &M::mass_motor, "m1 = r^2 I_M [kg] (each motor m1/2)")
      .def_rw("damping_motor", &M::damping_motor, "c1 = r^2 B [N s/m] (each motor c1/2)")
      .def_rw("mass_load", &M::mass_load, "I_c [kg]")
      .def_rw("k_z", &M::k_z, "[N/m] load spring to ground")
      .def_rw("pretension", &M::pretension, "T_pre [N] per tendon (= amplifier bias)")
      .def_rw("friction_c0", &M::friction_c0, "F_c0 [N] Coulomb friction per motor node")
      .def_rw("friction_mu_tension", &M::friction_mu_tension, "mu_T [-] friction per newton of tension")
      .def_rw("amplifier_lag", &M::amplifier_lag, "[s] first-order amplifier lag, 0 = ideal")
      .def_rw("noise_force", &M::noise_force, "[N rms] sensor noise on F_m")
      .def_rw("noise_position", &M::noise_position, "[m rms] sensor noise on X_t")
      .def_rw("dt", &M::dt, "[s] fixed step")
      .def_rw("clamp_stiffness", &M::clamp_stiffness, "[N/m] k_z at or above which the load is clamped")
      .def("k_e", &M::k_e, "k_e = k1 k2/(k1 + k2) [N/m]")
      .def("load_clamped", &M::load_clamped)
      .def("validate", &M::validate);

  nb::class_<D>(m, "TendonBenchData", "State, derived constants and outputs of one channel.")
      .def("__init__",
           [](D* self, const M& model, std::uint64_t seed) {
             check(model.validate(), "TendonBenchData");
             new (self) D(model, seed);
           },
           nb::arg("model"), nb::arg("seed") = 0)
      .def_ro("x_a", &D::x_a)
      .def_ro("v_a", &D::v_a)
      .def_ro("x_b", &D::x_b)
      .def_ro("v_b", &D::v_b)
      .def_ro("x_load", &D::x_load)
      .def_ro("v_load", &D::v_load)
      .def_ro("u_amp", &D::u_amp)
      .def_ro("time", &D::time)
      .def_ro("steps", &D::steps)
      .def_ro("tension_a", &D::tension_a)
      .def_ro("tension_b", &D::tension_b)
      .def_ro("friction_a", &D::friction_a)
      .def_ro("friction_b", &D::friction_b)
      .def_ro("stuck_a", &D::stuck_a)
      .def_ro("stuck_b", &D::stuck_b)
      .def_ro("force_true", &D::force_true)
      .def_ro("position_true", &D::position_true)
      .def_ro("force_measured", &D::force_measured)
      .def_ro("position_measured", &D::position_measured)
      .def_ro("h", &D::h)
      .def_ro("n_sub", &D::n_sub)
      .def_ro("clamped", &D::clamped);

  m.def("tendon_bench_reset",
        [](const M& mo, D& d, std::uint64_t seed) { return check(tendon_bench_reset(mo, d, seed), "tendon_bench_reset"); },
        nb::arg("model"), nb::arg("data"), nb::arg("seed") = 0);
  m.def("tendon_bench_step",
        [](const M& mo, D& d, double u) { return check(tendon_bench_step(mo, d, u), "tendon_bench_step"); },
        nb::arg("model"), nb::arg("data"), nb::arg("u"));
  m.def("tendon_bench_run",
        [](const M& mo, D& d, ConstArr u, Arr force_measured, Arr position_measured, Arr x_a, Arr x_b,
           Arr x_load, Arr tension_a, Arr tension_b) {
          const std::size_t n = u.shape(0);
          check_len(force_measured, n, "force_measured");
          check_len(position_measured, n, "position_measured");
          check_len(x_a, n, "x_a");
          check_len(x_b, n, "x_b");
          check_len(x_load, n, "x_load");
          check_len(tension_a, n, "tension_a");
          check_len(tension_b, n, "tension_b");
          Status s;
          {
            nb::gil_scoped_release release;
            s = tendon_bench_run(mo, d, u.data(), static_cast<std::int64_t>(n), force_measured.data(),
                                 position_measured.data(), x_a.data(), x_b.data(), x_load.data(),
                                 tension_a.data(), tension_b.data());
          }
          return check(s, "tendon_bench_run");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("u"), nb::arg("force_measured"),
        nb::arg("position_measured"), nb::arg("x_a"), nb::arg("x_b"), nb::arg("x_load"),
        nb::arg("tension_a"), nb::arg("tension_b"),
        "Run u (one command [N] per step) and write the end-of-step outputs into the preallocated float64 "
        "arrays (same length as u).");
}

}  // namespace tendyn::py

// Bindings of include/tendyn/tendon_bench.hpp: the McGill 2N tendon bench (one channel), and of lure.hpp: the
// Lur'e block model its identification (identify-bench) fits.
#include <cmath>
#include <cstdint>
#include <string>

#include <nanobind/ndarray.h>

#include "common.hpp"
#include "tendyn/lure.hpp"
#include "tendyn/routing.hpp"
#include "tendyn/tendon_bench.hpp"

namespace tendyn::py {

namespace {
using Arr = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using ConstArr = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

void check_len(const Arr& a, std::size_t n, const char* name) {
  if (a.shape(0) != n)
    throw nb::value_error((std::string("run: ") + name + " must have the length of u").c_str());
}

int index_of(const char* name) {
  int k = 0;
  for (const auto& f : tendon_bench_fields) {
    if (std::string(f.name) == name) return k;
    ++k;
  }
  return -1;
}

std::string bench_message(const char* name, double v) {
  const auto& f = tendon_bench_fields[index_of(name)];
  return std::string("TendonBenchModel.") + name + " = " + format_double(v) + ": must be finite and " +
         (f.bound == Bound::Positive ? "> 0" : ">= 0") + " [" + f.unit + "]";
}
}  // namespace

void expose_tendon_bench(nb::module_& m) {
  using M = TendonBenchModel;
  using D = TendonBenchData;
  auto cls = nb::class_<M>(m, "TendonBenchModel",
                "One 2N tendon channel of the McGill bench (S1), channel-equivalent values in rim units [SI].\n"
                "Every write re-validates: a non-finite or out-of-range value raises ValueError naming the field.")
      .def(nb::init<>());
#define TENDYN_BIND_BENCH(name, def, unit, bnd, doc)                                                  \
  cls.def_prop_rw(                                                                                      \
      #name, [](const M& mo) { return mo.name; },                                                       \
      [](M& mo, double v) {                                                                             \
        const auto& f = tendon_bench_fields[index_of(#name)];                                           \
        if (!(std::isfinite(v) && (f.bound == Bound::Positive ? v > 0.0 : v >= 0.0)))                   \
          throw nb::value_error(bench_message(#name, v).c_str());                                       \
        mo.name = v;                                                                                    \
      },                                                                                                \
      "[" unit "] " doc);
  TENDYN_TENDON_BENCH_FIELDS(TENDYN_BIND_BENCH)
#undef TENDYN_BIND_BENCH
  cls.def("k_e", &M::k_e, "k_e = k1 k2/(k1 + k2) [N/m]")
      .def("load_clamped", &M::load_clamped)
      .def("validate", &M::validate)
      .def_static(
          "fields",
          []() {
            nb::list out;
            for (const auto& f : tendon_bench_fields)
              out.append(nb::make_tuple(f.name, f.default_value, f.unit,
                                        f.bound == Bound::Positive ? "> 0" : ">= 0", f.doc));
            return out;
          },
          "The parameter table: (name, default, unit, bound, doc) per field, in order.");

  nb::class_<D>(m, "TendonBenchData", "State, derived constants and outputs of one channel.")
      .def("__init__",
           [](D* self, const M& model, std::uint64_t seed) {
             if (const BenchFieldInfo* bad = model.first_issue())
               throw nb::value_error((std::string("TendonBenchData: invalid model: TendonBenchModel.") + bad->name +
                                      (bad->bound == Bound::Positive ? " must be finite and > 0" : " must be finite and >= 0"))
                                         .c_str());
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

  m.def("reset",
        [](const M& mo, D& d, std::uint64_t seed) { return check(reset(mo, d, seed), "reset"); },
        nb::arg("model"), nb::arg("data"), nb::arg("seed") = 0);
  m.def("step",
        [](const M& mo, D& d, double u) { return check(step(mo, d, u), "step"); },
        nb::arg("model"), nb::arg("data"), nb::arg("u"));
  m.def("run",
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
            s = run(mo, d, u.data(), static_cast<std::int64_t>(n), force_measured.data(),
                                 position_measured.data(), x_a.data(), x_b.data(), x_load.data(),
                                 tension_a.data(), tension_b.data());
          }
          return check(s, "run");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("u"), nb::arg("force_measured"),
        nb::arg("position_measured"), nb::arg("x_a"), nb::arg("x_b"), nb::arg("x_load"),
        nb::arg("tension_a"), nb::arg("tension_b"),
        "Run u (one command [N] per step) and write the end-of-step outputs into the preallocated float64 "
        "arrays (same length as u).");

  // ---- controller in the loop (mirrors BenchControllerModel / BenchControllerData / run_closed_loop) ----
  using CM = BenchControllerModel;
  using CD = BenchControllerData;
  using Mat = nb::ndarray<const double, nb::ndim<2>, nb::device::cpu>;
  nb::class_<CM>(m, "BenchControllerModel",
                 "A discrete-time LTI controller C(z), x+ = A x + B e, u = C x + D e, e = r - F_m (sensed),\n"
                 "run every `decimation` bench steps (zero-order hold), |u| <= u_limit [N]. Order <= max_order.")
      .def(nb::init<>())
      .def_ro_static("max_order", &CM::max_order)
      .def_prop_ro("order", [](const CM& c) { return c.order; })
      .def_prop_rw("D", [](const CM& c) { return c.D; },
                   [](CM& c, double v) {
                     if (!std::isfinite(v)) throw nb::value_error("BenchControllerModel.D must be finite");
                     c.D = v;
                   }, "[-] feed-through")
      .def_prop_rw("decimation", [](const CM& c) { return c.decimation; },
                   [](CM& c, int v) {
                     if (v < 1) throw nb::value_error("BenchControllerModel.decimation must be >= 1");
                     c.decimation = v;
                   }, "bench steps per control period")
      .def_prop_rw("u_limit", [](const CM& c) { return c.u_limit; },
                   [](CM& c, double v) {
                     if (!(v > 0.0)) throw nb::value_error("BenchControllerModel.u_limit must be > 0 [N]");
                     c.u_limit = v;
                   }, "[N] command limit (inf = none)")
      .def("set_state_space",
           [](CM& c, Mat A, nb::ndarray<const double, nb::ndim<1>, nb::device::cpu> B,
              nb::ndarray<const double, nb::ndim<1>, nb::device::cpu> C, double D) {
             const std::size_t n = B.shape(0);
             if (n > static_cast<std::size_t>(CM::max_order))
               throw nb::value_error(("BenchControllerModel: order " + std::to_string(n) + " > max_order " +
                                      std::to_string(CM::max_order)).c_str());
             if (A.shape(0) != n || A.shape(1) != n || C.shape(0) != n)
               throw nb::value_error("BenchControllerModel.set_state_space: A must be n x n, B and C of length n");
             CM t = c;
             t.order = static_cast<int>(n);
             t.D = D;
             for (std::size_t i = 0; i < n; ++i) {
               t.B[i] = B(i);
               t.C[i] = C(i);
               for (std::size_t j = 0; j < n; ++j) t.A[i * CM::max_order + j] = A(i, j);
             }
             if (is_error(t.validate()))
               throw nb::value_error("BenchControllerModel.set_state_space: entries must be finite");
             c = t;
           },
           nb::arg("A"), nb::arg("B"), nb::arg("C"), nb::arg("D"),
           "Set the realisation (A n x n, B n, C n, D scalar); n = 0 for a pure gain.")
      .def("state_space",
           [](const CM& c) {
             nb::list A;
             for (int i = 0; i < c.order; ++i) {
               nb::list row;
               for (int j = 0; j < c.order; ++j) row.append(c.A[i * CM::max_order + j]);
               A.append(row);
             }
             nb::list B, C;
             for (int i = 0; i < c.order; ++i) {
               B.append(c.B[i]);
               C.append(c.C[i]);
             }
             return nb::make_tuple(A, B, C, c.D);
           },
           "(A, B, C, D) as nested lists.")
      .def("validate", &CM::validate);

  nb::class_<CD>(m, "BenchControllerData", "State of a BenchControllerModel (controller state, held command).")
      .def(nb::init<const CM&>(), nb::arg("model"))
      .def_prop_ro("x", [](const CD& cd) {
        nb::list out;
        for (int i = 0; i < CM::max_order; ++i) out.append(cd.x[i]);
        return out;
      })
      .def_ro("u", &CD::u)
      .def_ro("error", &CD::error)
      .def_ro("phase", &CD::phase)
      .def_ro("saturated", &CD::saturated);

  m.def("reset",
        [](const CM& c, CD& cd) { return check(reset(c, cd), "reset"); }, nb::arg("controller"),
        nb::arg("controller_data"));
  m.def("controller_update",
        [](const CM& c, CD& cd, double e) { return check(controller_update(c, cd, e), "controller_update"); },
        nb::arg("controller"), nb::arg("controller_data"), nb::arg("error"));
  m.def("step_closed_loop",
        [](const M& mo, D& d, const CM& c, CD& cd, double r) {
          return check(step_closed_loop(mo, d, c, cd, r), "step_closed_loop");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("controller"), nb::arg("controller_data"), nb::arg("reference"));
  m.def("run_closed_loop",
        [](const M& mo, D& d, const CM& c, CD& cd, ConstArr r, Arr force_measured, Arr u_cmd, Arr force_true) {
          const std::size_t n = r.shape(0);
          check_len(force_measured, n, "force_measured");
          check_len(u_cmd, n, "u_cmd");
          check_len(force_true, n, "force_true");
          Status s;
          {
            nb::gil_scoped_release release;
            s = run_closed_loop(mo, d, c, cd, r.data(), static_cast<std::int64_t>(n), force_measured.data(),
                                u_cmd.data(), force_true.data());
          }
          return check(s, "run_closed_loop");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("controller"), nb::arg("controller_data"), nb::arg("reference"),
        nb::arg("force_measured"), nb::arg("u_cmd"), nb::arg("force_true"),
        "Run the reference r [N] (one value per bench step) in closed loop; write F_m (sensed), the command u and "
        "the true F_m into the preallocated float64 arrays (length of r).");
  m.def(
      "lure_simulate",
      [](ConstArr b, ConstArr a, double level, ConstArr u, double per_output, double sign, Arr y) {
        if (b.shape(0) != a.shape(0) || a.shape(0) < 1)
          throw nb::value_error("lure_simulate: b and a need the same length n >= 1 (b_1..b_n, a_1..a_n)");
        if (y.shape(0) != u.shape(0)) throw nb::value_error("lure_simulate: y must have the length of u");
        Status s;
        {
          nb::gil_scoped_release release;
          s = lure_simulate(b.data(), a.data(), static_cast<int>(a.shape(0)), level, u.data(),
                            static_cast<long>(u.shape(0)), per_output, sign, y.data());
        }
        check(s, "lure_simulate");
      },
      nb::arg("b"), nb::arg("a"), nb::arg("level"), nb::arg("u"), nb::arg("per_output"), nb::arg("sign"),
      nb::arg("y").noconvert(),
      "y of the Lur'e model from rest for the input u (include/tendyn/lure.hpp), written into the preallocated "
      "float64 array y (length of u): b = b_1..b_n, a = a_1..a_n, level F [u unit], per_output mu, sign (1, -1 "
      "or 0: |y|).");
}

}  // namespace tendyn::py

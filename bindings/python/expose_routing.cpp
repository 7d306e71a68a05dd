#include <string>
#include <vector>

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "common.hpp"
#include "tendyn/model_file.hpp"
#include "tendyn/routing.hpp"

namespace tendyn::py {

namespace {
/// A read-only numpy view of an Eigen member of a model owned by `owner` (no copy; writes raise).
template <class Mat>
nb::object read_only_view(const Mat& a, nb::handle owner) {
  const std::size_t shape[2] = {static_cast<std::size_t>(a.rows()), static_cast<std::size_t>(a.cols())};
  const int64_t strides[2] = {1, static_cast<int64_t>(a.rows())};  // Eigen is column-major
  const std::size_t ndim = Mat::ColsAtCompileTime == 1 ? 1 : 2;
  return nb::cast(nb::ndarray<nb::numpy, const typename Mat::Scalar>(a.data(), ndim, shape, owner, strides));
}
}  // namespace

void expose_routing(nb::module_& m) {
  using M = TransmissionModel;
  using D = TransmissionData;
  using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  auto cls = nb::class_<M>(m, "TransmissionModel",
                "n tendon transmissions on an n-joint chain (routing + loss parameters), read-only once built.\n\n"
                "Build it from a dict of arrays named as the core fields (TransmissionModel.fields()):\n"
                "motor_radius, K, driven_radius, reducer_ratio are required, the rest default to lossless.\n"
                "The model is validated once; an invalid one raises ValueError naming field and 0-based index,\n"
                "e.g. 'beta[2,1] = 1.5: must be < 1'. Fields are read-only numpy views; to change a value,\n"
                "build a new model.");
  cls.def(
         "__init__",
         [](M* self, nb::dict arrays) {
           if (!arrays.contains("motor_radius"))
             throw nb::value_error("TransmissionModel: missing required field 'motor_radius'");
           const Eigen::VectorXd r_m = nb::cast<Eigen::VectorXd>(arrays["motor_radius"]);
           M model(static_cast<int>(r_m.size()));
           for (auto [key, value] : arrays) {
             const std::string name = nb::cast<std::string>(key);
             const FieldInfo* info = nullptr;
             for (const auto& f : transmission_fields)
               if (name == f.name) info = &f;
             if (!info) {
               std::string known;
               for (const auto& f : transmission_fields) known += std::string(known.empty() ? "" : ", ") + f.name;
               throw nb::value_error(("TransmissionModel: unknown field '" + name + "' (known: " + known + ")").c_str());
             }
             RowMatrixXd a;
             if (info->dims == 1) {
               const Eigen::VectorXd v = nb::cast<Eigen::VectorXd>(value);
               a = v;
             } else {
               a = nb::cast<RowMatrixXd>(value);
             }
             const int cols = info->dims == 1 ? 1 : model.n;
             if (a.rows() != model.n || a.cols() != cols)
               throw nb::value_error(("TransmissionModel: " + name + " has shape (" + std::to_string(a.rows()) +
                                      (info->dims == 1 ? "" : ", " + std::to_string(a.cols())) + "), expected (" +
                                      std::to_string(model.n) + (info->dims == 1 ? ",)" : ", " + std::to_string(model.n) + ")"))
                                         .c_str());
             model.set_field(info->name, a.data(), static_cast<int>(a.rows()), static_cast<int>(a.cols()));
           }
           for (const char* req : {"K", "driven_radius"})
             if (!arrays.contains(req))
               throw nb::value_error((std::string("TransmissionModel: missing required field '") + req + "'").c_str());
           model.update_matrices();  // the structure (blocks, dependent transmission) is part of the validation
           ValidationIssue issue;
           if (model.first_issue(&issue))
             throw nb::value_error(("invalid transmission model: " + describe(issue) +
                                    " (indices 0-based: [transmission] or [transmission, joint/branch])").c_str());
           new (self) M(std::move(model));
         },
         nb::arg("arrays"))
      .def_ro("n", &M::n);
#define TENDYN_BIND_FIELD(name, dims, unit, doc)                                                        \
  cls.def_prop_rw(                                                                                      \
      #name, [](nb::handle_t<M> self) { return read_only_view(nb::inst_ptr<M>(self)->name, self); },   \
      [](M&, nb::handle) {                                                                              \
        throw nb::attribute_error("TransmissionModel." #name " is read-only (the model was validated "   \
                                  "when built): build a new one, e.g. Transmission.from_arrays(..., " #name "=...)"); \
      },                                                                                                \
      "[" unit "] " doc " (read-only)");
  TENDYN_TRANSMISSION_FIELDS(TENDYN_BIND_FIELD)
#undef TENDYN_BIND_FIELD
#define TENDYN_BIND_MATRIX(name) \
  cls.def_prop_ro(#name, [](nb::handle_t<M> self) { return read_only_view(nb::inst_ptr<M>(self)->name, self); });
  TENDYN_BIND_MATRIX(joint_from_motor_position)
  TENDYN_BIND_MATRIX(motor_from_joint_position)
  TENDYN_BIND_MATRIX(motor_from_joint_torque)
  TENDYN_BIND_MATRIX(joint_from_motor_torque)
  TENDYN_BIND_MATRIX(last_joint)
  TENDYN_BIND_MATRIX(block_begin)
  TENDYN_BIND_MATRIX(block_end)
#undef TENDYN_BIND_MATRIX
  cls.def_ro("serial", &M::serial, "K lower-triangular with a positive diagonal (S0's recursion applies)")
      .def_ro("dependent_transmission", &M::dependent_transmission,
              "first transmission (0-based) whose row of K depends on the earlier ones (singular K), or -1");
  cls
      .def("validate", &M::validate)
      .def_static(
          "fields",
          []() {
            nb::list out;
            for (const auto& f : transmission_fields) out.append(nb::make_tuple(f.name, f.dims, f.unit, f.doc));
            return out;
          },
          "The parameter table: (name, dims, unit, doc) per field, in order (dims 1: (n), 2: (n, n)).");
  m.def(
      "routing_structure",
      [](const RowMatrixXd& K) {
        if (K.rows() != K.cols() || K.rows() == 0) throw nb::value_error("routing_structure: K must be square (n, n)");
        M mo(static_cast<int>(K.rows()));
        mo.set_field("K", K.data(), static_cast<int>(K.rows()), static_cast<int>(K.cols()));
        mo.motor_radius.setOnes();
        mo.update_matrices();
        nb::dict out;
        out["last_joint"] = nb::cast(std::vector<int>(mo.last_joint.data(), mo.last_joint.data() + mo.n));
        out["block_begin"] = nb::cast(std::vector<int>(mo.block_begin.data(), mo.block_begin.data() + mo.n));
        out["block_end"] = nb::cast(std::vector<int>(mo.block_end.data(), mo.block_end.data() + mo.n));
        out["serial"] = mo.serial;
        out["dependent_transmission"] = mo.dependent_transmission;
        return out;
      },
      nb::arg("K"),
      "The structure of a routing K (n, n) [m] as TransmissionModel.update_matrices() finds it, without validating "
      "anything else: last_joint, block_begin, block_end (lists, 0-based), serial, dependent_transmission (-1: K "
      "invertible).");
  m.def(
      "validate_report",
      [](const M& mo) {
        nb::list out;
        for (const auto& is : validate_report(mo)) out.append(describe(is));
        return out;
      },
      nb::arg("model"), "Every problem of the model as text ('beta[2,1] = 1.5: must be < 1', 0-based); [] if valid.");
  m.def(
      "save_transmission_model",
      [](const M& mo, const std::string& path) {
        std::string error;
        if (!save_transmission_model(mo, path, &error)) throw nb::value_error(error.c_str());
      },
      nb::arg("model"), nb::arg("path"), "Write the model file (include/tendyn/model_file.hpp) atomically.");
  m.def(
      "load_transmission_model",
      [](const std::string& path) {
        M mo;
        std::string error;
        if (!load_transmission_model(path, &mo, &error)) throw nb::value_error(error.c_str());
        return mo;
      },
      nb::arg("path"), "Read and validate a model file; ValueError names the file, line and field.");
  m.def("transmission_model_text", &transmission_model_text, nb::arg("model"));

  nb::class_<D>(m, "TransmissionData", "Preallocated workspace and outputs of the transmission calls.")
      .def(nb::init<const M&>(), nb::arg("model"))
      .def_ro("q", &D::q)
      .def_ro("qd", &D::qd)
      .def_ro("q_motor", &D::q_motor)
      .def_ro("qd_motor", &D::qd_motor)
      .def_ro("S", &D::S)
      .def_ro("Sdot", &D::Sdot)
      .def_ro("tension", &D::tension)
      .def_ro("tension_motor", &D::tension_motor)
      .def_ro("block_iterations", &D::block_iterations)
      .def_ro("pair_fallbacks", &D::pair_fallbacks)
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
        [](const M& mo, D& d, VecRef qd) { return check(velocities_from_joint(mo, d, qd), "velocities_from_joint"); },
        nb::arg("model"), nb::arg("data"), nb::arg("qd"));
  m.def("motor_torque_lossless",
        [](const M& mo, D& d, VecRef tj) { return check(motor_torque_lossless(mo, d, tj), "motor_torque_lossless"); },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_joint"));
  m.def("joint_torque_lossless",
        [](const M& mo, D& d, VecRef tm) { return check(joint_torque_lossless(mo, d, tm), "joint_torque_lossless"); },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_motor"));
}

}  // namespace tendyn::py

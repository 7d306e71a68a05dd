// Bindings of chain.hpp, compensator.hpp, compensator_file.hpp and render.hpp (same names as C++).
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "common.hpp"
#include "tendyn/compensator_file.hpp"
#include "tendyn/render.hpp"

namespace tendyn::py {

void expose_compensator(nb::module_& m) {
  using C = ChainModel;
  using CD = ChainData;
  nb::class_<C>(m, "ChainModel", "Kinematics and gravity of the chain a compensator serves (chain.hpp).")
      .def(nb::init<>())
      .def(nb::init<int>(), nb::arg("n"))
      .def_ro("n", &C::n)
      .def_rw("gravity", &C::gravity)
      .def_rw("parent", &C::parent)
      .def_rw("rotation", &C::rotation)
      .def_rw("translation", &C::translation)
      .def_rw("axis", &C::axis)
      .def_rw("prismatic", &C::prismatic)
      .def_rw("mass", &C::mass)
      .def_rw("com", &C::com)
      .def_rw("ee_joint", &C::ee_joint)
      .def_rw("ee_point", &C::ee_point)
      .def_rw("active_map", &C::active_map)
      .def_rw("active_offset", &C::active_offset)
      .def("n_active", &C::n_active)
      .def("first_issue", [](const C& c) {
        int j = -1;
        const char* what = c.first_issue(&j);
        return std::string(what ? what : "") + (what && j >= 0 ? " (joint " + std::to_string(j) + ")" : "");
      });
  nb::class_<CD>(m, "ChainData")
      .def(nb::init<const C&>(), nb::arg("model"))
      .def_ro("gravity_torque", &CD::gravity_torque)
      .def_ro("ee_position", &CD::ee_position)
      .def_ro("ee_jacobian", &CD::ee_jacobian)
      .def_ro("subtree_mass", &CD::subtree_mass)
      .def_ro("q_tree", &CD::q_tree)
      .def_ro("gravity_active", &CD::gravity_active)
      .def_ro("ee_jacobian_active", &CD::ee_jacobian_active);
  auto need_valid = [](const C& c) {
    if (c.validate() != Status::Ok) throw nb::value_error(("ChainModel: " + std::string(c.first_issue(nullptr))).c_str());
  };
  m.def("chain_forward_kinematics",
        [need_valid](const C& c, CD& d, VecRef q) { need_valid(c); return check(chain_forward_kinematics(c, d, q), "chain_forward_kinematics"); },
        nb::arg("model"), nb::arg("data"), nb::arg("q"));
  m.def("chain_gravity_torque",
        [need_valid](const C& c, CD& d, VecRef q) { need_valid(c); return check(chain_gravity_torque(c, d, q), "chain_gravity_torque"); },
        nb::arg("model"), nb::arg("data"), nb::arg("q"));
  m.def("chain_active",
        [need_valid](const C& c, CD& d, VecRef q_active, bool jacobian) {
          need_valid(c);
          return check(chain_active(c, d, q_active, jacobian), "chain_active");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("q_active"), nb::arg("jacobian") = true);

  using PM = PassivityModel;
  using PD = PassivityData;
  nb::class_<PM>(m, "PassivityModel",
                 "Passivity observer + controller at the motor ports (passivity.hpp), all motor side.")
      .def(nb::init<>())
      .def_rw("enabled", &PM::enabled)
      .def_rw("dissipation_coulomb", &PM::dissipation_coulomb)
      .def_rw("dissipation_viscous", &PM::dissipation_viscous)
      .def_rw("reserve", &PM::reserve)
      .def_rw("damping_max", &PM::damping_max)
      .def("first_issue", &PM::first_issue, nb::arg("n"));
  nb::class_<PD>(m, "PassivityData")
      .def(nb::init<int>(), nb::arg("n") = 0)
      .def("reset", &PD::reset)
      .def_ro("energy", &PD::energy)
      .def_ro("damping", &PD::damping)
      .def_ro("torque", &PD::torque)
      .def_ro("torque_added_prev", &PD::torque_added_prev)
      .def_ro("energy_injected", &PD::energy_injected)
      .def_ro("energy_budget", &PD::energy_budget);

  using TM = FrictionTrackingModel;
  using TD = FrictionTrackingData;
  nb::class_<TM>(m, "FrictionTrackingModel", "Online friction tracking settings (friction_tracking.hpp).")
      .def(nb::init<>())
      .def_rw("enabled", &TM::enabled)
      .def_rw("forgetting", &TM::forgetting)
      .def_rw("velocity_min", &TM::velocity_min)
      .def_rw("acceleration_max", &TM::acceleration_max)
      .def_rw("scale_min", &TM::scale_min)
      .def_rw("scale_max", &TM::scale_max)
      .def_rw("covariance_max", &TM::covariance_max)
      .def("first_issue", &TM::first_issue);
  nb::class_<TD>(m, "FrictionTrackingData")
      .def_ro("scale_constant", &TD::scale_constant)
      .def_ro("scale_viscous", &TD::scale_viscous)
      .def_ro("covariance", &TD::covariance)
      .def_ro("friction_constant", &TD::friction_constant)
      .def_ro("friction_viscous", &TD::friction_viscous)
      .def_ro("friction_load", &TD::friction_load)
      .def_ro("acceleration", &TD::acceleration)
      .def_ro("residual", &TD::residual)
      .def_ro("updates", &TD::updates);

  using M = CompensatorModel;
  using D = CompensatorData;
  nb::class_<M>(m, "CompensatorModel", "Real-time compensator model (compensator.hpp); validate() before use.")
      .def(nb::init<>())
      .def_rw("transmission", &M::transmission)
      .def_rw("chain", &M::chain)
      .def_rw("underestimation", &M::underestimation)
      .def_rw("velocity_band", &M::velocity_band)
      .def_rw("velocity_cutoff_hz", &M::velocity_cutoff_hz)
      .def_rw("rate_hz", &M::rate_hz)
      .def_rw("passivity", &M::passivity)
      .def_rw("tracking", &M::tracking)
      .def_rw("device", &M::device)
      .def_prop_rw(
          "loss_source",
          [](const M& mo) {
            std::vector<std::string> out;
            for (auto s : mo.loss_source) out.push_back(loss_source_names[static_cast<int>(s)]);
            return out;
          },
          [](M& mo, const std::vector<std::string>& names) {
            if (static_cast<int>(names.size()) != loss_term_count)
              throw nb::value_error("loss_source: 5 names expected (tau0, nu, beta, bearings, reducer_efficiency)");
            for (int k = 0; k < loss_term_count; ++k) {
              int src = -1;
              for (int j = 0; j < 3; ++j)
                if (names[k] == loss_source_names[j]) src = j;
              if (src < 0)
                throw nb::value_error(("loss_source[" + std::string(loss_terms[k]) + "]: '" + names[k] +
                                       "' is not device, identified or none").c_str());
              mo.loss_source[k] = static_cast<LossSource>(src);
            }
          },
          "source of each loss term (tau0, nu, beta, bearings, reducer_efficiency): device, identified or none")
      .def_rw("friction_source", &M::friction_source)
      .def("first_issue", &M::first_issue)
      .def("period", &M::period)
      .def("filter_gain", &M::filter_gain);
  nb::class_<D>(m, "CompensatorData", "State and outputs of the compensator.")
      .def("__init__",
           [](D* self, const M& mo) {
             const std::string problem = mo.first_issue();
             if (!problem.empty()) throw nb::value_error(("CompensatorModel: " + problem).c_str());
             new (self) D(mo);
           },
           nb::arg("model"))
      .def("reset", &D::reset)
      .def("restart", &D::restart)
      .def_ro("q_motor", &D::q_motor)
      .def_ro("qd_motor", &D::qd_motor)
      .def_ro("motor_step", &D::motor_step)
      .def_ro("passivity", &D::passivity)
      .def_ro("tracking", &D::tracking)
      .def_rw("tracking_active", &D::tracking_active)
      .def_ro("q", &D::q)
      .def_ro("qd", &D::qd)
      .def_ro("torque_joint_wanted", &D::torque_joint_wanted)
      .def_ro("torque_joint", &D::torque_joint)
      .def_ro("torque_motor_lossless", &D::torque_motor_lossless)
      .def_ro("torque_motor_friction", &D::torque_motor_friction)
      .def_ro("friction_weight", &D::friction_weight)
      .def_ro("torque_motor", &D::torque_motor)
      .def_ro("cycles", &D::cycles)
      .def_ro("compute_time", &D::compute_time)
      .def_prop_ro("gravity_torque", [](const D& d) { return Eigen::VectorXd(d.chain.gravity_active); })
      .def_prop_ro("ee_position", [](const D& d) { return Eigen::Vector3d(d.chain.ee_position); })
      .def_prop_ro("ee_jacobian", [](const D& d) { return Eigen::MatrixXd(d.chain.ee_jacobian_active); });
  m.def("compensator_cycle",
        [](const M& mo, D& d, VecRef qm, VecRef tj) {
          if (qm.size() != d.q_motor.size()) throw nb::value_error("compensator_cycle: data is not from this model");
          return check(compensator_cycle(mo, d, qm, tj), "compensator_cycle");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("q_motor"), nb::arg("torque_joint"));
  m.def("compensator_cycle_force",
        [](const M& mo, D& d, VecRef qm, VecRef f) {
          return check(compensator_cycle_force(mo, d, qm, f), "compensator_cycle_force");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("q_motor"), nb::arg("force_ee"));
  m.def("compensator_sense",
        [](const M& mo, D& d, VecRef qm) { return check(compensator_sense(mo, d, qm), "compensator_sense"); },
        nb::arg("model"), nb::arg("data"), nb::arg("q_motor"));
  m.def("compensator_command",
        [](const M& mo, D& d, VecRef tj) { return check(compensator_command(mo, d, tj), "compensator_command"); },
        nb::arg("model"), nb::arg("data"), nb::arg("torque_joint"));
  m.def("compensator_model_text", &compensator_model_text, nb::arg("model"));
  m.def(
      "save_compensator_model",
      [](const M& mo, const std::string& path) {
        std::string error;
        if (!save_compensator_model(mo, path, &error)) throw nb::value_error(error.c_str());
      },
      nb::arg("model"), nb::arg("path"), "Write the compensator model file (compensator_file.hpp) atomically.");
  m.def(
      "parse_compensator_model",
      [](const std::string& text, const std::string& name, const std::string& expected_device) {
        M mo;
        std::string error;
        if (!parse_compensator_model(text, name, expected_device, &mo, &error)) throw nb::value_error(error.c_str());
        return mo;
      },
      nb::arg("text"), nb::arg("name") = "compensator", nb::arg("expected_device") = "",
      "Parse a compensator model file's text (ValueError names the name, line and field).");
  m.def(
      "load_compensator_model",
      [](const std::string& path, const std::string& expected_device) {
        M mo;
        std::string error;
        if (!load_compensator_model(path, expected_device, &mo, &error)) throw nb::value_error(error.c_str());
        return mo;
      },
      nb::arg("path"), nb::arg("expected_device") = "",
      "Read a compensator model file; ValueError names the file, line and field.");

  using R = RenderModel;
  using RD = RenderData;
  nb::class_<R>(m, "RenderModel", "Haptic scene and gains of S0 eq. (23) (render.hpp).")
      .def(nb::init<>())
      .def_ro("n_planes", &R::n_planes)
      .def("add_plane", &R::add_plane, nb::arg("normal"), nb::arg("offset"))
      .def_rw("sphere", &R::sphere)
      .def_rw("sphere_center", &R::sphere_center)
      .def_rw("sphere_radius", &R::sphere_radius)
      .def_rw("stiffness", &R::stiffness)
      .def_rw("damping", &R::damping)
      .def_rw("surface_friction", &R::surface_friction)
      .def_rw("texture_amplitude", &R::texture_amplitude)
      .def_rw("texture_period", &R::texture_period)
      .def_rw("texture_direction", &R::texture_direction)
      .def_rw("substeps", &R::substeps);
  nb::class_<RD>(m, "RenderData")
      .def(nb::init<>())
      .def("reset", &RD::reset)
      .def_ro("x_hat", &RD::x_hat)
      .def_ro("xd_hat", &RD::xd_hat)
      .def_ro("x_god", &RD::x_god)
      .def_ro("normal", &RD::normal)
      .def_ro("force", &RD::force)
      .def_ro("force_friction", &RD::force_friction)
      .def_ro("force_texture", &RD::force_texture)
      .def_ro("in_contact", &RD::in_contact)
      .def_ro("compute_time", &RD::compute_time);
  m.def("render_cycle",
        [](const R& r, RD& d, const M& mo, D& cd, VecRef qm) {
          if (r.validate() != Status::Ok) throw nb::value_error("render_cycle: invalid RenderModel");
          return check(render_cycle(r, d, mo, cd, qm), "render_cycle");
        },
        nb::arg("render"), nb::arg("render_data"), nb::arg("model"), nb::arg("data"), nb::arg("q_motor"));
}

}  // namespace tendyn::py

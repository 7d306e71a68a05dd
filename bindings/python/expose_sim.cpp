#include <algorithm>
#include <vector>

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include "common.hpp"
#include "tendyn/sim.hpp"
#include "tendyn/sim_batch.hpp"

namespace tendyn::py {

void expose_sim(nb::module_& m) {
  using M = SimModel;
  using D = SimData;
  using RowMat = RowMatrixXd;
  using MatRef = Eigen::Ref<const RowMat>;
  using OutVec = Eigen::Ref<Eigen::VectorXd>;
  using OutMat = Eigen::Ref<RowMat>;

  nb::enum_<DriveKind>(m, "DriveKind")
      .value("Tendon", DriveKind::Tendon)
      .value("Elastic", DriveKind::Elastic)
      .value("Tendons", DriveKind::Tendons);
  nb::enum_<ControlMode>(m, "ControlMode")
      .value("Torque", ControlMode::Torque)
      .value("JointPID", ControlMode::JointPID)
      .value("MotorPID", ControlMode::MotorPID);
  nb::enum_<SiteKind>(m, "SiteKind")
      .value("Branch", SiteKind::Branch)
      .value("Reducer", SiteKind::Reducer)
      .value("MotorCoulomb", SiteKind::MotorCoulomb)
      .value("JointCoulomb", SiteKind::JointCoulomb)
      .value("Lock", SiteKind::Lock);

  nb::class_<M>(m, "SimModel", "Fixed-step simulator model (fill the fields, then finalize()).")
      .def(nb::init<>())
      .def_rw("body", &M::body)
      .def_rw("L", &M::L)
      .def_rw("c", &M::c)
      .def_ro("na", &M::na)
      .def_rw("drive", &M::drive)
      .def_rw("tendon", &M::tendon)
      .def_rw("tendons", &M::tendons)
      .def_rw("tendon_loss_compensation", &M::tendon_loss_compensation)
      .def_ro("nm", &M::nm)
      .def_ro("M_rotor", &M::M_rotor, "(nv, nv) constant mass the rotors add")
      .def_ro("Gm", &M::Gm, "(nm, na) motor velocities from joint velocities (slaved motors)")
      .def_prop_ro("n_ref", &M::n_ref)
      .def_prop_ro("n_ff", &M::n_ff)
      .def_rw("ratio", &M::ratio)
      .def_rw("stiffness_motor", &M::stiffness_motor)
      .def_rw("damping_motor", &M::damping_motor)
      .def_rw("rotor_inertia", &M::rotor_inertia)
      .def_rw("torque_constant", &M::torque_constant)
      .def_rw("peak_torque", &M::peak_torque)
      .def_rw("coulomb_motor", &M::coulomb_motor)
      .def_rw("viscous_motor", &M::viscous_motor)
      .def_rw("coulomb_joint", &M::coulomb_joint)
      .def_rw("viscous_joint", &M::viscous_joint)
      .def_rw("offset_joint", &M::offset_joint)
      .def_rw("lock_joint", &M::lock_joint)
      .def_rw("term_lo", &M::term_lo)
      .def_rw("term_step", &M::term_step)
      .def_rw("term_torque", &M::term_torque)
      .def_rw("stop_lower", &M::stop_lower)
      .def_rw("stop_upper", &M::stop_upper)
      .def_rw("stop_stiffness", &M::stop_stiffness)
      .def_rw("stop_damping", &M::stop_damping)
      .def_rw("gravity_compensation", &M::gravity_compensation)
      .def_rw("encoder_counts", &M::encoder_counts)
      .def_rw("current_noise", &M::current_noise)
      .def_rw("dt", &M::dt)
      .def_rw("control_decimation", &M::control_decimation)
      .def_rw("mode", &M::mode)
      .def_rw("kp", &M::kp)
      .def_rw("kd", &M::kd)
      .def_rw("ki", &M::ki)
      .def_rw("velocity_cutoff_hz", &M::velocity_cutoff_hz)
      .def_rw("pgs_max_iterations", &M::pgs_max_iterations)
      .def_rw("pgs_tolerance", &M::pgs_tolerance)
      .def_rw("pgs_speed_tolerance", &M::pgs_speed_tolerance)
      .def_rw("pgs_relaxation", &M::pgs_relaxation)
      .def_rw("pgs_exact_finish", &M::pgs_exact_finish)
      .def_ro("nv", &M::nv)
      .def_ro("n_sites", &M::n_sites)
      .def_ro("G", &M::G)
      .def_ro("D", &M::D)
      .def_ro("site_kind", &M::site_kind)
      .def_ro("site_i", &M::site_i)
      .def_ro("site_b", &M::site_b)
      .def("finalize", [](M& self) { return check(self.finalize(), "SimModel.finalize"); });

  nb::class_<D>(m, "SimData", "State and preallocated workspace of the simulator.")
      .def(nb::init<const M&>(), nb::arg("model"))
      .def("reset", &D::reset, nb::arg("q0"), nb::arg("seed"))
      .def_ro("time", &D::time)
      .def_ro("step_count", &D::step_count)
      .def_ro("q", &D::q)
      .def_ro("qd", &D::qd)
      .def_ro("q_motor", &D::q_motor)
      .def_ro("qd_motor", &D::qd_motor)
      .def_ro("q_motor_meas", &D::q_motor_meas)
      .def_ro("torque_motor_meas", &D::torque_motor_meas)
      .def_ro("torque_motor_cmd", &D::torque_motor_cmd)
      .def_ro("torque_motor", &D::torque_motor)
      .def_ro("tension", &D::tension)
      .def_ro("tension_motor", &D::tension_motor)
      .def_ro("p", &D::p)
      .def_ro("impulse_lo", &D::lo)  // the boxes of the last step, scaled to impulses [N·s or N·m·s]
      .def_ro("impulse_hi", &D::hi)
      .def_ro("pgs_iterations", &D::pgs_iterations)
      .def_ro("pgs_finished", &D::pgs_finished)
      .def_ro("work_motor", &D::work_motor)
      .def_ro("work_external", &D::work_external)
      .def_ro("dissipated", &D::dissipated)
      .def_ro("numerical_loss", &D::numerical_loss)
      .def_ro("stop_depth", &D::stop_depth)
      .def_ro("stops_touched", &D::stops_touched)
      .def_ro("stop_contact_time", &D::stop_contact_time)
      .def("set_velocity",
           [](D& d, VecRef qd, VecRef qd_motor) { d.qd = qd; d.qd_motor = qd_motor; d.qd_motor_prev = qd_motor; },
           nb::arg("qd"), nb::arg("qd_motor"))
      .def("set_motor_position", [](D& d, VecRef q_motor) { d.q_motor = q_motor; }, nb::arg("q_motor"));

  m.def("step",
        [](const M& mo, D& d, VecRef ref_q, VecRef ref_v, VecRef ff, VecRef ext) {
          if (ref_q.size() != mo.n_ref() || ref_v.size() != mo.n_ref() || ff.size() != mo.n_ff() || ext.size() != mo.na)
            throw nb::value_error("step: ref_q, ref_v need n_ref entries, ff n_ff, torque_ext na");
          return check(step(mo, d, ref_q, ref_v, ff, ext), "step");
        },
        nb::arg("model"), nb::arg("data"), nb::arg("ref_q"), nb::arg("ref_v"), nb::arg("ff"), nb::arg("torque_ext"));
  m.def("mechanical_energy", &mechanical_energy, nb::arg("model"), nb::arg("data"));
  m.def(
      "run",
      [](const M& mo, D& d, MatRef ref_q, MatRef ref_v, MatRef ff, MatRef ext, int log_every, OutVec time,
         OutMat q_motor_meas, OutMat torque_motor_meas, OutMat torque_motor_cmd, OutMat q_joint, OutMat qd_joint,
         OutMat q_motor, OutMat qd_motor) {
        if (log_every < 1 || log_every % mo.control_decimation != 0)
          throw nb::value_error("run: log_every must be a positive multiple of model.control_decimation");
        if (d.step_count % mo.control_decimation != 0)
          throw nb::value_error("run: the data is between two control periods (run steps in whole periods)");
        const long rows = (ref_q.rows() + log_every - 1) / log_every;
        if (time.size() != rows)
          throw nb::value_error("run: time must have ceil(steps / log_every) entries");
        if (ref_q.cols() != mo.n_ref() || ref_v.cols() != mo.n_ref() || ff.cols() != mo.n_ff() || ext.cols() != mo.na)
          throw nb::value_error("run: ref_q, ref_v need n_ref columns, ff n_ff, torque_ext na");
        for (const auto* o : {&q_motor_meas, &torque_motor_meas, &torque_motor_cmd, &q_motor, &qd_motor})
          if (o->rows() != rows || o->cols() != mo.nm)
            throw nb::value_error("run: every motor log array must be (ceil(steps / log_every), nm), float64, C order");
        for (const auto* o : {&q_joint, &qd_joint})
          if (o->rows() != rows || o->cols() != mo.na)
            throw nb::value_error("run: q_joint, qd_joint must be (ceil(steps / log_every), na), float64, C order");
        SimLog log{time, q_motor_meas, torque_motor_meas, torque_motor_cmd, q_joint, qd_joint, q_motor, qd_motor};
        Status s;
        {
          nb::gil_scoped_release release;
          s = run(mo, d, ref_q, ref_v, ff, ext, log_every, log);
        }
        return check(s, "run");
      },
      nb::arg("model"), nb::arg("data"), nb::arg("ref_q"), nb::arg("ref_v"), nb::arg("ff"),
      nb::arg("torque_ext"), nb::arg("log_every"), nb::arg("time"), nb::arg("q_motor_meas"),
      nb::arg("torque_motor_meas"), nb::arg("torque_motor_cmd"), nb::arg("q_joint"), nb::arg("qd_joint"),
      nb::arg("q_motor"), nb::arg("qd_motor"),
      "Run len(ref_q) steps; inputs row-major: ref_q, ref_v (steps, n_ref), ff (steps, n_ff), torque_ext (steps, na).\n"
      "Writes the log into the preallocated float64 arrays (time (rows,), q_joint, qd_joint (rows, na), the motor\n"
      "channels (rows, nm), rows = ceil(steps / log_every)), the fields of C++ SimLog in order.\n"
      "tendyn.sim.model.run_log allocates them and returns a dict.");

  using In3 = nb::ndarray<const double, nb::ndim<3>, nb::c_contig, nb::device::cpu>;
  using Out2 = nb::ndarray<double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
  using Out3 = nb::ndarray<double, nb::ndim<3>, nb::c_contig, nb::device::cpu>;
  m.def(
      "run_batch",
      [](nb::list models, nb::list datas, In3 ref_q, In3 ref_v, In3 ff, In3 ext, int log_every, int threads,
         Out2 time, Out3 q_motor_meas, Out3 torque_motor_meas, Out3 torque_motor_cmd, Out3 q_joint, Out3 qd_joint,
         Out3 q_motor, Out3 qd_motor) {
        const std::size_t B = nb::len(datas);
        if (B == 0) throw nb::value_error("run_batch: no runs (datas is empty)");
        if (nb::len(models) != 1 && nb::len(models) != B)
          throw nb::value_error("run_batch: give one model for every run or one model for all");
        std::vector<nb::object> keep;  // the list items stay alive while the GIL is released
        std::vector<const M*> mp(B);
        std::vector<D*> dp(B);
        for (std::size_t k = 0; k < B; ++k) {
          keep.push_back(datas[k]);
          dp[k] = &nb::cast<D&>(datas[k]);
          nb::handle mo = models[nb::len(models) == 1 ? 0 : k];
          keep.push_back(nb::borrow(mo));
          mp[k] = &nb::cast<const M&>(mo);
        }
        std::vector<D*> sorted = dp;
        std::sort(sorted.begin(), sorted.end());
        if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
          throw nb::value_error("run_batch: every run needs its own SimData (one appears twice in datas)");
        const long na = mp[0]->na;
        for (std::size_t k = 0; k < B; ++k) {
          const M& mo = *mp[k];
          const D& d = *dp[k];
          if (mo.na != na) throw nb::value_error("run_batch: every model must have the same number of joints");
          if (mo.nm != mo.na)
            throw nb::value_error("run_batch: N+1 tendon models (nm = na + 1 motors) are run one by one (run)");
          if (d.q.size() != mo.na || d.M.rows() != mo.nv || d.p.size() != mo.n_sites)
            throw nb::value_error("run_batch: a SimData was not made for its model");
          if (log_every < 1 || log_every % mo.control_decimation != 0)
            throw nb::value_error("run_batch: log_every must be a positive multiple of every model's control_decimation");
          if (d.step_count % mo.control_decimation != 0)
            throw nb::value_error("run_batch: a data is between two control periods (run steps in whole periods)");
        }
        const long steps = static_cast<long>(ref_q.shape(1));
        for (const In3* a : {&ref_q, &ref_v, &ff, &ext})
          if ((a->shape(0) != 1 && a->shape(0) != B) || static_cast<long>(a->shape(1)) != steps ||
              static_cast<long>(a->shape(2)) != na)
            throw nb::value_error("run_batch: inputs must be (runs or 1, steps, na) float64, C order");
        const long rows = (steps + log_every - 1) / log_every;
        if (time.shape(0) != B || static_cast<long>(time.shape(1)) != rows)
          throw nb::value_error("run_batch: time must be (runs, ceil(steps / log_every))");
        for (const Out3* o : {&q_motor_meas, &torque_motor_meas, &torque_motor_cmd, &q_joint, &qd_joint, &q_motor,
                              &qd_motor})
          if (o->shape(0) != B || static_cast<long>(o->shape(1)) != rows || static_cast<long>(o->shape(2)) != na)
            throw nb::value_error("run_batch: every log array must be (runs, ceil(steps / log_every), na), float64, C order");
        auto in = [&](const In3& a, std::size_t k) {
          return Eigen::Map<const RowMat>(a.data() + (a.shape(0) == 1 ? 0 : k * steps * na), steps, na);
        };
        auto out = [&](Out3& a, std::size_t k) { return Eigen::Map<RowMat>(a.data() + k * rows * na, rows, na); };
        std::vector<BatchRun> runs;
        runs.reserve(B);
        for (std::size_t k = 0; k < B; ++k)
          runs.push_back(BatchRun{mp[k], dp[k], in(ref_q, k), in(ref_v, k), in(ff, k), in(ext, k),
                                  SimLog{Eigen::Map<Eigen::VectorXd>(time.data() + k * rows, rows),
                                         out(q_motor_meas, k), out(torque_motor_meas, k), out(torque_motor_cmd, k),
                                         out(q_joint, k), out(qd_joint, k), out(q_motor, k), out(qd_motor, k)}});
        {
          nb::gil_scoped_release release;
          run_batch(runs.data(), static_cast<int>(B), log_every, threads);
        }
        for (std::size_t k = 0; k < B; ++k)
          if (is_error(runs[k].status))
            throw nb::value_error(("run_batch: run " + std::to_string(k) + ": " + status_message(runs[k].status)).c_str());
        return batch_threads(threads, static_cast<int>(B));
      },
      nb::arg("models"), nb::arg("datas"), nb::arg("ref_q"), nb::arg("ref_v"), nb::arg("ff"), nb::arg("torque_ext"),
      nb::arg("log_every"), nb::arg("threads"), nb::arg("time").noconvert(), nb::arg("q_motor_meas").noconvert(),
      nb::arg("torque_motor_meas").noconvert(), nb::arg("torque_motor_cmd").noconvert(),
      nb::arg("q_joint").noconvert(), nb::arg("qd_joint").noconvert(), nb::arg("q_motor").noconvert(),
      nb::arg("qd_motor").noconvert(),
      "Run len(datas) independent runs (C++ tendyn::run_batch) on `threads` threads (< 1: one per hardware\n"
      "thread), the GIL released. models: one SimModel for all runs or one per run; datas: one SimData per run.\n"
      "Inputs (runs or 1, steps, na), log arrays (runs, rows, na) and time (runs, rows) as for run(). Returns the\n"
      "number of threads used. tendyn.sim.model.run_batch allocates the log and returns a dict.");
}

}  // namespace tendyn::py

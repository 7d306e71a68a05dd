// The simulator step allocates nothing (tendon and elastic drives, friction on, sensors on); and physics
// checks against values computed by hand, so that this executable can fail on wrong simulator physics.
// `test_sim STEPS` runs those (CTest: sim_no_allocation); `test_sim batch` the batch checks of sim_batch_checks.hpp
// (CTest: sim_batch): one executable, so the simulator's templates are compiled once.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <Eigen/Geometry>

#include "counting_malloc.hpp"
#include "sim_batch_checks.hpp"
#include "sim_test_chain.hpp"
#include "tendyn/sim.hpp"

// The shared test chain, with a joint PID in the loop.
static tendyn::SimModel chain(tendyn::DriveKind kind) {
  tendyn::SimModel m = three_joint_chain(kind);
  m.mode = tendyn::ControlMode::JointPID;
  m.kp = Eigen::VectorXd::Constant(m.L.cols(), 20.0);
  m.kd = Eigen::VectorXd::Constant(m.L.cols(), 1.0);
  return m;
}

// One joint about the vertical axis (gravity gives no torque): 1 kg at 0.1 m, 0.001 kg m^2 about the COM.
static tendyn::SimModel one_joint(double r_m, double pulley, double ratio, double eta) {
  tendyn::SimModel m;
  m.body.add_joint(0, Eigen::Matrix4d::Identity(), Eigen::Vector3d::UnitZ(), false, 1.0,
                   Eigen::Vector3d(0.1, 0.0, 0.0), Eigen::Matrix3d::Identity() * 0.001, "j1");
  m.body.set_gravity(Eigen::Vector3d(0, 0, -9.81));
  m.L = Eigen::MatrixXd::Identity(1, 1);
  m.c = Eigen::VectorXd::Zero(1);
  m.drive = tendyn::DriveKind::Tendon;
  m.tendon = tendyn::TransmissionModel(Eigen::VectorXd::Constant(1, r_m), Eigen::MatrixXd::Zero(1, 1),
                                       Eigen::VectorXd::Constant(1, pulley), Eigen::VectorXd::Constant(1, ratio));
  m.tendon.reducer_efficiency.setConstant(eta);
  m.rotor_inertia = Eigen::VectorXd::Constant(1, 1e-5);
  m.dt = 1e-4;
  m.control_decimation = 10;
  return m;
}

static int physics_failures = 0;
static void expect(bool ok, const char* what, double got, double want) {
  if (!ok) {
    std::printf("PHYSICS FAIL %s: got %.12g, want %.12g\n", what, got, want);
    ++physics_failures;
  }
}

// Reducer n = 8, eta_d = 0.9, r_m = 8 mm, pulley 40 mm, C_m = 0.05 N m: n M_p = 0.32 * 0.05/0.008 = 2 N m.
// At constant speed the joint balances tau_ext with eta_d n M_p = 1.8 N m driving (qd = +1) and
// n M_p / eta_i = 2 * 0.9/0.8 = 2.25 N m back-driven (qd = -1), S0 eqs. 9-10: the speed must not drift.
static void reducer_constant_speed() {
  for (double qd : {1.0, -1.0}) {
    tendyn::SimModel m = one_joint(0.008, 0.04, 8.0, 0.9);
    if (tendyn::is_error(m.finalize())) { ++physics_failures; return; }
    tendyn::SimData d(m);
    d.reset(Eigen::VectorXd::Zero(1), 0);
    d.qd(0) = qd;
    d.qd_motor = m.Gm * d.qd;
    d.qd_motor_prev = d.qd_motor;
    Eigen::VectorXd z = Eigen::VectorXd::Zero(1), ff = Eigen::VectorXd::Constant(1, 0.05);
    Eigen::VectorXd ext = Eigen::VectorXd::Constant(1, qd > 0 ? -1.8 : -2.25);
    for (int k = 0; k < 3000; ++k) tendyn::step(m, d, z, z, ff, ext);
    expect(std::abs(d.qd(0) - qd) < 3e-3, qd > 0 ? "reducer driving, speed" : "reducer back-driven, speed",
           d.qd(0), qd);
  }
}

// Velocity estimate: first-order filter, alpha = 1 - exp(-2 pi f_c T_c); at a constant speed v0 the k-th
// control sample (k = 0 has no difference yet) reads v0 (1 - (1 - alpha)^k). f_c = 20 Hz, T_c = 1 ms.
static void velocity_estimator() {
  tendyn::SimModel m = one_joint(0.01, 0.05, 1.0, 1.0);
  m.mode = tendyn::ControlMode::JointPID;
  m.velocity_cutoff_hz = 20.0;
  m.peak_torque = Eigen::VectorXd::Constant(1, 1e-12);
  if (tendyn::is_error(m.finalize())) { ++physics_failures; return; }
  tendyn::SimData d(m);
  d.reset(Eigen::VectorXd::Zero(1), 0);
  d.qd(0) = 0.8;
  d.qd_motor = m.Gm * d.qd;
  Eigen::VectorXd z = Eigen::VectorXd::Zero(1);
  for (int k = 0; k < 101; ++k) tendyn::step(m, d, z, z, z, z);  // 11 control samples, k = 0..10
  const double alpha = 1.0 - std::exp(-2.0 * 3.141592653589793 * 20.0 * 1e-3);
  const double want = 0.8 * (1.0 - std::pow(1.0 - alpha, 10));
  expect(std::abs(d.v_est(0) - want) < 1e-6 * want, "velocity estimate after 10 samples", d.v_est(0), want);
}

// Encoder of 4096 counts: rounds to the nearest count, the error is within +-step/2 and centred.
static void encoder_rounding() {
  tendyn::SimModel m = one_joint(0.01, 0.05, 1.0, 1.0);
  m.encoder_counts = Eigen::VectorXd::Constant(1, 4096);
  if (tendyn::is_error(m.finalize())) { ++physics_failures; return; }
  tendyn::SimData d(m);
  d.reset(Eigen::VectorXd::Zero(1), 0);
  const double step = 2.0 * 3.141592653589793 / 4096;
  Eigen::VectorXd z = Eigen::VectorXd::Zero(1);
  double worst = 0.0, sum = 0.0;
  const int n = 10007;
  for (int k = 0; k < n; ++k) {
    d.q(0) = 1e-4 * k;                      // sweeps 1.0 rad of joint, 5 rad of motor
    tendyn::motor_state(m, d);
    tendyn::control(m, d, z, z, z);
    const double e = d.q_motor_meas(0) - d.q_motor(0);
    worst = std::max(worst, std::abs(e));
    sum += e;
  }
  expect(worst <= 0.5 * step + 1e-12, "encoder error within half a count", worst, 0.5 * step);
  expect(std::abs(sum / n) < 0.05 * step, "encoder error centred", sum / n, 0.0);
}

// One-pass mass matrix and bias forces (tree_dynamics.hpp) vs Pinocchio's crba and nonLinearEffects, an
// independent implementation (local frames, joint-variant dispatch), to 1e-12: a branching tree with
// revolute joints about z and about unaligned axes, a prismatic joint, off-diagonal inertias, gravity
// off the axes, random states.
static void tree_dynamics_matches_pinocchio() {
  tendyn::RigidBodyModel body;
  std::srand(7);
  auto rnd = [] { return 2.0 * std::rand() / RAND_MAX - 1.0; };
  const int parents[6] = {0, 1, 2, 3, 2, 5};  // joint 5 branches off joint 2 beside joint 3 (depth-first order)
  for (int j = 0; j < 6; ++j) {
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
    T.topLeftCorner<3, 3>() = Eigen::AngleAxisd(rnd() * 3.0, Eigen::Vector3d(rnd(), rnd(), rnd()).normalized())
                                  .toRotationMatrix();
    T.topRightCorner<3, 1>() = 0.3 * Eigen::Vector3d(rnd(), rnd(), rnd());
    const Eigen::Vector3d axis = j % 2 == 0 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d(rnd(), rnd(), rnd()).normalized();
    Eigen::Matrix3d A = Eigen::Matrix3d::Random() * 0.05;
    const Eigen::Matrix3d I = A * A.transpose() + 0.01 * Eigen::Matrix3d::Identity();
    body.add_joint(parents[j], T, axis, j == 3, 0.5 + std::abs(rnd()), 0.1 * Eigen::Vector3d(rnd(), rnd(), rnd()), I,
                   "j" + std::to_string(j + 1));
  }
  body.set_gravity(Eigen::Vector3d(1.0, -2.0, -9.81));
  const tendyn::TreeDynamicsModel tm(body.pin);
  expect(tm.valid, "tree of revolute/prismatic joints accepted", tm.valid, 1.0);
  if (!tm.valid) return;
  tendyn::TreeDynamicsData td(tm);
  pinocchio::Data pd(body.pin);
  double worst_m = 0.0, worst_b = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::VectorXd q(6), v(6);
    for (int j = 0; j < 6; ++j) { q(j) = 3.0 * rnd(); v(j) = 4.0 * rnd(); }
    tendyn::tree_mass_and_bias(tm, td, q, v);
    pinocchio::crba(body.pin, pd, Eigen::Ref<const Eigen::VectorXd>(q));  // the library's instantiation (sim_step.hpp)
    pd.M.triangularView<Eigen::StrictlyLower>() = pd.M.transpose().triangularView<Eigen::StrictlyLower>();
    pinocchio::nonLinearEffects(body.pin, pd, q, v);
    worst_m = std::max(worst_m, (td.M - pd.M).cwiseAbs().maxCoeff() / pd.M.cwiseAbs().maxCoeff());
    worst_b = std::max(worst_b, (td.nle - pd.nle).cwiseAbs().maxCoeff() / pd.nle.cwiseAbs().maxCoeff());
  }
  expect(worst_m < 1e-12, "one-pass mass matrix vs Pinocchio crba (relative)", worst_m, 0.0);
  expect(worst_b < 1e-12, "one-pass bias forces vs Pinocchio nonLinearEffects (relative)", worst_b, 0.0);
  std::printf("tree dynamics vs Pinocchio: mass matrix %.2e, bias forces %.2e (relative, worst of 50)\n", worst_m,
              worst_b);
}

// The step on the one-pass dynamics vs the same step on Pinocchio's crba + nonLinearEffects (the fallback
// for trees the one pass does not take): a tendon chain with friction and an elastic chain, 3000 steps.
static void step_on_pinocchio_matches() {
  for (auto kind : {tendyn::DriveKind::Tendon, tendyn::DriveKind::Elastic}) {
    tendyn::SimModel a = chain(kind);
    if (tendyn::is_error(a.finalize())) { ++physics_failures; return; }
    tendyn::SimModel b = a;
    b.tree.valid = false;  // Pinocchio path
    tendyn::SimData da(a), db(b);
    da.reset(Eigen::VectorXd::Constant(a.na, 0.2), 42);
    db.reset(Eigen::VectorXd::Constant(b.na, 0.2), 42);
    Eigen::VectorXd ref = Eigen::VectorXd::Constant(a.na, 0.5), zero = Eigen::VectorXd::Zero(a.na);
    double worst = 0.0;
    for (int s = 0; s < 3000; ++s) {
      tendyn::step(a, da, ref, zero, zero, zero);
      tendyn::step(b, db, ref, zero, zero, zero);
      worst = std::max(worst, (da.q - db.q).cwiseAbs().maxCoeff());
    }
    expect(worst < 1e-10, kind == tendyn::DriveKind::Tendon ? "tendon step, one pass vs Pinocchio [rad]"
                                                            : "elastic step, one pass vs Pinocchio [rad]", worst, 0.0);
  }
}

// The chain with a differential on joints 2-3 (issue 19): cables 2 and 3 both wrap the pulleys of joints 2 and 3
// (30 mm), cable 3 reversed on joint 3: K block [[r, r], [r, -r]]; friction on every branch (their sites reach
// joint 3 for cable 2, past its driven joint).
static tendyn::SimModel differential_chain() {
  tendyn::SimModel m = chain(tendyn::DriveKind::Tendon);
  const int n = 3;
  tendyn::TransmissionModel t(n);
  const double K[9] = {0.32, 0, 0, 0.015, 0.03, 0.03, 0.015, 0.03, -0.03};
  const double rm[3] = {0.008, 0.008, 0.008}, rd[3] = {0.04, 0.03, -0.03}, ratio[3] = {8, 1, 1};
  t.set_field("motor_radius", rm, n, 1);
  t.set_field("K", K, n, n);
  t.set_field("driven_radius", rd, n, 1);
  t.set_field("reducer_ratio", ratio, n, 1);
  t.update_matrices();
  t.reducer_efficiency(0) = 0.9;
  t.tau0.setConstant(1.0);
  t.nu.setConstant(10.0);
  t.beta.setConstant(0.02);
  m.tendon = t;
  return m;
}

// The chain moved by N+1 tendons (issue 19; sim.hpp, DriveKind::Tendons): 4 tendons on 3 joints, the finger's
// routing of python/tendyn/devices/tendon_finger.toml scaled by 2.5 (h = [1/12, 1/5, 7/8, 1] > 0), branch losses
// tau0 1 N, nu 10 N s/m on every branch (S0 eq. 12), floors 5 N, the PID torque allocated with the losses at the
// reference velocity (tendon_loss_compensation).
static tendyn::SimModel n_plus_one_chain() {
  tendyn::SimModel m = chain(tendyn::DriveKind::Tendons);
  Eigen::MatrixXd K(4, 3);
  K << 0.03, 0, 0, 0.025, 0.025, 0, 0.02, 0.02, 0.02, -0.025, -0.0225, -0.0175;
  Eigen::MatrixXd tau0 = Eigen::MatrixXd::Zero(4, 3), nu = Eigen::MatrixXd::Zero(4, 3);
  const int last[4] = {0, 1, 2, 2};
  for (int i = 0; i < 4; ++i)
    for (int b = 0; b <= last[i]; ++b) { tau0(i, b) = 1.0; nu(i, b) = 10.0; }
  const std::string issue = tendyn::make_tendon_model(K, Eigen::VectorXd::Constant(4, 0.008),
                                                      Eigen::VectorXd::Constant(4, 5.0), m.tendons,
                                                      Eigen::VectorXi(), tau0, nu);
  if (!issue.empty()) std::printf("n_plus_one_chain: %s\n", issue.c_str());
  m.rotor_inertia = Eigen::VectorXd::Constant(4, 1e-5);
  m.encoder_counts = Eigen::VectorXd::Constant(4, 16384);
  m.current_noise = Eigen::VectorXd::Constant(4, 0.01);
  m.tendon_loss_compensation = true;
  return m;
}

int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "batch") == 0) return sim_batch_checks();
  tree_dynamics_matches_pinocchio();
  step_on_pinocchio_matches();
  reducer_constant_speed();
  velocity_estimator();
  encoder_rounding();
  if (physics_failures) return 1;
  const long steps = argc > 1 ? std::atol(argv[1]) : 20000;
  int failures = 0;
  for (int c = 0; c < 4; ++c) {
    const auto kind = c == 1 ? tendyn::DriveKind::Elastic : c == 3 ? tendyn::DriveKind::Tendons
                                                                    : tendyn::DriveKind::Tendon;
    tendyn::SimModel m = c == 2 ? differential_chain() : c == 3 ? n_plus_one_chain() : chain(kind);
    if (tendyn::is_error(m.finalize())) { std::puts("finalize failed"); return 1; }
    if (c == 2 && m.n_sites != (1 + 3 + 3) + 3) { std::puts("differential: cable 2 must have 3 branch sites"); return 1; }
    if (c == 3 && (m.nm != 4 || m.n_sites != 1 + 2 + 3 + 3)) { std::puts("N+1: 4 motors, 9 branch sites"); return 1; }
    tendyn::SimData d(m);
    d.reset(Eigen::VectorXd::Constant(m.na, 0.2), 42);
    Eigen::VectorXd ref = Eigen::VectorXd::Constant(m.na, 0.5), zero = Eigen::VectorXd::Zero(m.na);
    counting::count = 0;
    counting::armed = true;
    for (long s = 0; s < steps; ++s) tendyn::step(m, d, ref, zero, zero, zero);
    counting::armed = false;
    std::printf("%s: %ld steps, %ld allocations, q = %.4f %.4f %.4f\n",
                c == 2 ? "tendon, differential" : c == 3 ? "N+1 tendons" : kind == tendyn::DriveKind::Tendon ? "tendon"
                                                                                                   : "elastic", steps,
                counting::count, d.q(0), d.q(1), d.q(2));
    if (counting::count != 0) ++failures;
    // the joint PID moves the differential's joints from 0.2 toward their reference 0.5 (against gravity and
    // friction, as on the serial chain): the coupled cables drive both joints the right way
    // N+1: as on the serial chain the weak PID leaves joint 1 low against gravity; joints 2-3 move toward 0.5,
    // and every tendon's motor pulls at least its floor (the allocation of tendons.hpp in the loop)
    if (c == 3 && !(d.q(1) > 0.25 && d.q(1) < 0.6 && d.q(2) > 0.25 && d.q(2) < 0.6 &&
                    (d.torque_motor.array() / 0.008 > 5.0 - 1e-9).all())) {
      std::puts("N+1 chain: the PID did not move joints 2-3 toward 0.5 with every tendon at or above its floor");
      ++failures;
    }
    if (c == 2 && !(d.q(1) > 0.25 && d.q(1) < 0.6 && d.q(2) > 0.25 && d.q(2) < 0.6)) {
      std::puts("differential chain: the PID did not move the differential's joints toward the reference");
      ++failures;
    }
  }
  return failures;
}

// The simulator step allocates nothing (tendon and elastic drives, friction on, sensors on).
#include <cstdio>
#include <cstdlib>

#include "counting_malloc.hpp"
#include "tendyn/sim.hpp"

static tendyn::SimModel chain(tendyn::DriveKind kind) {
  tendyn::SimModel m;
  const int n = 3;
  for (int j = 0; j < n; ++j) {
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
    T(0, 3) = j == 0 ? 0.0 : 0.25;
    m.body.add_joint(j, T, Eigen::Vector3d::UnitZ(), false, 1.0, Eigen::Vector3d(0.1, 0.02, 0.0),
                     Eigen::Matrix3d::Identity() * 0.01, "j" + std::to_string(j + 1));
  }
  m.body.set_gravity(Eigen::Vector3d(0, -9.81, 0));
  m.L = Eigen::MatrixXd::Identity(n, n);
  m.c = Eigen::VectorXd::Zero(n);
  m.drive = kind;
  if (kind == tendyn::DriveKind::Tendon) {
    Eigen::MatrixXd idle = Eigen::MatrixXd::Zero(n, n);
    idle(1, 0) = 0.015; idle(2, 0) = 0.015; idle(2, 1) = -0.015;
    m.tendon = tendyn::TransmissionModel(Eigen::VectorXd::Constant(n, 0.008), idle,
                                         Eigen::VectorXd::Constant(n, 0.04), Eigen::VectorXd::Constant(n, 8.0));
    m.tendon.reducer_efficiency.setConstant(0.9);
    m.tendon.tau0.setConstant(1.0); m.tendon.nu.setConstant(10.0); m.tendon.beta.setConstant(0.02);
  } else {
    m.ratio = Eigen::VectorXd::Constant(n, 20.0);
    m.stiffness_motor = Eigen::VectorXd::Constant(n, 2.0);
    m.coulomb_motor = Eigen::VectorXd::Constant(n, 0.006);
    m.viscous_motor = Eigen::VectorXd::Constant(n, 1e-4);
  }
  m.rotor_inertia = Eigen::VectorXd::Constant(n, 1e-5);
  m.encoder_counts = Eigen::VectorXd::Constant(n, 16384);
  m.current_noise = Eigen::VectorXd::Constant(n, 0.01);
  m.mode = tendyn::ControlMode::JointPID;
  m.kp = Eigen::VectorXd::Constant(n, 20.0);
  m.kd = Eigen::VectorXd::Constant(n, 1.0);
  m.dt = 1e-4;
  m.control_decimation = 10;
  return m;
}

int main(int argc, char** argv) {
  const long steps = argc > 1 ? std::atol(argv[1]) : 20000;
  int failures = 0;
  for (auto kind : {tendyn::DriveKind::Tendon, tendyn::DriveKind::Elastic}) {
    tendyn::SimModel m = chain(kind);
    if (tendyn::is_error(m.finalize())) { std::puts("finalize failed"); return 1; }
    tendyn::SimData d(m);
    d.reset(Eigen::VectorXd::Constant(m.na, 0.2), 42);
    Eigen::VectorXd ref = Eigen::VectorXd::Constant(m.na, 0.5), zero = Eigen::VectorXd::Zero(m.na);
    counting::count = 0;
    counting::armed = true;
    for (long s = 0; s < steps; ++s) tendyn::step(m, d, ref, zero, zero, zero);
    counting::armed = false;
    std::printf("%s: %ld steps, %ld allocations, q = %.4f %.4f %.4f\n",
                kind == tendyn::DriveKind::Tendon ? "tendon" : "elastic", steps, counting::count,
                d.q(0), d.q(1), d.q(2));
    if (counting::count != 0) ++failures;
  }
  return failures;
}

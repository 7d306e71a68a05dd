// The 3-joint test chain of the C++ simulator tests (test_sim_no_alloc.cpp, test_sim_batch.cpp): revolute
// joints about z, 0.25 m links, 1 kg at (0.1, 0.02) m, gravity −9.81 along y, sensors on, 10 kHz, control at
// 1 kHz. Tendon drive: coupled idle pulleys, friction on every branch (tau0, beta × friction_scale, nu 10) and
// reducer (η 0.9). Elastic drive: capstans N = 20 on K_T = 2 N·m/rad, motor Coulomb 0.006 N·m.
#pragma once

#include <string>

#include "tendyn/sim.hpp"

inline tendyn::SimModel three_joint_chain(tendyn::DriveKind kind, double friction_scale = 1.0) {
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
    m.tendon.tau0.setConstant(1.0 * friction_scale);
    m.tendon.nu.setConstant(10.0);
    m.tendon.beta.setConstant(0.02 * friction_scale);
  } else {
    m.ratio = Eigen::VectorXd::Constant(n, 20.0);
    m.stiffness_motor = Eigen::VectorXd::Constant(n, 2.0);
    m.coulomb_motor = Eigen::VectorXd::Constant(n, 0.006);
    m.viscous_motor = Eigen::VectorXd::Constant(n, 1e-4);
  }
  m.rotor_inertia = Eigen::VectorXd::Constant(n, 1e-5);
  m.encoder_counts = Eigen::VectorXd::Constant(n, 16384);
  m.current_noise = Eigen::VectorXd::Constant(n, 0.01);
  m.dt = 1e-4;
  m.control_decimation = 10;
  return m;
}

// N+1 tendons (include/tendyn/tendons.hpp): the feedforward allocates nothing in 10^5 calls (lossless and with
// S0 eq. 12 losses), and it is checked against the hand-derived finger of python/tendyn/devices/tendon_finger.toml:
// h = [1/12, 1/5, 7/8, 1], Kᵀ t = τ, every tension ≥ its floor with one on it, virtual work τᵀq̇ = tᵀℓ̇; with losses
// the joint equilibrium at every joint from the tensions there, and the motors' power = the joints' power + the
// power dissipated in the branches Σ (τ0 |Ṡ| + ν Ṡ²); a routing without closure and a rank-deficient one are
// refused naming the tendon.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "counting_malloc.hpp"
#include "tendyn/tendons.hpp"

static int fails = 0;
static void expect(bool ok, const char* what) {
  if (!ok) {
    std::printf("FAIL %s\n", what);
    ++fails;
  }
}

int main(int argc, char** argv) {
  const long cycles = argc > 1 ? std::atol(argv[1]) : 100000;
  Eigen::MatrixXd K(4, 3);
  K << 0.012, 0.0, 0.0,      //
      0.010, 0.010, 0.0,     //
      0.008, 0.008, 0.008,   //
      -0.010, -0.009, -0.007;
  const Eigen::VectorXd r_m = Eigen::VectorXd::Constant(4, 0.008);
  const Eigen::VectorXd floors = Eigen::VectorXd::Constant(4, 2.0);
  tendyn::TendonModel model;
  const std::string issue = tendyn::make_tendon_model(K, r_m, floors, model);
  expect(issue.empty(), "the finger builds");
  if (!issue.empty()) std::printf("  %s\n", issue.c_str());
  Eigen::Vector4d h_hand(1.0 / 12.0, 0.2, 0.875, 1.0);
  expect((model.null_vector - h_hand).cwiseAbs().maxCoeff() < 1e-12, "null vector = hand-derived [1/12, 1/5, 7/8, 1]");

  tendyn::TendonData data = tendyn::make_tendon_data(model);
  Eigen::VectorXd tau(3), tau_back(3), qd(3), speed(4);
  // warm-up, then count
  tau << 0.1, -0.05, 0.02;
  tendyn::tendon_feedforward(model, tau, data);
  counting::count = 0;
  counting::armed = true;
  double worst_torque = 0.0, worst_floor = 1e300, worst_power = 0.0;
  for (long k = 0; k < cycles; ++k) {
    const double s = 1e-3 * static_cast<double>(k % 1000);
    tau << 0.2 * std::sin(7.0 * s), -0.15 * std::cos(3.0 * s), 0.05 * std::sin(11.0 * s + 1.0);
    qd << std::cos(s), std::sin(2.0 * s), -0.5;
    if (tendyn::tendon_feedforward(model, tau, data) != tendyn::Status::Ok) ++fails;
    tendyn::tendon_joint_torque(model, data.tension, tau_back);
    tendyn::tendon_velocity(model, qd, speed);
    worst_torque = std::max(worst_torque, (tau_back - tau).cwiseAbs().maxCoeff());
    worst_floor = std::min(worst_floor, (data.tension - floors).minCoeff());
    worst_power = std::max(worst_power, std::abs(tau_back.dot(qd) - data.tension.dot(speed)));
  }
  counting::armed = false;
  std::printf("tendon_feedforward: %ld calls, %ld allocations; |K^T t - tau| <= %.3g N m, min(t - t_min) = %.3g N, "
              "|tau.qd - t.ld| <= %.3g W\n", cycles, counting::count, worst_torque, worst_floor, worst_power);
  expect(counting::count == 0, "no allocation in tendon_feedforward / tendon_joint_torque / tendon_velocity");
  expect(worst_torque < 1e-12, "the tensions deliver the joint torques");
  expect(std::abs(worst_floor) < 1e-9, "every tension >= its floor, one on it (least internal tension)");
  expect(worst_power < 1e-12, "virtual work");
  // with losses (S0 eq. 12): the finger's friction entries, branch b of tendon i
  Eigen::MatrixXd tau0(4, 3), nu(4, 3);
  tau0 << 0.05, 0, 0, 0.05, 0.04, 0, 0.05, 0.04, 0.03, 0.05, 0.04, 0.03;
  nu << 0.5, 0, 0, 0.5, 0.4, 0, 0.5, 0.4, 0.3, 0.5, 0.4, 0.3;
  Eigen::VectorXi last(4);
  last << 0, 1, 2, 2;
  tendyn::TendonModel lossy;
  expect(tendyn::make_tendon_model(K, r_m, floors, lossy, last, tau0, nu).empty(), "the lossy finger builds");
  tendyn::TendonData ld = tendyn::make_tendon_data(lossy);
  tau << 0.1, -0.05, 0.02;
  qd << 0.3, -0.2, 0.5;
  tendyn::tendon_feedforward(lossy, tau, qd, ld);
  double worst_eq = 0.0, worst_balance = 0.0, lowest = 1e300;
  counting::count = 0;
  counting::armed = true;
  for (long k = 0; k < cycles; ++k) {
    const double s = 1e-3 * static_cast<double>(k % 1000);
    tau << 0.2 * std::sin(7.0 * s), -0.15 * std::cos(3.0 * s), 0.05 * std::sin(11.0 * s + 1.0);
    qd << std::cos(s), std::sin(2.0 * s) - 0.3, -0.5 + s;
    if (tendyn::tendon_feedforward(lossy, tau, qd, ld) != tendyn::Status::Ok) ++fails;
    if (k % 97 != 0) continue;
    counting::armed = false;
    double dissipated = 0.0, motor_power = 0.0;
    for (int i = 0; i < 4; ++i) {
      double sdot = 0.0;  // Ṡ_ib = Σ_{l ≥ b} K_il q̇_l, written here again
      for (int b = last[i]; b >= 0; --b) {
        sdot += K(i, b) * qd[b];
        dissipated += tau0(i, b) * std::abs(sdot) + nu(i, b) * sdot * sdot;
      }
      motor_power += ld.motor_torque[i] * sdot / r_m[i];  // q̇_m = ℓ̇ / r_m, ℓ̇ = Ṡ_i0
      for (int b = 0; b <= last[i]; ++b) lowest = std::min(lowest, ld.tension_joint(i, b) - floors[i]);
      lowest = std::min(lowest, ld.tension[i] - floors[i]);
    }
    for (int j = 0; j < 3; ++j) {
      double tj = 0.0;
      for (int i = 0; i < 4; ++i) tj += K(i, j) * ld.tension_joint(i, j);
      worst_eq = std::max(worst_eq, std::abs(tj - tau[j]));
    }
    worst_balance = std::max(worst_balance, std::abs(motor_power - tau.dot(qd) - dissipated));
    counting::armed = true;
  }
  counting::armed = false;
  std::printf("tendon_feedforward with losses: %ld allocations; joint equilibrium <= %.3g N m, power balance <= %.3g "
              "W, min(t - t_min) over every point = %.3g N\n", counting::count, worst_eq, worst_balance, lowest);
  expect(counting::count == 0, "no allocation with losses");
  expect(worst_eq < 1e-12, "joint equilibrium with the tensions at each joint (S0 eq. 4)");
  expect(worst_balance < 1e-12, "motor power = joint power + branch dissipation");
  expect(std::abs(lowest) < 1e-9, "every point of every tendon >= its floor, one on it");
  // with β = 0.05 on every branch too (S0 eq. 11): the piecewise-linear solve allocates nothing, converges on every
  // call of the same sweep and delivers the joint torques
  Eigen::MatrixXd beta = (tau0.array() > 0.0).cast<double>() * 0.05;
  tendyn::TendonModel lossy_beta;
  expect(tendyn::make_tendon_model(K, r_m, floors, lossy_beta, last, tau0, nu, beta).empty(), "β finger builds");
  tendyn::TendonData bd = tendyn::make_tendon_data(lossy_beta);
  tendyn::tendon_feedforward(lossy_beta, tau, qd, bd);
  double worst_beta = 0.0;
  long not_ok = 0;
  int most_steps = 0;
  counting::count = 0;
  counting::armed = true;
  for (long k = 0; k < cycles / 10; ++k) {
    const double s = 1e-2 * static_cast<double>(k % 100);
    tau << 0.2 * std::sin(7.0 * s), -0.15 * std::cos(3.0 * s), 0.05 * std::sin(11.0 * s + 1.0);
    qd << std::cos(s), std::sin(2.0 * s) - 0.3, -0.5 + s;
    if (tendyn::tendon_feedforward(lossy_beta, tau, qd, bd) != tendyn::Status::Ok) ++not_ok;
    most_steps = std::max(most_steps, bd.iterations);
    for (int j = 0; j < 3; ++j) {
      double tj = 0.0;
      for (int i = 0; i < 4; ++i) tj += K(i, j) * bd.tension_joint(i, j);
      worst_beta = std::max(worst_beta, std::abs(tj - tau[j]));
    }
  }
  counting::armed = false;
  std::printf("tendon_feedforward with beta = 0.05: %ld allocations, %ld not converged, <= %d Newton steps, joint "
              "equilibrium <= %.3g N m\n", counting::count, not_ok, most_steps, worst_beta);
  expect(counting::count == 0, "no allocation with beta");
  expect(not_ok == 0, "beta: every call converges");
  expect(worst_beta < 1e-12, "beta: joint equilibrium (S0 eq. 4)");
  // mean time per call (printed, not asserted: the machine is shared)
  {
    const auto t0 = std::chrono::steady_clock::now();
    double sink = 0.0;
    for (long k = 0; k < cycles; ++k) {
      tau[0] = 1e-6 * static_cast<double>(k % 1000);
      tendyn::tendon_feedforward(model, tau, data);
      sink += data.tension[0];
    }
    const auto t1 = std::chrono::steady_clock::now();
    for (long k = 0; k < cycles; ++k) {
      tau[0] = 1e-6 * static_cast<double>(k % 1000);
      tendyn::tendon_feedforward(lossy, tau, qd, ld);
      sink += ld.tension[0];
    }
    const auto t2 = std::chrono::steady_clock::now();
    const double per = 1e9 / static_cast<double>(cycles);
    std::printf("mean per call (n = 3, m = 4): lossless %.1f ns, with losses %.1f ns (checksum %.3g)\n",
                std::chrono::duration<double>(t1 - t0).count() * per,
                std::chrono::duration<double>(t2 - t1).count() * per, sink);
  }
  // the motor torques are R_m t
  expect((data.motor_torque - r_m.cwiseProduct(data.tension)).cwiseAbs().maxCoeff() < 1e-15, "C_m = R_m t");
  // errors: NaN input, wrong size
  tau(0) = NAN;
  expect(tendyn::tendon_feedforward(model, tau, data) == tendyn::Status::NonFiniteInput, "NaN refused");
  Eigen::VectorXd tau2(2);
  tau2.setZero();
  expect(tendyn::tendon_feedforward(model, tau2, data) == tendyn::Status::SizeMismatch, "size refused");
  // the extensor wound like a flexor on joint 1: h is no longer > 0
  Eigen::MatrixXd bad = K;
  bad(3, 0) = 0.010;
  tendyn::TendonModel out;
  std::string why = tendyn::make_tendon_model(bad, r_m, floors, out);
  expect(why.find("no tension closure") != std::string::npos, "no closure refused");
  // two flexors equal: rank 2
  bad = K;
  bad.row(1) = K.row(0);
  bad.row(2) = K.row(0);
  why = tendyn::make_tendon_model(bad, r_m, floors, out);
  expect(why.find("rank") != std::string::npos, "rank deficiency refused");
  std::printf(fails ? "FAILED (%d)\n" : "ok\n", fails);
  return fails ? 1 : 0;
}

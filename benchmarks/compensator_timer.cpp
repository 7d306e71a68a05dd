// `make bench` helper: one L-EXOS compensator cycle (velocity estimate + gravity + losses) through the C ABI,
// against a plain C++ Eigen implementation of the same cycle, in the same run.
// Usage: compensator_timer COMP_FILE CALLS SEED
// Prints one JSON object: tendyn mean (batch timing: CALLS cycles timed as one block), median and p99.9
// (every cycle timed on its own, steady_clock overhead included), the same for the Eigen baseline, and the
// largest difference between the two outputs (they must agree).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "tendyn/c_api.h"
#include "plain_eigen_statics.hpp"
#include "tendyn/compensator_file.hpp"  // setup only: the baseline reads its numbers from the same file

namespace {

/// The same cycle written plainly with Eigen: dynamic matrices, homogeneous transforms, temporaries.
struct PlainEigenCompensator {
  int n;
  bench::PlainEigenStatics statics;  // the losses (benchmarks/plain_eigen_statics.hpp)
  Eigen::MatrixXd K, Jm2j, Mt;  // K, K^-1 R_m, R_m K^-T
  Eigen::VectorXd r_m;
  std::vector<Eigen::Matrix4d> placement;
  std::vector<Eigen::Vector3d> com;
  Eigen::VectorXd mass;
  Eigen::Vector3d g;
  double k, band, alpha, rate;
  Eigen::VectorXd qm_prev, qdm;
  bool first = true;

  explicit PlainEigenCompensator(const tendyn::CompensatorModel& m) : statics(m.transmission) {
    const auto& t = m.transmission;
    n = t.n;
    K = t.K; r_m = t.motor_radius;
    Jm2j = K.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd(r_m.asDiagonal()));
    Mt = r_m.asDiagonal() * K.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n)).transpose();
    for (int j = 0; j < n; ++j) {
      Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
      T.topLeftCorner<3, 3>() = m.chain.rotation[j];
      T.topRightCorner<3, 1>() = m.chain.translation[j];
      placement.push_back(T);
      com.push_back(m.chain.com[j]);
    }
    mass = m.chain.mass; g = m.chain.gravity;
    k = m.underestimation; band = m.velocity_band; alpha = m.filter_gain(); rate = m.rate_hz;
    qm_prev = Eigen::VectorXd::Zero(n); qdm = Eigen::VectorXd::Zero(n);
  }

  Eigen::VectorXd cycle(const Eigen::VectorXd& qm, const Eigen::VectorXd& tau_wanted) {
    if (first) { qm_prev = qm; first = false; }
    qdm += alpha * ((qm - qm_prev) * rate - qdm);
    qm_prev = qm;
    const Eigen::VectorXd q = Jm2j * qm, qd = Jm2j * qdm;
    // gravity: g = -sum_k J_com,k^T m_k g (serial chain, revolute about z of each joint frame)
    std::vector<Eigen::Matrix4d> T(n);
    Eigen::Matrix4d acc = Eigen::Matrix4d::Identity();
    for (int j = 0; j < n; ++j) {
      Eigen::Matrix4d rz = Eigen::Matrix4d::Identity();
      rz(0, 0) = std::cos(q(j)); rz(0, 1) = -std::sin(q(j)); rz(1, 0) = std::sin(q(j)); rz(1, 1) = std::cos(q(j));
      acc = acc * placement[j] * rz;
      T[j] = acc;
    }
    Eigen::VectorXd grav = Eigen::VectorXd::Zero(n);
    for (int kk = 0; kk < n; ++kk) {
      const Eigen::Vector3d c = T[kk].topLeftCorner<3, 3>() * com[kk] + T[kk].topRightCorner<3, 1>();
      for (int j = 0; j <= kk; ++j) {
        const Eigen::Vector3d z = T[j].block<3, 1>(0, 2), o = T[j].topRightCorner<3, 1>();
        grav(j) -= z.cross(c - o).dot(mass(kk) * g);
      }
    }
    const Eigen::VectorXd tau = tau_wanted + grav;
    const Eigen::VectorXd c0 = Mt * tau;
    const Eigen::VectorXd cff = statics.feedforward(tau, qd);  // statics with losses
    Eigen::VectorXd out(n);
    for (int i = 0; i < n; ++i) {
      const double w = band > 0 ? std::min(1.0, std::abs(qdm(i)) / band) : 1.0;
      out(i) = c0(i) + k * w * (cff(i) - c0(i));
    }
    return out;
  }
};

double quantile(std::vector<double>& v, double q) {  // linear interpolation, as numpy.percentile
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s COMP_FILE CALLS SEED\n", argv[0]);
    return 2;
  }
  const long calls = std::atol(argv[2]);
  char message[512];
  tendyn_compensator* comp = nullptr;
  if (tendyn_compensator_load(argv[1], nullptr, &comp, message, sizeof message) != TENDYN_OK) {
    std::fprintf(stderr, "%s\n", message);
    return 1;
  }
  tendyn::CompensatorModel model;
  std::string error;
  tendyn::load_compensator_model(argv[1], "", &model, &error);
  const int n = tendyn_compensator_size(comp);
  std::mt19937_64 rng(std::strtoull(argv[3], nullptr, 10));
  std::normal_distribution<double> normal(0.0, 1.0);
  // encoder readings: smooth motion (tens of rad/s at the motor) plus quantisation-sized noise
  std::vector<double> qm(static_cast<std::size_t>(n * calls)), tj(static_cast<std::size_t>(n * calls));
  for (long c = 0; c < calls; ++c)
    for (int i = 0; i < n; ++i) {
      const double t = static_cast<double>(c) / model.rate_hz;
      qm[c * n + i] = 3.0 * std::sin(2.0 * 3.141592653589793 * (0.3 + 0.17 * i) * t) + 4e-4 * normal(rng);
      tj[c * n + i] = normal(rng);
    }
  std::vector<double> out(static_cast<std::size_t>(n)), ns(static_cast<std::size_t>(calls));
  double checksum = 0.0;
  // tendyn through the C ABI: batch timing (mean), then per-call timing (median, tail)
  auto t0 = std::chrono::steady_clock::now();
  for (long c = 0; c < calls; ++c) {
    tendyn_compensator_cycle(comp, &qm[c * n], &tj[c * n], out.data(), nullptr);
    checksum += out[0];
  }
  const double mean_ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / calls;
  tendyn_compensator_reset(comp);
  double reported = 0.0;
  for (long c = 0; c < calls; ++c) {
    const auto a = std::chrono::steady_clock::now();
    tendyn_compensator_cycle(comp, &qm[c * n], &tj[c * n], out.data(), nullptr);
    const auto b = std::chrono::steady_clock::now();
    ns[c] = std::chrono::duration<double, std::nano>(b - a).count();
    checksum += out[0];
  }
  tendyn_compensator_reset(comp);
  double compute_time = 0.0;
  for (long c = 0; c < std::min(calls, 100000L); ++c) {
    tendyn_compensator_cycle(comp, &qm[c * n], &tj[c * n], out.data(), &compute_time);
    reported += compute_time;
  }
  reported /= static_cast<double>(std::min(calls, 100000L));
  std::vector<double> ns_copy = ns;
  const double median = quantile(ns_copy, 0.5), p999 = quantile(ns, 0.999);

  // plain Eigen baseline, same inputs; check agreement on the way
  tendyn_compensator_reset(comp);
  PlainEigenCompensator base(model);
  double max_diff = 0.0;
  for (long c = 0; c < std::min(calls, 20000L); ++c) {
    tendyn_compensator_cycle(comp, &qm[c * n], &tj[c * n], out.data(), nullptr);
    const Eigen::VectorXd e = base.cycle(Eigen::Map<const Eigen::VectorXd>(&qm[c * n], n),
                                         Eigen::Map<const Eigen::VectorXd>(&tj[c * n], n));
    for (int i = 0; i < n; ++i) max_diff = std::max(max_diff, std::abs(e(i) - out[i]));
  }
  PlainEigenCompensator base2(model);
  t0 = std::chrono::steady_clock::now();
  for (long c = 0; c < calls; ++c)
    checksum += base2.cycle(Eigen::Map<const Eigen::VectorXd>(&qm[c * n], n),
                            Eigen::Map<const Eigen::VectorXd>(&tj[c * n], n))(0);
  const double base_mean = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / calls;
  PlainEigenCompensator base3(model);
  for (long c = 0; c < calls; ++c) {
    const auto a = std::chrono::steady_clock::now();
    const Eigen::VectorXd e = base3.cycle(Eigen::Map<const Eigen::VectorXd>(&qm[c * n], n),
                                          Eigen::Map<const Eigen::VectorXd>(&tj[c * n], n));
    const auto b = std::chrono::steady_clock::now();
    ns[c] = std::chrono::duration<double, std::nano>(b - a).count();
    checksum += e(0);
  }
  ns_copy = ns;
  const double base_median = quantile(ns_copy, 0.5), base_p999 = quantile(ns, 0.999);
  tendyn_compensator_destroy(comp);
  std::printf("{\"calls\": %ld, \"mean_ns\": %.6g, \"median_ns\": %.6g, \"p999_ns\": %.6g, "
              "\"reported_compute_time_ns\": %.6g, \"eigen_mean_ns\": %.6g, \"eigen_median_ns\": %.6g, "
              "\"eigen_p999_ns\": %.6g, \"max_abs_diff\": %.3g, \"checksum\": %.17g}\n",
              calls, mean_ns, median, p999, 1e9 * reported, base_mean, base_median, base_p999, max_diff, checksum);
  return 0;
}

// `make bench` helper: the real-time feedforward motor_torque_feedforward (L-EXOS model file) against a plain
// C++ Eigen implementation of the same statics (benchmarks/plain_eigen_statics.hpp), in the same process.
// Usage: feedforward_timer MODEL_FILE CALLS SEED [ROUNDS]
// Loads the model file exported by Python (Transmission.export), draws CALLS seeded random inputs
// (joint torques ~ 5 N(0, 1) N·m, joint velocities ~ N(0, 1) rad/s) and prints one JSON object:
//   mean_ns            the mean per call: CALLS calls timed as one batch (one timer around the whole loop,
//                      thread CPU time), median over ROUNDS rounds (tendyn and Eigen interleaved per round)
//   mean_wall_ns       the same batches on the steady clock
//   median_ns, p999_ns every call timed on its own (two steady_clock reads around it): only for the tail;
//                      the pair of clock reads is included (timer_overhead_ns is its median alone)
//   eigen_*            the same for the plain Eigen baseline
//   max_rel_diff       the largest |C_m(core) − C_m(Eigen)| / max(1, |C_m|) over the first 100k calls;
//                      the timer fails (exit 1) above 1e-12
// Built only for `make bench`.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "plain_eigen_statics.hpp"
#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"

namespace {

double thread_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e9 * static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec);
}

double quantile(std::vector<double> v, double q) {  // linear interpolation, as numpy.percentile
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double median(std::vector<double> v) { return quantile(std::move(v), 0.5); }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4 && argc != 5) {
    std::fprintf(stderr, "usage: %s MODEL_FILE CALLS SEED [ROUNDS]\n", argv[0]);
    return 2;
  }
  tendyn::TransmissionModel model;
  std::string error;
  if (!tendyn::load_transmission_model(argv[1], &model, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  const long calls = std::atol(argv[2]);
  const int rounds = argc == 5 ? std::atoi(argv[4]) : 7;
  if (calls < 1 || rounds < 1) {
    std::fprintf(stderr, "CALLS and ROUNDS must be >= 1\n");
    return 2;
  }
  if (bench::PlainEigenStatics::has_bearings(model)) {
    std::fprintf(stderr, "the Eigen baseline leaves bearings out: give a model without bearings\n");
    return 2;
  }
  tendyn::TransmissionData data(model);
  const bench::PlainEigenStatics base(model);
  const int n = model.n;
  std::mt19937_64 rng(std::strtoull(argv[3], nullptr, 10));
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd tau(n, calls), qd(n, calls);  // columns = calls
  for (long k = 0; k < calls; ++k)
    for (int i = 0; i < n; ++i) {
      tau(i, k) = 5.0 * normal(rng);
      qd(i, k) = normal(rng);
    }
  // the two implementations agree before anything is timed
  double max_rel = 0.0;
  Eigen::VectorXd tk(n), vk(n);
  for (long k = 0; k < std::min(calls, 100000L); ++k) {
    if (tendyn::is_error(tendyn::motor_torque_feedforward(model, data, tau.col(k), qd.col(k)))) {
      std::fprintf(stderr, "call %ld returned an error status\n", k);
      return 1;
    }
    tk = tau.col(k);
    vk = qd.col(k);
    const Eigen::VectorXd e = base.feedforward(tk, vk);
    for (int i = 0; i < n; ++i)
      max_rel = std::max(max_rel, std::abs(e(i) - data.torque_motor(i)) / std::max(1.0, std::abs(e(i))));
  }
  if (!(max_rel <= 1e-12)) {
    std::fprintf(stderr, "the Eigen baseline disagrees with the core: max relative difference %.3g > 1e-12\n", max_rel);
    return 1;
  }

  double checksum = 0.0;  // keeps every call observable
  auto core_batch = [&](double* wall) {
    const auto w0 = std::chrono::steady_clock::now();
    const double t0 = thread_ns();
    for (long k = 0; k < calls; ++k) {
      tendyn::motor_torque_feedforward(model, data, tau.col(k), qd.col(k));
      checksum += data.torque_motor(0);
    }
    const double t1 = thread_ns();
    *wall = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - w0).count() / calls;
    return (t1 - t0) / calls;
  };
  auto eigen_batch = [&](double* wall) {
    const auto w0 = std::chrono::steady_clock::now();
    const double t0 = thread_ns();
    for (long k = 0; k < calls; ++k) {
      tk = tau.col(k);
      vk = qd.col(k);
      checksum += base.feedforward(tk, vk)(0);
    }
    const double t1 = thread_ns();
    *wall = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - w0).count() / calls;
    return (t1 - t0) / calls;
  };
  std::vector<double> core_mean, core_wall, eig_mean, eig_wall;
  for (int r = 0; r < rounds; ++r) {  // interleaved rounds
    double w = 0.0;
    core_mean.push_back(core_batch(&w));
    core_wall.push_back(w);
    eig_mean.push_back(eigen_batch(&w));
    eig_wall.push_back(w);
  }

  // per-call timing, for the tail only (the pair of clock reads is in every sample)
  std::vector<double> ns(static_cast<std::size_t>(calls)), ens(static_cast<std::size_t>(calls)),
      empty(static_cast<std::size_t>(std::min(calls, 100000L)));
  for (long k = 0; k < calls; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    tendyn::motor_torque_feedforward(model, data, tau.col(k), qd.col(k));
    const auto t1 = std::chrono::steady_clock::now();
    checksum += data.torque_motor(0);
    ns[static_cast<std::size_t>(k)] = std::chrono::duration<double, std::nano>(t1 - t0).count();
  }
  for (long k = 0; k < calls; ++k) {
    tk = tau.col(k);
    vk = qd.col(k);
    const auto t0 = std::chrono::steady_clock::now();
    checksum += base.feedforward(tk, vk)(0);
    const auto t1 = std::chrono::steady_clock::now();
    ens[static_cast<std::size_t>(k)] = std::chrono::duration<double, std::nano>(t1 - t0).count();
  }
  for (std::size_t k = 0; k < empty.size(); ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto t1 = std::chrono::steady_clock::now();
    empty[k] = std::chrono::duration<double, std::nano>(t1 - t0).count();
  }
  std::printf("{\"calls\": %ld, \"rounds\": %d, \"mean_ns\": %.6g, \"mean_wall_ns\": %.6g, \"median_ns\": %.6g, "
              "\"p999_ns\": %.6g, \"timer_overhead_ns\": %.6g, \"eigen_mean_ns\": %.6g, \"eigen_mean_wall_ns\": %.6g, "
              "\"eigen_median_ns\": %.6g, \"eigen_p999_ns\": %.6g, \"max_rel_diff\": %.3g, \"checksum\": %.17g}\n",
              calls, rounds, median(core_mean), median(core_wall), quantile(ns, 0.5), quantile(ns, 0.999),
              median(empty), median(eig_mean), median(eig_wall), quantile(ens, 0.5), quantile(ens, 0.999), max_rel,
              checksum);
  return 0;
}

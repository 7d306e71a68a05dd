// `make bench` helper: time each motor_torque_feedforward call on its own (steady_clock, overhead included).
// Usage: feedforward_timer MODEL_FILE CALLS SEED
// Loads the model file exported by Python (Transmission.export), draws CALLS seeded random inputs
// (joint torques ~ 5 N(0, 1) N·m, joint velocities ~ N(0, 1) rad/s), times every call and prints one JSON
// object: {"calls": …, "median_ns": …, "p999_ns": …, "checksum": …}. Built only for `make bench`.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s MODEL_FILE CALLS SEED\n", argv[0]);
    return 2;
  }
  tendyn::TransmissionModel model;
  std::string error;
  if (!tendyn::load_transmission_model(argv[1], &model, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  const long calls = std::atol(argv[2]);
  if (calls < 1) {
    std::fprintf(stderr, "CALLS must be >= 1\n");
    return 2;
  }
  tendyn::TransmissionData data(model);
  const int n = model.n;
  std::mt19937_64 rng(std::strtoull(argv[3], nullptr, 10));
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd tau(n, calls), qd(n, calls);  // columns = calls
  for (long k = 0; k < calls; ++k)
    for (int i = 0; i < n; ++i) {
      tau(i, k) = 5.0 * normal(rng);
      qd(i, k) = normal(rng);
    }
  std::vector<double> ns(static_cast<std::size_t>(calls));
  double checksum = 0.0;
  long errors = 0;
  for (long k = 0; k < calls; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const tendyn::Status s = tendyn::motor_torque_feedforward(model, data, tau.col(k), qd.col(k));
    const auto t1 = std::chrono::steady_clock::now();
    if (tendyn::is_error(s)) ++errors;
    checksum += data.torque_motor(0);  // keeps the calls observable
    ns[static_cast<std::size_t>(k)] = std::chrono::duration<double, std::nano>(t1 - t0).count();
  }
  if (errors) {
    std::fprintf(stderr, "%ld calls returned an error status\n", errors);
    return 1;
  }
  std::sort(ns.begin(), ns.end());
  auto quantile = [&](double q) {  // linear interpolation, as numpy.percentile
    const double pos = q * static_cast<double>(calls - 1);
    const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
    const std::size_t hi = std::min(lo + 1, ns.size() - 1);
    return ns[lo] + (pos - static_cast<double>(lo)) * (ns[hi] - ns[lo]);
  };
  std::printf("{\"calls\": %ld, \"median_ns\": %.6g, \"p999_ns\": %.6g, \"checksum\": %.17g}\n", calls,
              quantile(0.5), quantile(0.999), checksum);
  return 0;
}

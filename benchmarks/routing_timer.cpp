// `make bench` helper (issue 19): the real-time feedforward with losses of a general routing (a differential
// device: coupled blocks of K solved by the Newton iteration of losses.hpp) against the serial L-EXOS feedforward
// (S0's recursion), both timed in the same process, interleaved.
// Usage: routing_timer SERIAL_MODEL GENERAL_MODEL CALLS SEED [ROUNDS]
// Draws CALLS seeded random inputs per model (joint torques ~ 5 N(0, 1) N·m, joint velocities ~ N(0, 1) rad/s),
// times CALLS calls as one batch (thread CPU time) per round and prints one JSON object with the medians over
// the rounds: serial_mean_ns, general_mean_ns, general_iterations_mean (Newton steps per call, all blocks: only the
// 2x2 blocks whose table pattern failed its check take any) and general_pair_fallbacks_mean (such 2x2 blocks per
// call).
// Every call of the general model is checked first: no error status, no NotConverged, and the joint torques
// the forward statics give back from the motor torques equal the wanted ones (the two directions are exact
// inverses while every branch slides); the timer fails (exit 1) otherwise.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "thread_timer.hpp"
#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"

namespace {

using bench::median;
using bench::thread_ns;

struct Case {
  tendyn::TransmissionModel model;
  Eigen::MatrixXd tau, qd;
};

bool load(const char* path, long calls, std::mt19937_64& rng, Case* c) {
  std::string error;
  if (!tendyn::load_transmission_model(path, &c->model, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return false;
  }
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = c->model.n;
  c->tau.resize(n, calls);
  c->qd.resize(n, calls);
  for (long k = 0; k < calls; ++k)
    for (int i = 0; i < n; ++i) {
      c->tau(i, k) = 5.0 * normal(rng);
      c->qd(i, k) = normal(rng);
    }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5 && argc != 6) {
    std::fprintf(stderr, "usage: %s SERIAL_MODEL GENERAL_MODEL CALLS SEED [ROUNDS]\n", argv[0]);
    return 2;
  }
  const long calls = std::atol(argv[3]);
  const int rounds = argc == 6 ? std::atoi(argv[5]) : 7;
  if (calls < 1 || rounds < 1) return 2;
  std::mt19937_64 rng(std::strtoull(argv[4], nullptr, 10));
  Case serial, general;
  if (!load(argv[1], calls, rng, &serial) || !load(argv[2], calls, rng, &general)) return 1;
  if (!serial.model.serial || general.model.serial) {
    std::fprintf(stderr, "the first model must be serial, the second not\n");
    return 2;
  }
  tendyn::TransmissionData ds(serial.model), dg(general.model), check(general.model);
  long iterations = 0, fallbacks = 0;
  double worst = 0.0;
  for (long k = 0; k < std::min(calls, 100000L); ++k) {
    const tendyn::Status s = tendyn::motor_torque_feedforward(general.model, dg, general.tau.col(k), general.qd.col(k));
    if (s != tendyn::Status::Ok) {
      std::fprintf(stderr, "call %ld: %s\n", k, tendyn::status_message(s));
      return 1;
    }
    iterations += dg.block_iterations;
    fallbacks += dg.pair_fallbacks;
    const Eigen::VectorXd cm = dg.torque_motor;
    tendyn::joint_torque_forward(general.model, check, cm, general.qd.col(k));
    for (int i = 0; i < general.model.n; ++i)
      worst = std::max(worst, std::abs(check.torque_joint(i) - general.tau(i, k)) / std::max(1.0, std::abs(general.tau(i, k))));
  }
  if (!(worst <= 1e-9)) {
    std::fprintf(stderr, "forward(feedforward(tau)) != tau: max relative difference %.3g\n", worst);
    return 1;
  }
  double checksum = 0.0;
  auto batch = [&](Case& c, tendyn::TransmissionData& d) {
    const double t0 = thread_ns();
    for (long k = 0; k < calls; ++k) {
      tendyn::motor_torque_feedforward(c.model, d, c.tau.col(k), c.qd.col(k));
      checksum += d.torque_motor(0);
    }
    return (thread_ns() - t0) / static_cast<double>(calls);
  };
  std::vector<double> ts, tg;
  for (int r = 0; r < rounds; ++r) {
    ts.push_back(batch(serial, ds));
    tg.push_back(batch(general, dg));
  }
  std::printf("{\"calls\": %ld, \"rounds\": %d, \"serial_n\": %d, \"general_n\": %d, \"serial_mean_ns\": %.6g, "
              "\"general_mean_ns\": %.6g, \"general_iterations_mean\": %.6g, \"general_pair_fallbacks_mean\": %.6g, "
              "\"max_rel_roundtrip\": %.3g, \"checksum\": %.17g}\n",
              calls, rounds, serial.model.n, general.model.n, median(ts), median(tg),
              static_cast<double>(iterations) / static_cast<double>(std::min(calls, 100000L)),
              static_cast<double>(fallbacks) / static_cast<double>(std::min(calls, 100000L)), worst, checksum);
  return 0;
}

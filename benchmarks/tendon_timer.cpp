// `make bench` helper (issue 19): the real-time feedforward of an N+1 tendon routing (include/tendyn/tendons.hpp:
// minimum-norm tensions + λ h ≥ the floors, S0 eq. 12 losses along every tendon), lossless and with losses, timed
// in the same process, interleaved.
// Usage: tendon_timer MODEL.txt CALLS SEED TORQUE_SCALE [ROUNDS]
// MODEL.txt (written by benchmarks/run.py from tendyn.tendons.Tendons): "n m", then K (m rows of n) [m],
// motor_radius (m) [m], tension_min (m) [N], last_joint (m, 0-based), tau0 (m rows of n) [N], nu (m rows of n)
// [N·s/m], whitespace separated. Draws CALLS seeded inputs (joint torques ~ TORQUE_SCALE N(0, 1) N·m, joint
// velocities ~ N(0, 1) rad/s), times CALLS calls as one batch (thread CPU time) per round and prints one JSON
// object with the medians over the rounds: lossless_mean_ns, lossy_mean_ns. Every call is checked first: status
// Ok, the tensions at each joint deliver the wanted joint torques (Σ_i K_ij T_ij = τ_j), every tension at or
// above its floor; the timer fails (exit 1) otherwise.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "thread_timer.hpp"
#include "tendyn/tendons.hpp"

namespace {

using bench::median;
using bench::thread_ns;

bool read_model(const char* path, tendyn::TendonModel* model) {
  std::ifstream in(path);
  int n = 0, m = 0;
  if (!(in >> n >> m) || n < 1 || m != n + 1) return false;
  Eigen::MatrixXd K(m, n), tau0(m, n), nu(m, n);
  Eigen::VectorXd radius(m), floor(m);
  Eigen::VectorXi last(m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) in >> K(i, j);
  for (int i = 0; i < m; ++i) in >> radius[i];
  for (int i = 0; i < m; ++i) in >> floor[i];
  for (int i = 0; i < m; ++i) in >> last[i];
  for (auto* a : {&tau0, &nu})
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j) in >> (*a)(i, j);
  if (!in) return false;
  const std::string error = tendyn::make_tendon_model(K, radius, floor, *model, last, tau0, nu);
  if (!error.empty()) std::fprintf(stderr, "%s: %s\n", path, error.c_str());
  return error.empty();
}

// the worst of |Σ_i K_ij T_ij − τ_j| / max(1, |τ_j|) and of (floor − T_ij) / max(1, floor) over the call
double check(const tendyn::TendonModel& model, const tendyn::TendonData& d, const Eigen::VectorXd& tau) {
  double worst = 0.0;
  for (int j = 0; j < model.n; ++j) {
    double s = 0.0;
    for (int i = 0; i < model.m; ++i)
      if (j <= model.last_joint[i]) {
        s += model.K(i, j) * d.tension_joint(i, j);
        worst = std::max(worst, (model.tension_min[i] - d.tension_joint(i, j)) / std::max(1.0, model.tension_min[i]));
      }
    worst = std::max(worst, std::abs(s - tau[j]) / std::max(1.0, std::abs(tau[j])));
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5 && argc != 6) {
    std::fprintf(stderr, "usage: %s MODEL.txt CALLS SEED TORQUE_SCALE [ROUNDS]\n", argv[0]);
    return 2;
  }
  tendyn::TendonModel model;
  if (!read_model(argv[1], &model)) {
    std::fprintf(stderr, "%s: not a tendon model file\n", argv[1]);
    return 2;
  }
  const long calls = std::atol(argv[2]);
  const double scale = std::atof(argv[4]);
  const int rounds = argc == 6 ? std::atoi(argv[5]) : 7;
  if (calls < 1 || rounds < 1 || !(scale > 0.0)) return 2;
  std::mt19937_64 rng(std::strtoull(argv[3], nullptr, 10));
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = model.n;
  Eigen::MatrixXd tau(n, calls), qd(n, calls);
  for (long k = 0; k < calls; ++k)
    for (int j = 0; j < n; ++j) {
      tau(j, k) = scale * normal(rng);
      qd(j, k) = normal(rng);
    }
  tendyn::TendonData d = tendyn::make_tendon_data(model);
  double worst = 0.0;
  for (long k = 0; k < std::min(calls, 100000L); ++k) {
    const Eigen::VectorXd t = tau.col(k);
    for (int lossy = 0; lossy < 2; ++lossy) {
      const tendyn::Status s = lossy ? tendyn::tendon_feedforward(model, tau.col(k), qd.col(k), d)
                                     : tendyn::tendon_feedforward(model, tau.col(k), d);
      if (s != tendyn::Status::Ok) {
        std::fprintf(stderr, "call %ld: %s\n", k, tendyn::status_message(s));
        return 1;
      }
      worst = std::max(worst, check(model, d, t));
    }
  }
  if (!(worst <= 1e-9)) {
    std::fprintf(stderr, "torques not delivered or a tension below its floor: worst %.3g\n", worst);
    return 1;
  }
  double checksum = 0.0;
  auto batch = [&](bool lossy) {
    const double t0 = thread_ns();
    for (long k = 0; k < calls; ++k) {
      if (lossy)
        tendyn::tendon_feedforward(model, tau.col(k), qd.col(k), d);
      else
        tendyn::tendon_feedforward(model, tau.col(k), d);
      checksum += d.motor_torque(0);
    }
    return (thread_ns() - t0) / static_cast<double>(calls);
  };
  std::vector<double> t_lossless, t_lossy;
  for (int r = 0; r < rounds; ++r) {
    t_lossless.push_back(batch(false));
    t_lossy.push_back(batch(true));
  }
  std::printf("{\"calls\": %ld, \"rounds\": %d, \"n\": %d, \"m\": %d, \"lossless_mean_ns\": %.6g, "
              "\"lossy_mean_ns\": %.6g, \"max_rel_check\": %.3g, \"checksum\": %.17g}\n",
              calls, rounds, model.n, model.m, median(t_lossless), median(t_lossy), worst, checksum);
  return 0;
}

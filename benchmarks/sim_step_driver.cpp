// Private timing / profiling driver of the simulator step (issue 12 item 2): reads a simulator model dumped
// by benchmarks/sim_step_profile.py (the L-EXOS twin by default), runs the benchmark's input (10 s at the
// model rate, ff = 0.2 sin(2π f t), f = 0.7, 1.1, 1.3, 1.7 Hz, sensors on, seed 1) and prints
//   * the thread CPU time per step of each repeat [µs], and
//   * (with a trajectory path) q, qd every log_every steps for the trajectory comparison.
// Built twice by the profile script: once against main's headers (old step), once against this tree's.
//   sim_step_driver MODEL.txt TRANSMISSION.model REPEATS [TRAJ_OUT]
#include <time.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tendyn/model_file.hpp"
#include "tendyn/sim.hpp"

static double thread_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char** argv) {
  if (argc < 4) { std::fprintf(stderr, "usage: %s MODEL.txt TRANSMISSION.model REPEATS [TRAJ_OUT]\n", argv[0]); return 2; }
  std::ifstream in(argv[1]);
  std::map<std::string, std::vector<std::vector<double>>> f;  // key -> list of rows (a key may repeat)
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string key;
    if (!(ss >> key)) continue;
    std::vector<double> v;
    double x;
    while (ss >> x) v.push_back(x);
    f[key].push_back(v);
  }
  auto vec = [&](const std::string& k) {
    const auto& r = f.at(k).at(0);
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(r.data(), r.size()));
  };
  tendyn::SimModel m;
  const auto g = f.at("gravity").at(0);
  m.body.set_gravity(Eigen::Vector3d(g[0], g[1], g[2]));
  int jn = 0;
  for (const auto& r : f["joint"]) {  // parent, placement(16 row-major), axis(3), prismatic, mass, com(3), inertia(9)
    Eigen::Matrix4d T;
    for (int a = 0; a < 16; ++a) T(a / 4, a % 4) = r[1 + a];
    Eigen::Matrix3d I;
    for (int a = 0; a < 9; ++a) I(a / 3, a % 3) = r[25 + a];
    m.body.add_joint(static_cast<int>(r[0]), T, Eigen::Vector3d(r[17], r[18], r[19]), r[20] != 0.0, r[21],
                     Eigen::Vector3d(r[22], r[23], r[24]), I, "j" + std::to_string(++jn));
  }
  const auto Ls = f.at("L").at(0);
  const int lr = static_cast<int>(Ls[0]), lc = static_cast<int>(Ls[1]);
  m.L.resize(lr, lc);
  for (int a = 0; a < lr * lc; ++a) m.L(a / lc, a % lc) = Ls[2 + a];
  m.c = vec("c");
  std::string err;
  if (!tendyn::load_transmission_model(argv[2], &m.tendon, &err)) { std::fprintf(stderr, "%s\n", err.c_str()); return 1; }
  m.drive = tendyn::DriveKind::Tendon;
  m.rotor_inertia = vec("rotor_inertia");
  m.torque_constant = vec("torque_constant");
  m.peak_torque = vec("peak_torque");
  m.encoder_counts = vec("encoder_counts");
  m.current_noise = vec("current_noise");
  m.dt = f.at("dt").at(0).at(0);
  m.control_decimation = static_cast<int>(f.at("control_decimation").at(0).at(0));
  if (const char* tol = std::getenv("TENDYN_PGS_TOLERANCE")) m.pgs_tolerance = std::atof(tol);  // experiments
#ifdef TENDYN_HAS_PGS_SPEED_TOLERANCE  // absent from the headers of older refs
  if (const char* v = std::getenv("TENDYN_PGS_SPEED_TOLERANCE")) m.pgs_speed_tolerance = std::atof(v);
#endif
  if (const char* w = std::getenv("TENDYN_PGS_RELAXATION")) m.pgs_relaxation = std::atof(w);
  if (const char* c = std::getenv("TENDYN_PGS_MAX_ITERATIONS")) m.pgs_max_iterations = std::atoi(c);
  if (tendyn::is_error(m.finalize())) { std::fprintf(stderr, "finalize failed\n"); return 1; }
  const Eigen::VectorXd q0 = vec("q0");
  const int na = m.na;
  const char* secs = std::getenv("TENDYN_PROFILE_SECONDS");  // simulated seconds (default 10)
  const long n = std::lround((secs ? std::atof(secs) : 10.0) / m.dt);
  Eigen::MatrixXd ff(n, na);
  const double fr[4] = {0.7, 1.1, 1.3, 1.7};
  // optional "hold" line: constant motor torques added to the sines (the stick-slip test of sim_bench.py)
  const Eigen::VectorXd hold = f.count("hold") ? vec("hold") : Eigen::VectorXd::Zero(na);
  const double amp = f.count("amplitude") ? f.at("amplitude").at(0).at(0) : 0.2;
  for (long s = 0; s < n; ++s)
    for (int i = 0; i < na; ++i) ff(s, i) = hold(i) + amp * std::sin(2 * M_PI * fr[i % 4] * (s * m.dt));
  const Eigen::VectorXd z = Eigen::VectorXd::Zero(na);
  const int repeats = std::atoi(argv[3]);
  FILE* traj = argc > 4 ? std::fopen(argv[4], "w") : nullptr;
  tendyn::SimData d(m);
  long pgs_total = 0, pgs_cap = 0;
  int pgs_max = 0;
  for (int r = 0; r < repeats; ++r) {
    d.reset(q0, 1);
    pgs_total = pgs_cap = 0;
    pgs_max = 0;
    const double t0 = thread_seconds();
    for (long s = 0; s < n; ++s) {
      if (traj && r == 0 && s % m.control_decimation == 0) {
        std::fprintf(traj, "%.17g", d.time);
        for (int i = 0; i < na; ++i) std::fprintf(traj, " %.17g", d.q(i));
        for (int i = 0; i < na; ++i) std::fprintf(traj, " %.17g", d.qd(i));
        std::fprintf(traj, "\n");
      }
      if (tendyn::is_error(tendyn::step(m, d, z, z, ff.row(s).transpose(), z))) { std::fprintf(stderr, "step failed\n"); return 1; }
      pgs_total += d.pgs_iterations;
      pgs_cap += d.pgs_iterations >= m.pgs_max_iterations;
      pgs_max = std::max(pgs_max, d.pgs_iterations);
      if (std::getenv("TENDYN_PROFILE_DEBUG") && r == 0 && d.pgs_iterations >= m.pgs_max_iterations) {
        std::fprintf(stderr, "step %ld:", s);
        for (int k = 0; k < m.n_sites; ++k)
          std::fprintf(stderr, " [%c u=%.1e p=%.2f]", d.p(k) <= d.lo(k) ? 'L' : d.p(k) >= d.hi(k) ? 'H' : 'i', d.u(k),
                       d.p(k) / std::max(d.hi(k), -d.lo(k)));
        std::fprintf(stderr, "\n");
      }
    }
    const double t1 = thread_seconds();
    std::printf("%.6f\n", (t1 - t0) / n * 1e6);
    std::fflush(stdout);
  }
  if (traj) std::fclose(traj);
  std::fprintf(stderr, "sites %d, PGS sweeps: mean %.3f max %d at-cap share %.4f, q(T) %.17g %.17g %.17g %.17g, dissipated %.17g, work %.17g\n",
               m.n_sites, double(pgs_total) / n, pgs_max, double(pgs_cap) / n, d.q(0), d.q(1 % na), d.q(2 % na), d.q(3 % na), d.dissipated, d.work_motor);
  return 0;
}

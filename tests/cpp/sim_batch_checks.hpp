// tendyn::run_batch (include/tendyn/sim_batch.hpp): a batch spread over threads equals the same runs one after
// the other, bit for bit (logs and final states); and the stepping loop allocates nothing (the allocations of
// a batch are those of its thread starts: the same for 200 and for 2000 steps per run).
// Run by `test_sim batch` (CTest: sim_batch). A header of test_sim.cpp, not its own executable: the simulator's
// templates cost ~100 s of compiler CPU per translation unit, paid once for both checks (issue 39).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "counting_malloc.hpp"
#include "sim_test_chain.hpp"
#include "tendyn/sim_batch.hpp"

namespace {

// The shared 3-joint tendon chain; `scale` multiplies tau0 and beta.
tendyn::SimModel batch_chain(double scale) { return three_joint_chain(tendyn::DriveKind::Tendon, scale); }

struct Logs {  // one run's log arrays
  long rows;
  Eigen::VectorXd time;
  tendyn::RowMatrixXd a, b, c, q, qd, qm, qdm;
  explicit Logs(long r, int n)
      : rows(r), time(Eigen::VectorXd::Zero(r)), a(r, n), b(r, n), c(r, n), q(r, n), qd(r, n), qm(r, n), qdm(r, n) {}
  tendyn::SimLog log() { return tendyn::SimLog{time, a, b, c, q, qd, qm, qdm}; }
  bool same(const Logs& o) const {
    auto eq = [](const auto& x, const auto& y) {
      return std::memcmp(x.data(), y.data(), sizeof(double) * static_cast<std::size_t>(x.size())) == 0;
    };
    return eq(time, o.time) && eq(a, o.a) && eq(b, o.b) && eq(c, o.c) && eq(q, o.q) && eq(qd, o.qd) && eq(qm, o.qm) &&
           eq(qdm, o.qdm);
  }
};

struct Batch {
  std::vector<tendyn::SimModel> models;
  std::vector<tendyn::SimData> datas;
  std::vector<tendyn::RowMatrixXd> ff;
  tendyn::RowMatrixXd zero;
  std::vector<Logs> logs;
  std::vector<tendyn::BatchRun> runs;
  Batch(int count, long steps) {
    for (int k = 0; k < count; ++k) {
      models.push_back(batch_chain(0.5 + 0.25 * k));
      models.back().finalize();
    }
    zero = tendyn::RowMatrixXd::Zero(steps, 3);
    for (int k = 0; k < count; ++k) {
      datas.emplace_back(models[k]);
      datas.back().reset(Eigen::VectorXd::Constant(3, 0.1 * k), 7 + k);
      ff.push_back(tendyn::RowMatrixXd(steps, 3));
      for (long s = 0; s < steps; ++s)
        for (int i = 0; i < 3; ++i) ff.back()(s, i) = 0.05 * (1 + k) * std::sin(0.001 * (i + 1) * s);
      logs.emplace_back((steps + 9) / 10, 3);
    }
    for (int k = 0; k < count; ++k) {
      using Map = Eigen::Map<const tendyn::RowMatrixXd>;
      runs.push_back(tendyn::BatchRun{&models[k], &datas[k], Map(zero.data(), steps, 3), Map(zero.data(), steps, 3),
                                      Map(ff[k].data(), steps, 3), Map(zero.data(), steps, 3), logs[k].log()});
    }
  }
};

}  // namespace

inline int sim_batch_checks() {
  int failures = 0;
  const int count = 6;
  const long steps = 2000;
  Batch seq(count, steps), par(count, steps);
  for (auto& r : seq.runs)  // one after the other, on this thread
    r.status = tendyn::run(*r.model, *r.data, r.ref_q, r.ref_v, r.ff, r.torque_ext, 10, r.log);
  const tendyn::Status s = tendyn::run_batch(par.runs.data(), count, 10, 3);
  if (tendyn::is_error(s)) { std::printf("FAIL run_batch returned an error\n"); ++failures; }
  if (seq.logs[0].same(seq.logs[count - 1])) { std::printf("FAIL the runs do not differ\n"); ++failures; }
  for (int k = 0; k < count; ++k) {
    const bool same = seq.logs[k].same(par.logs[k]) && seq.datas[k].q == par.datas[k].q &&
                      seq.datas[k].qd == par.datas[k].qd && seq.datas[k].dissipated == par.datas[k].dissipated;
    if (!same) { std::printf("FAIL run %d: the batch differs from the sequential run\n", k); ++failures; }
  }
  // allocations: thread starts only, not per step
  long allocs[2];
  const long lengths[2] = {200, 2000};
  for (int t = 0; t < 2; ++t) {
    Batch b(count, lengths[t]);
    counting::count = 0;
    counting::armed = true;
    tendyn::run_batch(b.runs.data(), count, 10, 3);
    counting::armed = false;
    allocs[t] = counting::count;
  }
  std::printf("run_batch: %d runs on 3 threads equal the sequential runs bit for bit: %s; allocations %ld (200 steps),"
              " %ld (2000 steps)\n", count, failures ? "NO" : "yes", allocs[0], allocs[1]);
  if (allocs[0] != allocs[1]) { std::printf("FAIL the stepping loop allocates\n"); ++failures; }
  return failures ? 1 : 0;
}

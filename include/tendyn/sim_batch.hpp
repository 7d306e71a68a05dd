// tendyn — many independent simulator runs at once (design sweeps, Monte Carlo over friction parameters).
//
// A batch is a list of runs; each run has its own SimData (state and workspace, allocated beforehand), its
// own inputs and log, and a model that runs may share (one model, many inputs) or not (one model per draw of
// the parameters). The runs are spread over worker threads that take the next run from a shared counter;
// each run is stepped by the same allocation-free tendyn::run() as a single run, so a run's result does
// not depend on the thread that ran it nor on the others: the batch equals the sequential runs bit for bit.
// Allocation happens only when the worker threads start (std::thread), never in the stepping loop.
// A model's ControlHook is called from a worker thread: a hook shared by runs must be thread-safe.
#pragma once

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "tendyn/sim.hpp"

namespace tendyn {

/// One run of a batch: inputs are (steps, na) row-major (numpy's layout), the log as for run().
struct BatchRun {
  const SimModel* model;
  SimData* data;
  Eigen::Map<const RowMatrixXd> ref_q, ref_v, ff, torque_ext;
  SimLog log;
  Status status = Status::Ok;  ///< what run() returned for this run
};

/// Worker threads run_batch uses for `requested` (< 1: one per hardware thread) and `n_runs` runs.
inline int batch_threads(int requested, int n_runs) {
  int t = requested;
  if (t < 1) t = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, std::min(t, n_runs));
}

/// Run every run of `runs` (n_runs of them) with run(), logging every `log_every` steps, on
/// batch_threads(n_threads, n_runs) threads (the calling thread is one of them). Each run's status is
/// written to its `status`; returns the worst of them. The runs must not share a SimData.
inline Status run_batch(BatchRun* runs, int n_runs, int log_every, int n_threads) {
  if (n_runs <= 0) return Status::Ok;
  const int threads = batch_threads(n_threads, n_runs);
  std::atomic<int> next{0};
  auto worker = [&]() {
    for (int k = next.fetch_add(1, std::memory_order_relaxed); k < n_runs;
         k = next.fetch_add(1, std::memory_order_relaxed)) {
      BatchRun& r = runs[k];
      r.status = run(*r.model, *r.data, r.ref_q, r.ref_v, r.ff, r.torque_ext, log_every, r.log);
    }
  };
  if (threads == 1) {
    worker();
  } else {
    std::vector<std::thread> pool;
    pool.reserve(static_cast<std::size_t>(threads - 1));
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
  }
  Status s = Status::Ok;
  for (int k = 0; k < n_runs; ++k) s = worst(s, runs[k].status);
  return s;
}

}  // namespace tendyn

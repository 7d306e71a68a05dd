"""Benchmark tx40_identify: the real TX40 9 s log (45 000 samples at 5 kHz) identified end to end by tendyn
(C++ regressor of all samples with the parallel filter in the same pass) against a per-sample Python loop over
``pinocchio.computeJointTorqueRegressor`` doing the same treatment (same Butterworth, central differences,
same FIR, same decimation) and the same least squares, in the same run."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "python" / "tendyn" / "data" / "tx40"   # shipped (tendyn data path tx40)


def _log():
    from tendyn.io.importer import import_logs

    return import_logs([DATA / "pos_read_data.csv", DATA / "curr_data.csv"], DATA / "import.toml")


def tendyn_identify(dev, log):
    from tendyn.ident import IDIM

    return IDIM(dev).fit(log, crossval=False)


def python_loop_identify(model, log, treatment):
    """The same treatment and LS, with a per-sample Python loop over Pinocchio's regressor."""
    import pinocchio as pin
    from tendyn.ident.treatment import butter_zero_phase, central_differences, parallel_filter_taps

    time_, q, tau = model.joint_signals(log)
    dt = 1.0 / treatment.rate_hz
    qf = butter_zero_phase(q, treatment.cutoff_hz, treatment.rate_hz, treatment.order)
    qd = central_differences(qf, dt)
    qdd = central_differences(qd, dt)
    pm = model.compiled.pinocchio_model
    data = pm.createData()
    n, na = q.shape
    p_in = 10 * pm.nv
    G = model.G
    rows = np.zeros((n, na, p_in + 4 * na + 3 * G.shape[0]))
    for s in range(n):
        Y = model.L.T @ pin.computeJointTorqueRegressor(pm, data, model.L @ qf[s] + model.c, model.L @ qd[s],
                                                       model.L @ qdd[s])
        rows[s, :, :p_in] = Y
        for j in range(na):
            rows[s, j, p_in + 4 * j:p_in + 4 * j + 4] = (qdd[s, j], qd[s, j], np.sign(qd[s, j]), 1.0)
        for i in range(G.shape[0]):
            c = p_in + 4 * na + 3 * i
            gv, ga = G[i] @ qd[s], G[i] @ qdd[s]
            rows[s, :, c] = G[i] * ga
            rows[s, :, c + 1] = G[i] * gv
            rows[s, :, c + 2] = G[i] * np.sign(gv)
    taps = parallel_filter_taps(treatment.decimate)
    K = treatment.decimate
    from scipy.signal import convolve

    def dec(x):  # x (n, ...) -> centred windows, every K-th
        y = convolve(x, taps.reshape((-1,) + (1,) * (x.ndim - 1)), mode="valid")
        return y[::K]
    Wd = dec(rows)                         # (n_out, na, p)
    taud = dec(tau)
    qdd_ = dec(qd)
    thr = np.broadcast_to(np.asarray(treatment.velocity_threshold or 0.0, float), (na,))
    keep = [np.abs(qdd_[:, j]) >= thr[j] for j in range(na)]          # the same near-zero-speed removal
    W = np.concatenate([Wd[keep[j], j, :] for j in range(na)])[:, model.standard_columns][:, list(model.base.columns)]
    Yv = np.concatenate([taud[keep[j], j] for j in range(na)])
    x, *_ = np.linalg.lstsq(W, Yv, rcond=None)
    return x


def bench_tx40_identify(results: list) -> None:
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident import IdentModel

    if not DATA.is_dir():
        print(f"[bench] tx40_identify skipped: no data at {DATA}")
        return
    dev = load_device(bundled("tx40"))
    log = _log()
    tendyn_identify(dev, log)              # warm-up (imports, compiled device)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        est = tendyn_identify(dev, log)
        best = min(best, time.perf_counter() - t0)
    model = IdentModel(dev)
    t0 = time.perf_counter()
    x_loop = python_loop_identify(model, log, est.treatment_)
    loop = time.perf_counter() - t0
    agree = float(np.max(np.abs(x_loop - est.params_) / np.maximum(np.abs(est.params_), 1e-9 + est.stderr_)))
    print(f"[bench] tx40_identify: tendyn {best:.3f} s, python loop {loop:.3f} s; same parameters to "
          f"{agree:.2e} (relative)")
    results.append(dict(name="tx40_identify", value=best, unit="s", baseline="python loop over "
                        "pinocchio.computeJointTorqueRegressor, same treatment + LS", baseline_value=loop,
                        ratio=loop / best))

"""Benchmark of issue 21: `blockmodel_fit`, a 3rd-order Wiener (dead-zone) output-error fit on 10 000 samples.

tendyn (:class:`tendyn.ident.blockmodel.BlockModel`: lfilter simulation, exact Jacobian by filtering, linear
initial estimate included in the time) against ``scipy.optimize.least_squares`` on a plain Python simulation
loop with finite-difference Jacobian, started from tendyn's own initial estimate (so the baseline is timed on
the optimisation alone). Goal: ratio >= 10 and tendyn <= 1 s.
"""

from __future__ import annotations

import sys
import time

import numpy as np


def plain_wiener(theta, u, n):
    """ŷ of a Wiener dead-zone model by a plain loop over the samples (the baseline's simulator)."""
    b, a, d = theta[:n + 1], theta[n + 1:2 * n + 1], theta[2 * n + 1]
    x = np.zeros(u.size)
    for t in range(u.size):
        acc = 0.0
        for k in range(n + 1):
            if t - k >= 0:
                acc += b[k] * u[t - k]
        for k in range(1, n + 1):
            if t - k >= 0:
                acc -= a[k - 1] * x[t - k]
        x[t] = acc
    return np.sign(x) * np.maximum(np.abs(x) - d, 0.0)


def problem(n_samples: int = 10_000, seed: int = 3):
    """A 3rd-order Wiener dead-zone system, PRBS-like input held 5 samples, output noise at 1 % of its rms."""
    from scipy import signal

    rng = np.random.default_rng(seed)
    poles = [0.95, 0.9 * np.exp(0.2j), 0.9 * np.exp(-0.2j)]
    a = np.real(np.poly(poles))[1:]
    b = np.array([0.0, 0.02, 0.015, 0.005])
    u = np.repeat(rng.choice([-1.0, 1.0], n_samples // 5 + 1), 5)[:n_samples] * rng.uniform(0.3, 1.0, n_samples)
    x = signal.lfilter(b, np.concatenate([[1.0], a]), u)
    y = np.sign(x) * np.maximum(np.abs(x) - 0.2 * np.std(x), 0.0)
    y = y + 0.01 * np.std(y) * rng.normal(size=n_samples)
    return u, y, np.concatenate([b, a, [0.2 * np.std(x)]])


def bench_blockmodel_fit(results: list, rounds: int = 3) -> None:
    from scipy.optimize import least_squares

    from tendyn.ident import blockmodel as bm

    u, y, truth = problem()
    n = 3
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        model = bm.BlockModel("wiener", "dead-zone", order=n, rate_hz=1000.0).fit((u, y))
        times.append(time.perf_counter() - t0)
    best = min(times)
    # the baseline from tendyn's starting point (its ARX + linear output error + grid initial estimate)
    b0, a0 = bm._arx([bm.Record(u, y, 1000.0)], n)
    b0, p0 = bm._initial_nonlinear("wiener", bm.nonlinearity("dead-zone"), n, b0, a0, [bm.Record(u, y, 1000.0)], 0)
    th0 = np.concatenate([b0, a0, p0])
    lb = np.concatenate([np.full(2 * n + 1, -np.inf), [0.0]])
    print(f"[bench] blockmodel_fit: tendyn {best:.3f} s; plain-loop least_squares …", file=sys.stderr)
    t0 = time.perf_counter()
    sol = least_squares(lambda th: plain_wiener(th, u, n) - y, th0, bounds=(lb, np.inf), method="trf")
    base = time.perf_counter() - t0
    nrms_base = float(np.linalg.norm(plain_wiener(sol.x, u, n) - y) / np.linalg.norm(y - y.mean()))
    nrms_tendyn = model.nrms(u, y)
    print(f"[bench] blockmodel_fit: tendyn {best:.3f} s (NRMS {nrms_tendyn:.4f}, dead-zone "
          f"{model.params_['width']:.4f} vs {truth[-1]:.4f}); baseline {base:.2f} s (NRMS {nrms_base:.4f}, "
          f"{sol.nfev} evaluations): {base / best:.1f}x", file=sys.stderr)
    results.append(dict(name="blockmodel_fit", value=best, unit="s", baseline="scipy least_squares on a plain "
                        "simulation loop (finite-difference Jacobian, from tendyn's initial estimate)",
                        baseline_value=base, ratio=base / best, samples=int(u.size), order=n,
                        nrms=nrms_tendyn, baseline_nrms=nrms_base, goal_s=1.0, goal_ratio=10.0))


if __name__ == "__main__":
    res: list = []
    bench_blockmodel_fit(res, rounds=1)
    print(res)


def bench_blockmodel_amplitudes(results: list, amplitude_N: float = 1.0, duration_s: float = 4.0) -> None:
    """Issue 30, item 4: the amplitude check. On the McGill twin, PRBS logs at A, 0.5 A and 1.5 A (4 s each); the
    push-pull Lur'e model and the one-loop Lur'e model (the baseline) fitted at A only; value = the worst NRMS
    ratio (record at 0.5 A or 1.5 A over the fit's own NRMS; goal ≤ 1.2), ratio = baseline's worst / ours."""
    from tendyn.device.tendon_bench import load_tendon_bench
    from tendyn.devices import bundled
    from tendyn.ident.blockmodel import BlockModel
    from tendyn.pipelines import s1_logs

    bench = load_tendon_bench(bundled("mcgill_bench"))
    recs = s1_logs.bench_records(s1_logs.prbs_logs(bench, (amplitude_N, 0.5 * amplitude_N, 1.5 * amplitude_N), 300,
                                                   duration_s))
    worst = {}
    for st in ("push-pull", "lure"):
        m = BlockModel(st, "coulomb", order=2).fit(recs[:1])
        worst[st] = max(m.nrms(r.u, r.y) / m.fit_nrms_ for r in recs[1:])
    results.append(dict(name="blockmodel_amplitude_mcgill", value=worst["push-pull"], unit="NRMS ratio (0.5x, 1.5x)",
                        baseline="one-loop Lur'e model, same records", baseline_value=worst["lure"],
                        ratio=worst["lure"] / worst["push-pull"]))
    # generated benches (A = 8 F_c): the coulomb-tension push-pull model against the constant-level one
    gen = {"more friction": dict(friction_c0=0.2), "damped": dict(damping_motor=30.0),
           "lighter, stiffer": dict(mass_motor=0.35, k1=4.0e4, pretension=8.0, friction_c0=0.06)}
    worst_t, worst_c = {}, {}
    for name, ch in gen.items():
        b = bench.replace(**ch)
        fc = b.friction_c0 + b.friction_mu_tension * b.pretension
        recs = s1_logs.bench_records(s1_logs.prbs_logs(b, (8 * fc, 4 * fc, 12 * fc), 400, duration_s))
        for nl, out in (("coulomb-tension", worst_t), ("coulomb", worst_c)):
            m = BlockModel("push-pull", nl, order=2).fit(recs[:1])
            out[name] = max(m.nrms(r.u, r.y) / m.fit_nrms_ for r in recs[1:])
    print(f"[bench] blockmodel amplitudes, generated benches: coulomb-tension {worst_t}, constant level {worst_c}")
    results.append(dict(name="blockmodel_amplitude_generated", value=max(worst_t.values()),
                        unit="worst NRMS ratio (0.5x, 1.5x) over 3 generated benches",
                        baseline="push-pull with a constant friction level, same records",
                        baseline_value=max(worst_c.values()), ratio=max(worst_c.values()) / max(worst_t.values()),
                        per_bench=worst_t, per_bench_baseline=worst_c))

"""`make bench`: tendyn against baselines measured in the same run; ratios > 1 mean tendyn is better.

Writes benchmarks/results.json as a list of {name, value, unit, baseline, baseline_value, ratio}
and prints it as a table. Machines are shared and noisy: only same-run ratios mean anything.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from numpy_statics import motor_torque_feedforward as numpy_feedforward  # noqa: E402

from tendyn.device import load_device  # noqa: E402
from tendyn.devices import bundled  # noqa: E402
from tendyn.io import atomic_write_text  # noqa: E402
from tendyn.transmission import Transmission  # noqa: E402


def timer_path(name: str) -> str:
    """The C++ timer `name` that `make bench` builds (its path in TENDYN_<NAME>_TIMER, else build/bench/)."""
    timer = os.environ.get(f"TENDYN_{name.upper()}", str(HERE.parent / "build/bench/benchmarks" / name))
    if not Path(timer).exists():
        raise SystemExit(f"{timer} not found: run `make bench` (it builds benchmarks/{name}.cpp)")
    return timer


def bench_feedforward(results: list, calls: int = 1_000_000, baseline_calls: int = 3000) -> None:
    """Feedforward motor torques with losses, L-EXOS (4 transmissions): C++ core vs a plain C++ Eigen
    implementation of the same statics (benchmarks/plain_eigen_statics.hpp, same executable, checked equal to
    1e-12) and vs the numpy recursion. The mean is batch-timed (`calls` random inputs, one timer around the
    whole loop, thread CPU time, median of 7 interleaved rounds); median and p99.9 come from per-call timing
    (two clock reads around each call, their cost included) and are kept for the tail only."""
    dev = load_device(bundled("lexos"))
    tr = Transmission.from_device(dev)
    arr = dev.routing_arrays()
    rng = np.random.default_rng(7)
    tau = rng.normal(size=(baseline_calls, tr.n)) * 5
    qd = rng.normal(size=(baseline_calls, tr.n))
    # the two implementations agree before anything is timed
    for k in range(50):
        np.testing.assert_allclose(numpy_feedforward(arr, tau[k], qd[k]),
                                   tr.feedforward(tau[k], qd[k]).torque_motor, rtol=1e-10, atol=1e-12)
    timer = timer_path("feedforward_timer")
    print(f"[bench] C++ feedforward and its Eigen baseline, {calls} calls x 7 rounds ({Path(timer).name}) …",
          file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        model_file = Path(tmp) / "lexos.model"
        tr.export(model_file)  # the timer runs exactly this model
        out = subprocess.run([timer, str(model_file), str(calls), "7", "7"], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"feedforward_timer failed: {out.stderr.strip()}")
    timed = json.loads(out.stdout)
    print(f"[bench] numpy baseline, {baseline_calls} calls …", file=sys.stderr)
    base = np.empty(baseline_calls)
    t0 = time.thread_time_ns()
    for k in range(baseline_calls):
        a = time.perf_counter_ns()
        numpy_feedforward(arr, tau[k], qd[k])
        base[k] = time.perf_counter_ns() - a
    np_mean = (time.thread_time_ns() - t0) / baseline_calls
    mean, med, p999 = timed["mean_ns"], timed["median_ns"], timed["p999_ns"]
    emean, emed, ep999 = timed["eigen_mean_ns"], timed["eigen_median_ns"], timed["eigen_p999_ns"]
    bmed, bp999 = np.median(base), np.percentile(base, 99.9)
    extra = dict(calls=timed["calls"], rounds=timed["rounds"], mean_wall_us=timed["mean_wall_ns"] / 1e3,
                 eigen_mean_wall_us=timed["eigen_mean_wall_ns"] / 1e3,
                 max_rel_diff_eigen=timed["max_rel_diff"], goal_us=0.1,
                 timer="one thread-CPU timer around 1M calls, median of rounds")
    results.append(dict(name="lexos_feedforward_mean", value=mean / 1e3, unit="us/call",
                        baseline="plain C++ Eigen (same statics)", baseline_value=emean / 1e3, ratio=emean / mean,
                        **extra))
    results.append(dict(name="lexos_feedforward_mean", value=mean / 1e3, unit="us/call",
                        baseline="numpy recursion (same physics, timer around the loop)",
                        baseline_value=np_mean / 1e3, ratio=np_mean / mean))
    tail = dict(timer="steady_clock pair around each call (included)", timer_overhead_us=timed["timer_overhead_ns"] / 1e3)
    results.append(dict(name="lexos_feedforward_median", value=med / 1e3, unit="us/call",
                        baseline="plain C++ Eigen (same statics)", baseline_value=emed / 1e3, ratio=emed / med, **tail))
    results.append(dict(name="lexos_feedforward_median", value=med / 1e3, unit="us/call",
                        baseline="numpy recursion (same physics)", baseline_value=bmed / 1e3, ratio=bmed / med))
    results.append(dict(name="lexos_feedforward_p99.9", value=p999 / 1e3, unit="us/call",
                        baseline="plain C++ Eigen (same statics)", baseline_value=ep999 / 1e3, ratio=ep999 / p999,
                        **tail))
    results.append(dict(name="lexos_feedforward_p99.9", value=p999 / 1e3, unit="us/call",
                        baseline="numpy recursion (same physics)", baseline_value=bp999 / 1e3, ratio=bp999 / p999))


def bench_differential_feedforward(results: list, calls: int = 1_000_000) -> None:
    """Issue 19: feedforward motor torques with losses on a 7-transmission differential device (generated:
    differential pairs at joints 2-3 and 6-7, every branch lossy, no bearings) against the L-EXOS feedforward
    (serial, S0's recursion) timed in the same process (benchmarks/routing_timer.cpp: interleaved rounds, one
    thread-CPU timer around `calls` calls, median of 7). The ratio is L-EXOS time / differential time (< 1: the
    coupled blocks cost more). block_steps_per_call: Newton steps per call (only the 2x2 blocks whose pattern from
    the table failed its check take any); pair_fallbacks_per_call: such 2x2 blocks per call (2 pairs a call). The peers cannot do it at all: the plain Eigen and numpy statics of the other
    entries are S0's serial recursion, and MuJoCo's fixed tendons carry no tension-dependent losses."""
    from tendyn.devices.generate import write_cable_device

    timer = timer_path("routing_timer")
    print(f"[bench] differential feedforward (7 transmissions) vs L-EXOS, {calls} calls x 7 rounds …", file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        lexos, diff = Path(tmp) / "lexos.model", Path(tmp) / "diff7.model"
        Transmission.from_device(load_device(bundled("lexos"))).export(lexos)
        dev = load_device(write_cable_device(tmp, 7, planar=False, differential=True, seed=19))
        Transmission.from_device(dev).export(diff)
        out = subprocess.run([timer, str(lexos), str(diff), str(calls), "19", "7"], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"routing_timer failed: {out.stderr.strip()}")
    t = json.loads(out.stdout)
    results.append(dict(name="diff7_feedforward_mean", value=t["general_mean_ns"] / 1e3, unit="us/call",
                        baseline="L-EXOS feedforward (serial, 4 transmissions, same run)",
                        baseline_value=t["serial_mean_ns"] / 1e3, ratio=t["serial_mean_ns"] / t["general_mean_ns"],
                        goal_us=0.2, block_steps_per_call=t["general_iterations_mean"],
                        pair_fallbacks_per_call=t["general_pair_fallbacks_mean"],
                        method="2x2 blocks: the pattern's solve from a table (64 patterns), checked; Newton when "
                               "the check fails",
                        max_rel_roundtrip=t["max_rel_roundtrip"], calls=t["calls"], rounds=t["rounds"],
                        timer="one thread-CPU timer around 1M calls, median of 7 interleaved rounds"))


def bench_tendon_feedforward(results: list, calls: int = 1_000_000, baseline_calls: int = 2000) -> None:
    """Issue 19: the N+1 tendon feedforward of the bundled `tendon_finger` (3 joints, 4 tendons; tensions =
    minimum-norm + λh at or above the floors, include/tendyn/tendons.hpp) in C++ (benchmarks/tendon_timer.cpp:
    lossless and with S0 eq. 12 losses along every tendon, interleaved, thread-CPU timer around `calls` calls,
    median of 7) against what a cable-robot engineer would write: the tension distribution as a linear program
    (min Σt s.t. Kᵀ t = τ, t ≥ floors; scipy.optimize.linprog with HiGHS, the solver scipy recommends) and the same
    closed form in numpy, both per call in Python. The LP and the closed form give the same tensions (h > 0: the
    least Σt is the least λ); checked to 1e-9 relative. The peers have no losses along the tendons."""
    from scipy.optimize import linprog

    from tendyn.tendons import Tendons

    dev = load_device(bundled("tendon_finger"))
    td = Tendons.from_device(dev)
    box = td.largest_torque_box()
    scale = 0.3 * box                                   # joint torques ~ 0.3 box N(0, 1): inside it mostly
    timer = timer_path("tendon_timer")
    print(f"[bench] N+1 tendon feedforward ({dev.name}: {td.n} joints, {td.m} tendons), {calls} calls x 7 rounds …",
          file=sys.stderr)
    m = td.model
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "finger.txt"
        rows = [f"{td.n} {td.m}"] + [" ".join(f"{x:.17g}" for x in r) for r in np.asarray(m.K)]
        rows += [" ".join(f"{x:.17g}" for x in np.asarray(v)) for v in (m.motor_radius, m.tension_min)]
        rows += [" ".join(str(int(x)) for x in np.asarray(m.last_joint))]
        rows += [" ".join(f"{x:.17g}" for x in r) for a in (m.tau0, m.nu) for r in np.asarray(a)]
        path.write_text("\n".join(rows) + "\n", encoding="utf-8")
        out = subprocess.run([timer, str(path), str(calls), "19", f"{scale:.17g}", "7"], capture_output=True,
                             text=True)
    if out.returncode != 0:
        raise SystemExit(f"tendon_timer failed: {out.stderr.strip()}")
    t = json.loads(out.stdout)
    rng = np.random.default_rng(19)
    taus = scale * rng.standard_normal((baseline_calls, td.n))
    Kt, h, floor, P = td.K.T, td.null_vector, td.tension_min, td.tension_from_torque

    def numpy_closed_form(tau):
        t0 = P @ tau
        return t0 + np.max((floor - t0) / h) * h

    def lp(tau):
        return linprog(np.ones(td.m), A_eq=Kt, b_eq=tau, bounds=list(zip(floor, [None] * td.m)), method="highs").x

    worst = 0.0
    for tau in taus[:200]:
        ours = td.feedforward(tau).tension
        worst = max(worst, float(np.max(np.abs(lp(tau) - ours) / np.maximum(1.0, np.abs(ours)))),
                    float(np.max(np.abs(numpy_closed_form(tau) - ours) / np.maximum(1.0, np.abs(ours)))))
    if not worst <= 1e-9:
        raise SystemExit(f"tendon feedforward: the LP or the numpy closed form disagrees with tendons.hpp ({worst:.3g})")
    timings = {}
    for name, fn in (("lp", lp), ("numpy", numpy_closed_form)):
        t0 = time.perf_counter()
        for tau in taus:
            fn(tau)
        timings[name] = (time.perf_counter() - t0) / baseline_calls * 1e6
    common = dict(unit="us/call", lossless_us=t["lossless_mean_ns"] / 1e3, calls=t["calls"], rounds=t["rounds"],
                  max_rel_check=t["max_rel_check"], max_rel_diff_baselines=worst, torque_scale_Nm=scale,
                  timer="one thread-CPU timer around 1M calls, median of 7 interleaved rounds (baselines: "
                        f"{baseline_calls} calls in Python)")
    lossy = t["lossy_mean_ns"] / 1e3
    results.append(dict(name="nplus1_feedforward_mean", value=lossy, baseline="scipy linprog (HiGHS), min Σt "
                        "s.t. Kᵀt = τ, t ≥ floors, lossless, per call", baseline_value=timings["lp"],
                        ratio=timings["lp"] / lossy, **common))
    results.append(dict(name="nplus1_feedforward_mean", value=lossy, baseline="numpy closed form (minimum-norm + "
                        "λh), lossless, per call", baseline_value=timings["numpy"], ratio=timings["numpy"] / lossy,
                        **common))


def bench_compensator(results: list, calls: int = 1_000_000, baseline_calls: int = 5000, device=None,
                      name: str = "lexos_compensator_cycle") -> None:
    """One compensator cycle (velocity estimate + gravity + losses) through the C ABI, of L-EXOS or ``device``:
    mean from batch timing, median and p99.9 from per-call timing, over `calls` cycles; against a plain C++
    Eigen implementation (same executable, same run) and a numpy implementation of the same cycle."""
    from numpy_compensator import NumpyCompensator

    from tendyn.control import Compensator
    from tendyn.device import compile_device

    dev = compile_device(load_device(bundled("lexos")) if device is None else device)
    comp = Compensator.from_device(dev)
    m = comp.model
    n = comp.n
    ref = NumpyCompensator(dev.device.routing_arrays(), dev.joint_frames, dev.device.kinematics.gravity,
                           m.underestimation, m.velocity_band, m.filter_gain(), m.rate_hz)
    rng = np.random.default_rng(7)
    t = np.arange(baseline_calls) / m.rate_hz
    qm = np.column_stack([3.0 * np.sin(2 * np.pi * (0.3 + 0.17 * i) * t) for i in range(n)])
    qm += 4e-4 * rng.normal(size=qm.shape)
    tj = rng.normal(size=qm.shape)
    for k in range(200):  # the numpy cycle is the same cycle
        np.testing.assert_allclose(ref.cycle(qm[k], tj[k]), comp.cycle(qm[k], tj[k]), rtol=1e-9, atol=1e-11)
    timer = timer_path("compensator_timer")
    print(f"[bench] {name}: compensator cycle of {dev.name} ({n} transmissions) through the C ABI, {calls} calls "
          "(batch and one by one) …", file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "model.comp"
        comp.export(path)
        out = subprocess.run([timer, str(path), str(calls), "7"], capture_output=True, text=True, check=True)
    timed = json.loads(out.stdout)
    if not timed["max_abs_diff"] < 1e-9:
        raise SystemExit(f"compensator_timer: the Eigen baseline disagrees with the core ({timed['max_abs_diff']})")
    print(f"[bench] numpy compensator cycle, {baseline_calls} calls …", file=sys.stderr)
    ref = NumpyCompensator(dev.device.routing_arrays(), dev.joint_frames, dev.device.kinematics.gravity,
                           m.underestimation, m.velocity_band, m.filter_gain(), m.rate_hz)
    base = np.empty(baseline_calls)
    t0 = time.perf_counter()
    for k in range(baseline_calls):
        a = time.perf_counter_ns()
        ref.cycle(qm[k], tj[k])
        base[k] = time.perf_counter_ns() - a
    np_mean = (time.perf_counter() - t0) / baseline_calls * 1e9
    mean, med, p999 = timed["mean_ns"], timed["median_ns"], timed["p999_ns"]
    emean, emed, ep999 = timed["eigen_mean_ns"], timed["eigen_median_ns"], timed["eigen_p999_ns"]
    results.append(dict(name=name, value=mean / 1e3, unit="us/call", baseline="plain C++ Eigen (same cycle)",
                        baseline_value=emean / 1e3, ratio=emean / mean))
    results.append(dict(name=name, value=mean / 1e3, unit="us/call", baseline="numpy (same cycle)",
                        baseline_value=np_mean / 1e3, ratio=np_mean / mean))
    results.append(dict(name=f"{name}_median", value=med / 1e3, unit="us/call", baseline="plain C++ Eigen (same cycle)",
                        baseline_value=emed / 1e3, ratio=emed / med))
    results.append(dict(name=f"{name}_median", value=med / 1e3, unit="us/call", baseline="numpy (same cycle)",
                        baseline_value=np.median(base) / 1e3, ratio=np.median(base) / med))
    results.append(dict(name=f"{name}_p99.9", value=p999 / 1e3, unit="us/call", baseline="plain C++ Eigen (same cycle)",
                        baseline_value=ep999 / 1e3, ratio=ep999 / p999))
    results.append(dict(name=f"{name}_p99.9", value=p999 / 1e3, unit="us/call", baseline="numpy (same cycle)",
                        baseline_value=np.percentile(base, 99.9) / 1e3, ratio=np.percentile(base, 99.9) / p999))


def bench_compensator_tracking(results: list, calls: int = 1_000_000,
                               name: str = "lexos_compensator_cycle_tracking") -> None:
    """Issue 23: one L-EXOS compensator cycle with online friction tracking (RLS, every cycle an update: the
    acceleration gate opened) and the passivity observer/controller on, through the C ABI (target ≤ 0.6 µs mean,
    p99.9 ≤ 1.5 µs), against the plain C++ Eigen cycle without either (same executable, same run): the ratio
    is the price of both; no peer tracks friction online or guarantees the compensator's passivity."""
    from tendyn.control import Compensator
    from tendyn.device import compile_device

    dev = compile_device(load_device(bundled("lexos")))
    comp = Compensator.from_device(dev, passivity=True, tracking={"acceleration_max": 1e6, "velocity_min": 0.1})
    timer = timer_path("compensator_timer")
    print(f"[bench] {name}: compensator + tracking + passivity controller cycle of {dev.name}, {calls} calls …",
          file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "model.comp"
        comp.export(path)
        if "section tracking" not in path.read_text() or "section passivity" not in path.read_text():
            raise SystemExit("the tracking benchmark's model file lacks its tracking or passivity section")
        out = subprocess.run([timer, str(path), str(calls), "7"], capture_output=True, text=True, check=True)
    timed = json.loads(out.stdout)   # max_abs_diff is not checked: the baseline neither tracks nor dissipates
    base = "plain C++ Eigen cycle without tracking/passivity"
    for suffix, key in (("", "mean_ns"), ("_median", "median_ns"), ("_p99.9", "p999_ns")):
        value, ref = timed[key], timed["eigen_" + key]
        results.append(dict(name=name + suffix, value=value / 1e3, unit="us/call", baseline=base,
                            baseline_value=ref / 1e3, ratio=ref / value))


def bench_zwidth_grid(results: list, points: int = 40, serial_points: int = 40, n_workers: int = 2) -> None:
    """Issue 23: the Z-width grid of the L-EXOS twin, ``points`` × ``points`` (K, B) points in the compensated
    mode (target ≤ 60 s on 2 cores), on a local Dask cluster of ``n_workers``; baseline: the same points one
    after the other in one process (``serial_points`` of them timed, scaled to the grid), same run."""
    from tendyn.device import compile_device
    from tendyn.pipelines.zwidth import DEFAULT_DAMPING, DEFAULT_STIFFNESS, _task, run_zwidth, zwidth_point

    dev = compile_device(load_device(bundled("lexos")))
    ks = np.geomspace(DEFAULT_STIFFNESS[0], DEFAULT_STIFFNESS[1], points)
    bs = np.linspace(DEFAULT_DAMPING[0], DEFAULT_DAMPING[1], points)
    print(f"[bench] zwidth_grid: {points}x{points} points of {dev.name} on {n_workers} local Dask workers …",
          file=sys.stderr)
    t0 = time.perf_counter()
    res = run_zwidth(dev, stiffness=ks, damping=bs, modes=("compensated",), n_workers=n_workers, progress=False)
    grid_s = time.perf_counter() - t0
    if len(res.rows) != points * points:
        raise SystemExit(f"zwidth_grid: {len(res.rows)} points came back, {points * points} asked")
    q0, normal = _task(dev)
    rng = np.random.default_rng(3)
    pick = rng.choice(points * points, serial_points, replace=False)
    t0 = time.perf_counter()
    for p in pick:
        zwidth_point(dev.device, ks[p // points], bs[p % points], mode="compensated", q0=q0, normal=normal)
    serial_s = (time.perf_counter() - t0) / serial_points * points * points
    results.append(dict(name="zwidth_grid", value=grid_s, unit="s", baseline=f"the same points in one process "
                        f"({serial_points} timed, scaled)", baseline_value=serial_s, ratio=serial_s / grid_s))


def print_table(results: list) -> None:
    print(f"{'benchmark':<34} {'tendyn':>12} {'baseline':>12} {'unit':>9} {'ratio':>9}  baseline")
    for r in results:
        print(f"{r['name']:<34} {r['value']:12.4g} {r['baseline_value']:12.4g} {r['unit']:>9} "
              f"{r['ratio']:9.1f}  {r['baseline']}")


ONLY = {"cli_help_latency": "cli", "identify_tx40_end_to_end": "identify",
        "diff7_feedforward_mean": "differential", "nplus1_feedforward_mean": "tendons",
        "lexos_compensator_cycle_tracking": "tracking",
        "zwidth_grid": "zwidth", "tx40_identify": "tx40", "stream_identify_1h": "stream",
        "design_evaluations_per_s": "design", "dask_design_speedup": "design", "dask_sweep_speedup": "sweep",
        "dask_identify_speedup": "dask_identify",
        "python_suite_wall": "suite",
        "identify_iv_gen6_twin_end_to_end": "closed_loop", "identify_didim_gen6_twin_end_to_end": "closed_loop",
        "blockmodel_amplitude_mcgill": "amplitude", "blockmodel_amplitude_generated": "amplitude"}
"""Entries that `python benchmarks/run.py --only NAME,…` runs alone, merged into results.json by name."""


def run_only(names: list[str]) -> int:
    import cli_bench

    unknown = [n for n in names if n not in ONLY]
    if unknown:
        print(f"run.py: --only: unknown {', '.join(unknown)} (known: {', '.join(ONLY)})", file=sys.stderr)
        return 2
    results: list = []
    groups = {ONLY[n] for n in names}
    if "cli" in groups:
        cli_bench.bench_cli_latency(results)
    if "identify" in groups:
        cli_bench.bench_identify_end_to_end(results)
    if "differential" in groups:
        bench_differential_feedforward(results)
    if "tendons" in groups:
        bench_tendon_feedforward(results)
    if "tracking" in groups:
        bench_compensator_tracking(results)
    if "zwidth" in groups:
        bench_zwidth_grid(results)
    if "tx40" in groups:
        from tx40_identify import bench_tx40_identify

        bench_tx40_identify(results)
    if "stream" in groups:
        from ident_scale import bench_stream

        bench_stream(results)
    if "design" in groups:
        from design_bench import bench_dask_design, bench_design_evaluations

        bench_design_evaluations(results)
        bench_dask_design(results)
    if "sweep" in groups:
        from s1_bench import bench_dask_sweep

        bench_dask_sweep(results)
    if "dask_identify" in groups:
        from ident_scale import bench_dask

        bench_dask(results)
    if "suite" in groups:
        from suite_bench import bench_test_suite

        bench_test_suite(results)
    if "closed_loop" in groups:
        from closed_loop_bench import bench_closed_loop_identify

        bench_closed_loop_identify(results)
    if "amplitude" in groups:
        from blockmodel_bench import bench_blockmodel_amplitudes

        bench_blockmodel_amplitudes(results)
    path = HERE / "results.json"
    old = json.loads(path.read_text(encoding="utf-8")) if path.exists() else []
    new = {r["name"] for r in results}
    atomic_write_text(path, json.dumps([r for r in old if r["name"] not in new] + results, indent=2))
    print_table(results)
    return 0


def main() -> int:
    if "--only" in sys.argv:
        return run_only(sys.argv[sys.argv.index("--only") + 1].split(","))
    results: list = []
    bench_feedforward(results)
    bench_differential_feedforward(results)
    bench_tendon_feedforward(results)
    bench_compensator(results)
    bench_compensator_tracking(results)
    with tempfile.TemporaryDirectory() as tmp:   # issue 17: the same cycle on a generated 8-transmission device
        from tendyn.devices.generate import write_cable_device

        eight = load_device(write_cable_device(tmp, 8, planar=False, seed=8))
        bench_compensator(results, device=eight, name="gen8_compensator_cycle")
    try:
        import mujoco  # noqa: F401  (a benchmark-only dependency)
    except ImportError as exc:
        print(f"[bench] simulator benchmarks against MuJoCo skipped: {exc}", file=sys.stderr)
    else:
        from sim_bench import bench_batch, bench_simulator

        setup = bench_simulator(results)
        bench_batch(results, setup)
    from s1_bench import bench_dask_sweep, bench_sensitivity_sweep

    bench_sensitivity_sweep(results)
    bench_dask_sweep(results)
    from blockmodel_bench import bench_blockmodel_amplitudes, bench_blockmodel_fit

    bench_blockmodel_fit(results)
    bench_blockmodel_amplitudes(results)
    from tx40_identify import bench_tx40_identify

    bench_tx40_identify(results)
    from ident_scale import bench_dask, bench_stream

    bench_dask(results)
    bench_stream(results)
    bench_zwidth_grid(results)
    from design_bench import bench_dask_design, bench_design_evaluations

    bench_design_evaluations(results)
    bench_dask_design(results)
    from cli_bench import bench_cli_latency, bench_identify_end_to_end

    bench_cli_latency(results)
    bench_identify_end_to_end(results)
    from closed_loop_bench import bench_closed_loop_identify

    bench_closed_loop_identify(results)
    from suite_bench import bench_test_suite

    bench_test_suite(results)
    path = HERE / "results.json"
    atomic_write_text(path, json.dumps(results, indent=2))
    print_table(results)
    print(f"\nwritten: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

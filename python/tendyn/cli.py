"""The `tendyn` command. Parses arguments and calls the packages; no physics lives here.

Every command that computes something takes ``--json`` and then prints its main results as one
JSON document on stdout; progress and logs go to stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def _load(device_arg: str):
    """A device file path, or the name of a bundled twin (e.g. ``lexos``)."""
    from tendyn.device import load_device
    from tendyn.devices import bundled

    path = Path(device_arg)
    if path.suffix == ".toml" or path.exists():
        return load_device(path)
    return load_device(bundled(device_arg))


def _matrix_text(name: str, M: np.ndarray, unit: str) -> str:
    rows = "\n".join("    " + "  ".join(f"{v:+10.5f}" for v in row) for row in M)
    return f"  {name} [{unit}]\n{rows}"


def cmd_routing_show(args) -> int:
    from tendyn.io import to_jsonable
    from tendyn.transmission import Transmission

    dev = _load(args.device)
    if not hasattr(dev, "transmissions"):
        print(f"tendyn: error: {dev.name} is a tendon bench (one 2N channel): it has no routing to show",
              file=sys.stderr)
        return 2
    if not dev.transmissions:
        return _show_capstan_drives(dev, args.json)
    tr = Transmission.from_device(dev)
    M = tr.matrices()
    if args.json:
        doc = {"device": dev.name, "n": tr.n, "routing": tr.routing_table(),
               **{k: M[k] for k in ("joint_from_motor_position", "motor_from_joint_position",
                                     "motor_from_joint_torque", "joint_from_motor_torque", "K", "R_m")},
               "units": {"K": "m", "R_m": "m", "joint_from_motor_position": "rad/rad",
                         "motor_from_joint_position": "rad/rad", "motor_from_joint_torque": "(N·m)/(N·m)",
                         "joint_from_motor_torque": "(N·m)/(N·m)"}}
        print(json.dumps(to_jsonable(doc), indent=2))
        return 0
    print(f"{dev.name}: {tr.n} tendon transmissions (transmission i drives joint i)")
    print(f"{'tr':>3} {'r_m [mm]':>9}  {'signed radius at joints 1…i [mm]':<36} {'pulley':>7} {'n':>5} {'eta_d':>6} {'q/q_m':>7}")
    for row in tr.routing_table():
        radii = " ".join(f"{1e3 * r:+7.1f}" for r in row["radius_at_joint_m"][:-1])
        print(f"{row['transmission']:>3} {1e3 * row['motor_radius_m']:9.2f}  {radii:<36} "
              f"{1e3 * row['driven_radius_m']:7.1f} {row['reducer_ratio']:5.1f} "
              f"{row['reducer_efficiency']:6.2f} {1 / row['joint_per_motor_ratio']:7.4f}")
    print("\nR_m q_m = K q (S0 eqs. 1–2, corrected); τ_J = Kᵀ t, C_m = R_m t (eq. 5, corrected)")
    print(_matrix_text("K", M["K"], "m"))
    print(_matrix_text("joint_from_motor_position  q = K⁻¹R_m q_m", M["joint_from_motor_position"], "rad/rad"))
    print(_matrix_text("motor_from_joint_position  q_m = R_m⁻¹K q", M["motor_from_joint_position"], "rad/rad"))
    print(_matrix_text("motor_from_joint_torque  C_m = R_m K⁻ᵀ τ_J", M["motor_from_joint_torque"], "N·m/N·m"))
    print(_matrix_text("joint_from_motor_torque  τ_J = Kᵀ R_m⁻¹ C_m", M["joint_from_motor_torque"], "N·m/N·m"))
    return 0


def _show_capstan_drives(dev, as_json: bool) -> int:
    """Capstan drives: one motor per active joint through ratio N, q_m = N q, C_m = τ_J / N."""
    from tendyn.io import to_jsonable

    N = np.array([d.ratio for d in dev.drives], float)
    M = {"joint_from_motor_position": np.diag(1 / N), "motor_from_joint_position": np.diag(N),
         "motor_from_joint_torque": np.diag(1 / N), "joint_from_motor_torque": np.diag(N), "K": np.diag(N)}
    drives = [{"drive": d.name, "joint": d.joint, "ratio": d.ratio, "stiffness_motor_Nm_rad": d.stiffness_motor,
               "coulomb_motor_Nm": d.coulomb_motor, "viscous_motor_Nms_rad": d.viscous_motor} for d in dev.drives]
    if as_json:
        print(json.dumps(to_jsonable({"device": dev.name, "n": len(N), "drives": drives, **M,
                                      "units": {"K": "- (capstan ratio: q_m = K q)"}}), indent=2))
        return 0
    print(f"{dev.name}: {len(N)} capstan drives (motor i drives active joint i through ratio N)")
    for d in drives:
        print(f"  {d['drive']}: joint {d['joint']}, N = {d['ratio']:g}, K_T = {d['stiffness_motor_Nm_rad']:g} N·m/rad "
              f"(motor side), Coulomb {d['coulomb_motor_Nm']:.4g} N·m, viscous {d['viscous_motor_Nms_rad']:.3g} N·m·s/rad")
    for name, unit in (("joint_from_motor_position", "rad/rad"), ("motor_from_joint_torque", "N·m/N·m")):
        print(_matrix_text(name, M[name], unit))
    return 0


def _demo_capstan(dev, out: Path, as_json: bool) -> int:
    """Demo on a capstan device: blocked-link test, motor torque vs motor angle (stiffness + hysteresis)."""
    from tendyn.io import save_png
    from tendyn.sim import experiments as ex

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    print(f"[demo] blocked-link tests on the {dev.name} twin …", file=sys.stderr)
    fig, ax = plt.subplots(figsize=(5.6, 4.2))
    slopes = {}
    for k, d in enumerate(dev.drives):
        run = ex.blocked_link(dev, joint=k + 1, torque_amplitude=0.1, period=2.0, cycles=1)
        qm = run.states["q_motor"][:, k] - run.states["q_motor"][0, k]
        tau = run.log[f"torque_motor_cmd_{k + 1}"]
        slopes[d.name] = float(np.polyfit(qm, tau, 1)[0])
        ax.plot(qm * 1e3, tau, lw=1.2, label=f"{d.name}: slope {slopes[d.name]:.2f} N·m/rad")
    ax.set_xlabel("motor angle [mrad] (links blocked)")
    ax.set_ylabel("motor torque [N·m]")
    ax.set_title(f"{dev.name}: capstan stiffness and friction hysteresis")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig_path = save_png(fig, out / "blocked_link.png")
    if as_json:
        print(json.dumps({"device": dev.name, "figure": str(fig_path), "stiffness_motor_Nm_rad": slopes}))
    else:
        for name, k in slopes.items():
            print(f"{name}: torque/angle slope {k:.3f} N·m/rad (motor side)")
        print(f"figure: {fig_path}")
    return 0


def cmd_demo(args) -> int:
    from tendyn.io import atomic_write_text, to_jsonable
    from tendyn.pipelines.statics_demo import statics_demo

    dev = _load(args.device)
    out = Path(args.out)
    if getattr(dev, "kind", "serial") == "tendon_bench_2n" or not hasattr(dev, "transmissions"):
        return _demo_bench(dev, out, args.json)
    if not dev.transmissions:
        return _demo_capstan(dev, out, args.json)
    from tendyn.io import save_png

    print(f"[demo] statics with losses on {dev.name} …", file=sys.stderr)
    demo = statics_demo(dev)
    fig_path = out / "statics_with_losses.png"
    save_png(demo.plot(), fig_path)
    atomic_write_text(out / "statics_with_losses.json", json.dumps(to_jsonable(demo.to_dict())))
    sweep = None
    if dev.transmissions and dev.n_joints >= 2:
        from tendyn.pipelines.friction_sweep import friction_sweep

        print(f"[demo] constant-velocity tests on the {dev.name} twin (S1, S2) …", file=sys.stderr)
        sweep = friction_sweep(dev, transmission=1, q0=np.array([0.0, 0.3, 0.0, 0.8])[: dev.n_joints])
        save_png(sweep.plot(), out / "constant_velocity_tests.png")
        atomic_write_text(out / "constant_velocity_tests.json", json.dumps(to_jsonable(sweep.to_dict())))
    if args.json:
        print(json.dumps({"device": dev.name, "figure": str(fig_path),
                          "data": str(out / "statics_with_losses.json")}))
    else:
        for s in demo.sweeps:
            k = len(s.torque_joint) - 1
            print(f"joint {s.joint + 1}: to deliver {s.torque_joint[k]:+.2f} N·m at {s.speed:+.1f} rad/s "
                  f"the motor needs {s.motor_positive_speed[k]:+.4f} N·m "
                  f"(lossless {s.motor_lossless[k]:+.4f}); back-driven at {-s.speed:+.1f} rad/s "
                  f"{s.motor_negative_speed[k]:+.4f} N·m")
        print(f"figure: {fig_path}")
        if sweep is not None:
            for name, (v, c) in sweep.points.items():
                pairs = ", ".join(f"{vi:+.0f} rad/s: {ci:+.4f}" for vi, ci in zip(v, c))
                print(f"{name}: mean motor-{sweep.transmission} torque [N·m] at {pairs}")
            print(f"figure: {out / 'constant_velocity_tests.png'}")
    return 0


def _floats(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


EXPERIMENTS = ("constant-velocity", "exciting", "blocked-link", "stepped-sine", "swept-sine", "low-speed-loop")
BENCH_EXPERIMENTS = ("stepped-sine", "swept-sine", "low-speed-loop")


def _simulate_bench(bench, args, progress):
    """Experiments on a 2N tendon bench: (log, truth) pairs."""
    from tendyn.sim import tendon_bench as tb

    rate = args.rate if args.rate != 10_000.0 else 20_000.0   # the bench's own default step
    log_every = max(1, int(round(rate / args.log_rate))) if args.log_rate else 1
    truth = bench.to_dict()
    if args.experiment == "stepped-sine":
        out = []
        for k, f in enumerate(args.freqs):
            n = int(round(args.cycles * rate / f))
            u = args.torque * np.sin(2 * np.pi * f * (np.arange(n) + 0.5) / rate)
            run = tb.simulate(bench, u, rate, args.seed)
            out.append((tb.bench_log(bench, run, "stepped_sine", {"freq_hz": f, "amplitude_N": args.torque},
                                     log_every), truth))
            progress(k + 1, len(args.freqs))
        return out
    if args.experiment == "swept-sine":
        res = tb.swept_sine(bench, f0_hz=min(args.freqs), f1_hz=max(args.freqs), duration_s=args.duration,
                            amplitude_N=args.torque, rate_hz=rate, seed=args.seed)
        opts = {"f0_hz": min(args.freqs), "f1_hz": max(args.freqs), "duration_s": args.duration,
                "amplitude_N": args.torque}
        return [(tb.bench_log(bench, res.runs[0], "swept_sine", opts, log_every), truth)]
    n = int(round(args.cycles / 0.2 * rate))
    u = args.torque * np.sin(2 * np.pi * 0.2 * (np.arange(n) + 0.5) / rate)
    run = tb.simulate(bench, u, rate, args.seed)
    return [(tb.bench_log(bench, run, "low_speed_loop", {"freq_hz": 0.2, "amplitude_N": args.torque},
                          log_every), truth)]


def cmd_simulate(args) -> int:
    import time

    from tqdm import tqdm

    from tendyn.io.logs import write_log, write_truth
    from tendyn.sim import experiments as ex

    dev = _load(args.device)
    q0 = None if args.q0 is None else np.asarray(args.q0, float)
    bar = tqdm(total=1, unit="step", unit_scale=True, file=sys.stderr, disable=args.quiet or None,
               desc=f"{dev.name}: {args.experiment}")

    def progress(done, total):
        bar.total = total
        bar.n = done
        bar.refresh()

    common = dict(rate_hz=args.rate, control_hz=args.control_rate, seed=args.seed, progress=progress)
    t0 = time.perf_counter()
    is_bench = getattr(dev, "kind", "serial") == "tendon_bench_2n" or not hasattr(dev, "transmissions")
    if is_bench and args.experiment not in BENCH_EXPERIMENTS:
        print(f"tendyn: error: {dev.name} is a tendon bench: experiments {', '.join(BENCH_EXPERIMENTS)}",
              file=sys.stderr)
        return 2
    if not is_bench and args.experiment == "low-speed-loop":
        print(f"tendyn: error: low-speed-loop is an experiment of the tendon bench, not of {dev.name}",
              file=sys.stderr)
        return 2
    if is_bench:
        runs = [ex.SimRun(log, truth) for log, truth in _simulate_bench(dev, args, progress)]
    elif args.experiment == "constant-velocity":
        runs = [ex.constant_velocity(dev, args.transmission, args.speeds, strategy=args.strategy, q0=q0,
                                     log_rate_hz=args.log_rate, **common)]
    elif args.experiment == "exciting":
        runs = [ex.exciting_trajectory(dev, duration=args.duration, q0=q0, log_rate_hz=args.log_rate, **common)]
    elif args.experiment == "blocked-link":
        runs = [ex.blocked_link(dev, args.joint, args.torque, period=args.period, cycles=args.cycles, q0=q0,
                                log_rate_hz=args.log_rate, **common)]
    elif args.experiment == "swept-sine":
        runs = [ex.swept_sine(dev, args.transmission, args.torque, f0_hz=min(args.freqs), f1_hz=max(args.freqs),
                              duration=args.duration, q0=q0, rate_hz=args.rate, seed=args.seed, progress=progress)]
    else:
        common["control_hz"] = args.rate
        runs = ex.stepped_sine(dev, args.transmission, omega=2 * np.pi * np.asarray(args.freqs), amplitude=args.torque,
                               q0=q0, **common)
    wall = time.perf_counter() - t0
    bar.close()

    out = Path(args.out)
    if out.suffix not in (".parquet", ".csv"):
        print(f"tendyn: error: --out must end in .parquet or .csv (got {out.name})", file=sys.stderr)
        return 2
    written = []
    for k, run in enumerate(runs):
        path = out if len(runs) == 1 else out.with_name(f"{out.stem}_{k + 1:02d}{out.suffix}")
        write_log(run.log, path)
        truth = write_truth(run.truth, path)
        written.append({"log": str(path), "truth": str(truth), "n_samples": run.log.n_samples,
                        "duration_s": float(run.log.time[-1] - run.log.time[0])})
    simulated = sum(w["duration_s"] for w in written)
    summary = {"device": dev.name, "experiment": args.experiment, "seed": args.seed,
               "log_rate_hz": runs[0].log.meta["rate_hz"],
               "logs": written, "wall_s": wall, "simulated_s_per_wall_s": simulated / wall if wall else None}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for w in written:
            print(f"{w['log']}: {w['n_samples']} samples, {w['duration_s']:.2f} s simulated (truth: {w['truth']})")
        print(f"wall {wall:.2f} s, {summary['simulated_s_per_wall_s']:.1f} simulated s per wall s")
    return 0


def _demo_bench(bench, out: Path, as_json: bool) -> int:
    """Demo on a 2N tendon bench: open-loop FRF at several amplitudes vs the analytic plant (S1, C22)."""
    from tendyn.io import atomic_write_text, save_png, to_jsonable
    from tendyn.pipelines.bench_frf import bench_frf

    print(f"[demo] stepped sines on the {bench.name} twin at 4 amplitudes …", file=sys.stderr)
    frf = bench_frf(bench)
    fig_path = out / "bench_frf_amplitudes.png"
    save_png(frf.plot(), fig_path)
    atomic_write_text(out / "bench_frf_amplitudes.json", json.dumps(to_jsonable(frf.to_dict())))
    peaks = frf.peaks_hz()
    if as_json:
        print(json.dumps({"device": bench.name, "figure": str(fig_path), "peak_hz": {str(a): f for a, f in peaks.items()}}))
    else:
        for a, f in peaks.items():
            print(f"input {a:.2f} N: open-loop resonance peak at {f:.0f} Hz")
        print(f"figure: {fig_path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="tendyn", description="Tendon transmissions: model, simulate, identify, compensate.")
    sub = p.add_subparsers(dest="command", required=True)

    routing = sub.add_parser("routing", help="transmission routing and matrices")
    rsub = routing.add_subparsers(dest="action", required=True)
    show = rsub.add_parser("show", help="print the routing table and the four matrices")
    show.add_argument("device", help="device file (.toml) or bundled twin name (lexos, …)")
    show.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    show.set_defaults(func=cmd_routing_show)

    sim = sub.add_parser("simulate", help="run an experiment on a twin and write its log")
    sim.add_argument("device", help="device file (.toml) or bundled twin name")
    sim.add_argument("experiment", choices=EXPERIMENTS)
    sim.add_argument("--out", required=True, help="log file (.parquet or .csv); the truth goes beside it")
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument("--rate", type=float, default=10_000.0, help="integration rate [Hz] (1–20 kHz)")
    sim.add_argument("--control-rate", type=float, default=None,
                     help="controller/sensor rate [Hz] (default 1 kHz for cable drives, 5 kHz for capstan drives)")
    sim.add_argument("--log-rate", type=float, default=1_000.0, help="log sampling rate [Hz]")
    sim.add_argument("--q0", type=_floats, help="initial active joint positions [rad], comma-separated")
    sim.add_argument("--transmission", type=int, default=1, help="1-based transmission (constant-velocity, stepped-sine)")
    sim.add_argument("--strategy", choices=("S1", "S2"), default="S2", help="S0 identification strategy")
    sim.add_argument("--speeds", type=_floats, default=[2.0, 5.0, 10.0], help="motor speeds [rad/s]")
    sim.add_argument("--duration", type=float, default=20.0, help="exciting / swept-sine length [s]")
    sim.add_argument("--joint", type=int, default=1, help="1-based joint (blocked-link)")
    sim.add_argument("--torque", type=float, default=0.1,
                     help="input amplitude: motor torque [N·m] on chains, force command [N] on a tendon bench")
    sim.add_argument("--period", type=float, default=2.0, help="triangle period [s] (blocked-link)")
    sim.add_argument("--cycles", type=int, default=3)
    sim.add_argument("--freqs", type=_floats, default=[1.0, 2.0, 5.0, 10.0], help="frequencies [Hz] (stepped-sine)")
    sim.add_argument("--quiet", action="store_true", help="no progress bar")
    sim.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    sim.set_defaults(func=cmd_simulate)

    demo = sub.add_parser("demo", help="statics with losses on a device: figure + data")
    demo.add_argument("device", nargs="?", default="lexos")
    demo.add_argument("--out", default="out/demo", help="output folder [default: out/demo]")
    demo.add_argument("--json", action="store_true")
    demo.set_defaults(func=cmd_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from tendyn.device import DeviceError

    try:
        return args.func(args)
    except DeviceError as exc:
        print(f"tendyn: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

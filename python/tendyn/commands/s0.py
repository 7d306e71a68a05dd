"""Command-line logic of the S0 friction workflow (issue 8, items 1–4): ``plan``, ``identify-friction``,
``decompose``. :func:`register` (found by :func:`tendyn.cli.build_parser`) adds them with
:func:`add_plan_arguments`, :func:`add_identify_friction_arguments`, :func:`add_decompose_arguments`; each
sets ``func`` to the ``run_*`` function, which returns the exit code (0) and raises :class:`tendyn.errors.UsageError` for bad
input (exit 2). No physics here: it calls :mod:`tendyn.sim.experiments` and :mod:`tendyn.ident`.

::

    tendyn plan constant-velocity lexos --transmission 2 --strategy S2 --speeds 2,4,6,8,10 --out ref.csv
    tendyn identify-friction lexos runs/t*.parquet --out friction.json [--gravity pairs|model|both] [--json]
    tendyn decompose lexos friction.json [--shares shares.json] [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from tendyn.commands import args as conv
from tendyn.errors import UsageError

PLAN_EXPERIMENTS = ("constant-velocity",)
DEFAULT_PLAN_SPEEDS = (2.0, 4.0, 6.0, 8.0, 10.0)
LOG_SUFFIXES = (".csv", ".parquet")


# ---- argparse converters (shared ones from tendyn.commands.args; messages without the option name) ------

def _out_path(suffixes):
    """An output path with one of ``suffixes`` whose folder exists (nothing is written before the work)."""
    def convert(text: str) -> Path:
        p = Path(text)
        if p.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"must end in {' or '.join(suffixes)} (got {text!r})")
        if p.exists() and p.is_dir():
            raise argparse.ArgumentTypeError(f"{text} is a folder")
        parent = p.parent if str(p.parent) else Path(".")
        if not parent.is_dir():
            raise argparse.ArgumentTypeError(f"folder {parent} does not exist")
        return p
    convert.__name__ = "path"
    return convert


def _load_device(text: str):
    """A device file path or a bundled twin name (as the rest of the command line)."""
    from tendyn.device import load_device
    from tendyn.devices import bundled

    path = Path(text)
    if path.suffix.lower() == ".toml" or path.exists():
        return load_device(path)
    return load_device(bundled(text))


def _print_json(doc) -> None:
    from tendyn.io import to_jsonable

    print(json.dumps(to_jsonable(doc), indent=2, allow_nan=False))


# ---- plan -------------------------------------------------------------------------------------------

def add_plan_arguments(subparsers) -> argparse.ArgumentParser:
    """``tendyn plan constant-velocity DEVICE --transmission I --strategy S1|S2 [...] --out REF.csv``."""
    p = subparsers.add_parser("plan", help="write the references of a twin experiment for a real controller")
    p.add_argument("experiment", choices=PLAN_EXPERIMENTS, help="the experiment to plan")
    p.add_argument("device", help="device file (.toml) or bundled twin name (lexos, …)")
    p.add_argument("--transmission", type=conv.number(1, integer=True), required=True, help="1-based transmission to move")
    p.add_argument("--strategy", choices=("S1", "S2"), default="S2",
                   help="S1 holds the other motors (motor-space references), S2 the other joints (joint-space); "
                        "default S2")
    p.add_argument("--speeds", type=conv.numbers(0.0, 1000.0, lo_open=True, unit="rad/s"), default=DEFAULT_PLAN_SPEEDS,
                   help="motor speeds [rad/s], comma-separated; one forward and one backward pass each "
                        "(identify-friction needs >= 5; default 2,4,6,8,10)")
    p.add_argument("--travel", type=conv.number(0.0, 1e4, lo_open=True, unit="rad"), default=20.0,
                   help="motor travel per pass [rad] (default 20, as the twin's experiment)")
    p.add_argument("--accel", type=conv.number(0.0, 1e6, lo_open=True, unit="rad/s²"), default=200.0,
                   help="motor acceleration of the ramps [rad/s^2] (default 200)")
    p.add_argument("--q0", type=conv.numbers(-10.0, 10.0, unit="rad"), default=None,
                   help="start joint positions [rad], comma-separated (default 0)")
    p.add_argument("--rate", type=conv.number(0.0, 1e6, lo_open=True, unit="Hz"), default=1000.0,
                   help="sample rate of the references [Hz] (the controller's rate; default 1000)")
    p.add_argument("--out", type=_out_path(LOG_SUFFIXES), required=True, help="REF.csv or REF.parquet")
    p.add_argument("--json", action="store_true", help="print a summary as JSON on stdout")
    p.set_defaults(func=run_plan)
    return p


def plan_constant_velocity(device, transmission: int, strategy: str, speeds, travel: float, accel: float,
                           q0, rate_hz: float):
    """The reference log of the constant-velocity test: time, position and speed references of every motor
    (S1) or joint (S2); ``options`` says which are held. Same references as
    :func:`tendyn.sim.experiments.constant_velocity` with the same settings (at ``rate_hz``)."""
    from tendyn.io import make_log
    from tendyn.sim.experiments import constant_velocity_references
    from tendyn.transmission import Transmission

    Gm = Transmission.from_device(device).matrices()["motor_from_joint_position"]
    n = Gm.shape[0]
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, float)
    ref_q, ref_v, space = constant_velocity_references(Gm, transmission, speeds, strategy, travel, accel, q0,
                                                       1.0 / rate_hz)
    cols = {"time": np.arange(ref_q.shape[0]) / rate_hz}
    prefix, vprefix = ("q_motor_ref_", "qd_motor_ref_") if space == "motor" else ("q_ref_", "qd_ref_")
    for i in range(n):
        cols[f"{prefix}{i + 1}"] = ref_q[:, i]
        cols[f"{vprefix}{i + 1}"] = ref_v[:, i]
    held = [i + 1 for i in range(n) if i != transmission - 1]
    options = {"transmission": transmission, "strategy": strategy, "space": space,
               "held_motors" if space == "motor" else "held_joints": held,
               "speeds_motor": [float(v) for v in speeds], "travel_motor": travel, "accel_motor": accel,
               "q0": q0.tolist(), "note": ("hold the listed motors at their start; drive motor "
                                           f"{transmission} along q_motor_ref_{transmission}") if space == "motor"
               else (f"hold the listed joints at q0; drive joint {transmission} along q_ref_{transmission}")}
    return make_log(cols, device=device.name, rate_hz=rate_hz, seed=None,
                    experiment=f"plan_constant_velocity_{strategy}", options=options)


def run_plan(args) -> int:
    from tendyn.io import write_log

    dev = _load_device(args.device)
    n = dev.n_transmissions
    if n == 0:
        raise UsageError(f"{dev.name} has no tendon transmissions to plan a constant-velocity test for", "device")
    if not 1 <= args.transmission <= n:
        raise UsageError(f"must be 1…{n} (got {args.transmission})", "transmission")
    if args.q0 is not None and len(args.q0) != dev.n_joints:
        raise UsageError(f"{len(args.q0)} values, {dev.name} has {dev.n_joints} joints", "q0")
    log = plan_constant_velocity(dev, args.transmission, args.strategy, args.speeds, args.travel, args.accel,
                                 args.q0, args.rate)
    write_log(log, args.out)
    summary = {"out": str(args.out), "device": dev.name, "samples": log.n_samples,
               "duration_s": float(log.time[-1]), **log.meta["options"]}
    if args.json:
        _print_json(summary)
    else:
        held = summary.get("held_motors", summary.get("held_joints"))
        what = "motors" if "held_motors" in summary else "joints"
        print(f"{args.out}: {log.n_samples} samples, {summary['duration_s']:.1f} s; transmission "
              f"{args.transmission} ({args.strategy}), held {what}: {', '.join(map(str, held))}")
    return 0


# ---- identify-friction ----------------------------------------------------------------------------------

def add_identify_friction_arguments(subparsers) -> argparse.ArgumentParser:
    """``tendyn identify-friction DEVICE LOG... --out FRICTION.json [--gravity …] [--json]``."""
    p = subparsers.add_parser("identify-friction",
                              help="fit C_m = C_m0 sgn(qd_m) + nu qd_m per transmission from constant-velocity logs")
    p.add_argument("device", help="device file (.toml) or bundled twin name")
    p.add_argument("logs", nargs="+", type=conv.existing_file, metavar="LOG",
                   help="constant-velocity logs (.csv/.parquet), one or more per transmission; every "
                        "transmission of the device must be covered")
    p.add_argument("--out", type=_out_path((".json",)), required=True, help="FRICTION.json to write")
    p.add_argument("--gravity", choices=("pairs", "model", "both"), default="pairs",
                   help="gravity removal: forward/backward pairs (S0, default), the device's gravity model, or both")
    p.add_argument("--min-speeds", type=conv.number(2, 1000, integer=True), default=5,
                   help="fewest distinct speeds per direction accepted (default 5)")
    p.add_argument("--json", action="store_true", help="print FRICTION.json on stdout too")
    from tendyn.commands.history import add_record_arguments

    add_record_arguments(p)
    p.set_defaults(func=run_identify_friction)
    return p


def identify_friction(device, logs, gravity: str = "pairs", min_speeds: int = 5, names=None) -> dict:
    """Fit every transmission from ``logs`` (:class:`tendyn.io.Log`), attach the residual-error bounds
    computed from the identified values themselves (decomposed with the default shares) and return the
    FRICTION.json document. Raises UsageError naming the log or transmission when something is missing."""
    from tendyn.ident.decomposition import decompose
    from tendyn.ident.friction import (IdentificationError, TransmissionFriction, log_strategy,
                                       log_transmission, residual_error_bound)
    from tendyn.ident.friction_file import friction_document

    names = names or [f"log {k + 1}" for k in range(len(logs))]
    n = device.n_transmissions
    groups: dict[int, list] = {}
    for name, log in zip(names, logs):
        if log.meta.get("device") not in (device.name, str(getattr(device, "path", ""))):
            raise UsageError(f"{name}: the log is about {log.meta.get('device')!r}, not {device.name!r}")
        t = log_transmission(log)
        if not 1 <= t <= n:
            raise UsageError(f"{name}: transmission {t}, the device has 1…{n}")
        groups.setdefault(t, []).append((name, log))
    missing = [t for t in range(1, n + 1) if t not in groups]
    if missing:
        raise UsageError(f"no constant-velocity log for transmission {', '.join(map(str, missing))} "
                         f"(FRICTION.json needs every transmission 1…{n})")
    fits = []
    for t in range(1, n + 1):
        strategies = {log_strategy(lg) for _, lg in groups[t]}
        if len(strategies) > 1:
            raise UsageError(f"transmission {t}: logs of different strategies "
                             f"({', '.join(sorted(str(s) for s in strategies))}); give one strategy per transmission")
        est = TransmissionFriction(t, gravity=gravity, device=device if gravity != "pairs" else None,
                                   min_speeds=min_speeds)
        try:
            est.fit([lg for _, lg in groups[t]])
        except IdentificationError as exc:
            raise UsageError(f"{', '.join(nm for nm, _ in groups[t])}: {exc}") from None
        fits.append(est.result_)
    c0 = np.array([f.coulomb_motor for f in fits])
    nu = np.array([f.viscous_motor for f in fits])
    dec = decompose(device, np.maximum(c0, 0.0), np.maximum(nu, 0.0))
    arr = device.routing_arrays()
    for f in fits:
        if f.strategy in ("S1", "S2"):
            f.residual_bound = residual_error_bound(arr["K"], arr["motor_radius"], f.transmission - 1, f.strategy,
                                                    dec.tau0_branch, dec.nu_branch, max(f.speeds_motor))
    return friction_document(device.name, fits)


def run_identify_friction(args) -> int:
    from tendyn.ident.friction_file import write_friction, FORMAT
    from tendyn.io import read_log

    from tendyn.commands.history import check_record, record_result

    dev = _load_device(args.device)
    if dev.n_transmissions == 0:
        raise UsageError(f"{dev.name} has no tendon transmissions", "device")
    check_record(args)
    logs = [read_log(p) for p in args.logs]
    doc = identify_friction(dev, logs, args.gravity, args.min_speeds, names=[str(p) for p in args.logs])
    write_friction(doc, args.out)
    record_result(args, dev, "identify-friction", doc, source=", ".join(str(p) for p in args.logs))
    if args.json:
        _print_json(doc)
    else:
        print(f"{dev.name}: friction identified ({FORMAT}) -> {args.out}")
        print(friction_table(doc))
    return 0


def friction_table(doc) -> str:
    """The paper-like table of a FRICTION.json document."""
    lines = [f"{'tr':<4}{'strategy':<10}{'C_m0 [N·m]':>12}{'σ':>11}{'%σ':>7}{'ν [N·m·s/rad]':>15}{'σ':>11}"
             f"{'%σ':>7}{'bound [N·m]':>13}"]
    for f in doc["fits"]:
        b = f.get("residual_bound")
        pct = lambda x: float("nan") if x is None else x   # noqa: E731
        lines.append(f"{f['transmission']:<4}{str(f.get('strategy')):<10}{f['coulomb_motor']:>12.5g}"
                     f"{f['coulomb_motor_std']:>11.3g}{pct(f.get('coulomb_motor_rel_std_pct')):>7.2f}"
                     f"{f['viscous_motor']:>15.5g}{f['viscous_motor_std']:>11.3g}"
                     f"{pct(f.get('viscous_motor_rel_std_pct')):>7.2f}{'—' if b is None else f'{b:.3g}':>13}")
    return "\n".join(lines)


# ---- decompose ---------------------------------------------------------------------------------------

def add_decompose_arguments(subparsers) -> argparse.ArgumentParser:
    """``tendyn decompose DEVICE FRICTION.json [--shares FILE] [--json]``."""
    p = subparsers.add_parser("decompose", help="per-branch friction from the global values (S0 eqs. 18–21)")
    p.add_argument("device", help="device file (.toml) or bundled twin name")
    p.add_argument("friction", type=conv.existing_file, metavar="FRICTION.json", help="identified global friction")
    p.add_argument("--shares", type=conv.existing_file, default=None,
                   help="loss shares p, p' per branch (JSON, tendyn.shares/1); default: from the device's "
                        "construction (pulleys and bearings per link)")
    p.add_argument("--json", action="store_true", help="print the decomposition as JSON on stdout")
    p.set_defaults(func=run_decompose)
    return p


def run_decompose(args) -> int:
    from tendyn.ident.decomposition import SharesError, decompose, read_shares
    from tendyn.ident.friction_file import FrictionFileError, read_friction

    dev = _load_device(args.device)
    if dev.n_transmissions == 0:
        raise UsageError(f"{dev.name} has no tendon transmissions", "device")
    try:
        doc = read_friction(args.friction, device=dev)
        p = pp = None
        if args.shares is not None:
            p, pp = read_shares(args.shares, dev)
    except (FrictionFileError, SharesError) as exc:
        raise UsageError(str(exc)) from None
    dec = decompose(dev, doc["coulomb_motor"], doc["viscous_motor"], p, pp)
    if args.json:
        _print_json(dec.to_dict())
    else:
        print(dec.table())
    return 0


def register(subparsers) -> None:
    """Register the three commands (found by :func:`tendyn.cli.build_parser`)."""
    add_plan_arguments(subparsers)
    add_identify_friction_arguments(subparsers)
    add_decompose_arguments(subparsers)


if __name__ == "__main__":   # a stand-alone entry until cli.py wires the commands in
    parser = argparse.ArgumentParser(prog="tendyn")
    register(parser.add_subparsers(dest="command", required=True))
    a = parser.parse_args()
    try:
        sys.exit(a.func(a))
    except UsageError as e:
        print(f"tendyn: error: {e}", file=sys.stderr)
        sys.exit(2)
